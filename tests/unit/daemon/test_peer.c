/* Who may use the control socket (daemon/peer.h): the rule on its own, and
 * the credentials the kernel reports, for this process and (as root) for a
 * child that became another user with supplementary groups. */
#define _GNU_SOURCE /* setgroups */
#include <grp.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include "daemon/peer.h"
#include "tests/gonio_test.h"

static struct peer_cred cred(uid_t uid, gid_t gid, const gid_t *groups, size_t n)
{
    struct peer_cred pc = {.pid = 1, .uid = uid, .gid = gid, .n_groups = n};
    if (n) /* groups may be NULL then; memcpy must not see NULL */
        memcpy(pc.groups, groups, n * sizeof *groups);
    return pc;
}

static void test_rule(void **state)
{
    (void)state;
    const uid_t self = 990;
    const gid_t gonio = 991;
    const gid_t other[] = {24, 25, 100}, member[] = {24, 991, 100};
    struct peer_cred pc;
    pc = cred(0, 0, NULL, 0);
    assert_true(peer_allowed(&pc, self, gonio)); /* root */
    pc = cred(self, 5000, NULL, 0);
    assert_true(peer_allowed(&pc, self, gonio)); /* goniod's own user */
    pc = cred(1000, gonio, other, 3);
    assert_true(peer_allowed(&pc, self, gonio)); /* primary group */
    pc = cred(1000, 1000, member, 3);
    assert_true(peer_allowed(&pc, self, gonio)); /* supplementary group */
    pc = cred(1000, 1000, other, 3);
    assert_false(peer_allowed(&pc, self, gonio));
    pc = cred(1000, 1000, NULL, 0);
    assert_false(peer_allowed(&pc, self, gonio));
    /* n_groups bounds what is looked at: a stale entry beyond it is not a
     * membership. */
    pc = cred(1000, 1000, member, 1);
    assert_false(peer_allowed(&pc, self, gonio));
    pc = cred(self + 1, 1000, NULL, 0);
    assert_false(peer_allowed(&pc, self, gonio));
}

static void test_own_credentials(void **state)
{
    (void)state;
    int sv[2];
    assert_int_equal(socketpair(AF_UNIX, SOCK_STREAM, 0, sv), 0);
    struct peer_cred pc;
    assert_int_equal(peer_cred_get(sv[0], &pc), 0);
    assert_int_equal(pc.pid, getpid());
    assert_int_equal(pc.uid, geteuid());
    assert_int_equal(pc.gid, getegid());
    gid_t mine[PEER_MAX_GROUPS];
    int n = getgroups(PEER_MAX_GROUPS, mine);
    assert_true(n >= 0);
    assert_int_equal(pc.n_groups, (size_t)n);
    for (int i = 0; i < n; i++)
        assert_int_equal(pc.groups[i], mine[i]);
    close(sv[0]);
    close(sv[1]);
    /* Not a socket: an error, not made-up credentials. */
    int fd[2];
    assert_int_equal(pipe(fd), 0);
    assert_true(peer_cred_get(fd[0], &pc) < 0);
    close(fd[0]);
    close(fd[1]);
}

/* A child drops to uid/gid 65534 with supplementary groups {4242, 4343} and
 * connects; the parent reads what the kernel says about it. */
static void test_other_user(void **state)
{
    (void)state;
    if (geteuid() != 0) {
        gonio_test_skip("test_other_user: needs root to become another user");
    }
    int status;
    /* A listening socket, and a child that connects as 65534. */
    int lfd = socket(AF_UNIX, SOCK_STREAM, 0);
    assert_true(lfd >= 0);
    struct sockaddr_un sa = {.sun_family = AF_UNIX};
    /* Abstract address: no file, no permissions in the way. */
    snprintf(sa.sun_path + 1, sizeof sa.sun_path - 1, "gonio-test-peer-%d", (int)getpid());
    socklen_t len = (socklen_t)(sizeof sa.sun_family + 1 + strlen(sa.sun_path + 1));
    assert_int_equal(bind(lfd, (struct sockaddr *)&sa, len), 0);
    assert_int_equal(listen(lfd, 1), 0);
    pid_t parent = getpid();
    pid_t child = gonio_test_fork();
    assert_true(child >= 0);
    if (child == 0) {
        const gid_t groups[] = {4242, 4343};
        if (setgroups(2, groups) || setgid(65534) || setuid(65534))
            _exit(2);
        if (gonio_test_die_with_parent(parent) != 0)
            _exit(4);
        int fd = socket(AF_UNIX, SOCK_STREAM, 0);
        if (fd < 0 || connect(fd, (struct sockaddr *)&sa, len) < 0)
            _exit(3);
        char b;
        (void)!read(fd, &b, 1); /* wait until the parent has looked */
        _exit(0);
    }
    int cfd = accept(lfd, NULL, NULL);
    assert_true(cfd >= 0);
    struct peer_cred pc;
    assert_int_equal(peer_cred_get(cfd, &pc), 0);
    close(cfd);
    close(lfd);
    assert_int_equal(waitpid(child, &status, 0), child);
    assert_true(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    assert_int_equal(pc.pid, child);
    assert_int_equal(pc.uid, 65534);
    assert_int_equal(pc.gid, 65534);
    assert_int_equal(pc.n_groups, 2);
    assert_true(peer_allowed(&pc, 990, 4343));
    assert_false(peer_allowed(&pc, 990, 4444));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rule),
        cmocka_unit_test(test_own_credentials),
        cmocka_unit_test(test_other_user),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
