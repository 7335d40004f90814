/* A journal that cannot be written says why: on a full disk write() first
 * stops short (errno untouched), and only the next write() says ENOSPC. The
 * append must report the cause ("No space left on device", not a stale or
 * invented errno), leave no partial record behind, and go on once there is
 * room. Three ways to fill the disk: a write() interposed here (everywhere),
 * the file size limit (RLIMIT_FSIZE, everywhere), and a real 16 KiB tmpfs
 * (root with mount rights in a private mount namespace, else skipped). */
#define _GNU_SOURCE /* syscall, unshare */
#include <errno.h>
#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include "journal/journal.h"
#include "tests/gonio_test.h"

static char dir[256];

/* The interposed disk: armed on one fd, the next write() stores half its
 * bytes and returns that count, the ones after fail with ENOSPC (what the
 * kernel does when the disk fills mid-write). The engine's static
 * libraries bind to this definition (as test_durability's fsync). */
static int full_fd = -1, full_after_short;

ssize_t write(int fd, const void *buf, size_t len)
{
    if (fd == full_fd && full_after_short) {
        errno = ENOSPC;
        return -1;
    }
    if (fd == full_fd) {
        full_after_short = 1;
        len /= 2;
    }
    return (ssize_t)syscall(SYS_write, fd, buf, len);
}

static int setup(void **state)
{
    (void)state;
    return gonio_test_dir_make(dir, sizeof dir, "nospace");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

static struct journal_sample make(int i)
{
    struct journal_sample s = {0};
    s.point = i;
    s.theta_i = 10.0 + i / 7.0;
    s.theta_r = -30.0 + i / 3.0;
    s.theta_o = fabs(s.theta_r);
    s.s = s.theta_i;
    s.a = s.theta_i + s.theta_r;
    s.rgb[0] = s.rgb[1] = s.rgb[2] = 1.0 / (i + 7);
    s.integration_s = 0.05;
    s.rig_time_s = 1.25 * (i + 1);
    return s;
}

static off_t size_of(const char *path)
{
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    return st.st_size;
}

/* The journal's fd: the highest open descriptor just after journal_open. */
static int last_fd(void)
{
    int fd = dup(0);
    close(fd);
    return fd - 1;
}

static void test_short_write_then_enospc_names_the_disk(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/full.csv", dir);
    struct journal_sample *old = NULL;
    size_t n = 0;
    struct gonio_err err = {0};
    journal *j = journal_open(path, &old, &n, &err);
    assert_non_null(j);
    struct journal_sample a = make(0), b = make(1);
    assert_int_equal(journal_append(j, &a, &err), 0);
    off_t whole = size_of(path);
    full_fd = last_fd();
    full_after_short = 0;
    assert_int_equal(journal_append(j, &b, &err), -ENOSPC);
    full_fd = -1;
    if (!strstr(err.msg, "cannot write sample: No space left on device"))
        fail_msg("got '%s'", err.msg);
    assert_int_equal(size_of(path), whole); /* the half record is gone */
    assert_int_equal(journal_append(j, &b, &err), 0); /* room again: it goes on */
    journal_close(j);
    struct journal_sample *s;
    assert_int_equal(journal_read(path, &s, &n, &err), 0);
    assert_int_equal(n, 2);
    free(s);
    free(old);
}

/* The file size limit stops a write() short the same way; the cause is then
 * EFBIG, and the append names it. */
static void test_file_size_limit_names_its_cause(void **state)
{
    (void)state;
    char path[300];
    snprintf(path, sizeof path, "%s/limit.csv", dir);
    struct journal_sample *old = NULL;
    size_t n = 0;
    struct gonio_err err = {0};
    journal *j = journal_open(path, &old, &n, &err);
    assert_non_null(j);
    struct journal_sample a = make(0), b = make(1);
    assert_int_equal(journal_append(j, &a, &err), 0);
    off_t whole = size_of(path);
    struct rlimit was;
    assert_int_equal(getrlimit(RLIMIT_FSIZE, &was), 0);
    if (was.rlim_cur != RLIM_INFINITY && was.rlim_cur < (rlim_t)whole + 300) {
        journal_close(j);
        free(old);
        gonio_test_skip("RLIMIT_FSIZE already below the test's journal");
        return;
    }
    void (*prev)(int) = signal(SIGXFSZ, SIG_IGN);
    struct rlimit lim = {.rlim_cur = (rlim_t)whole + 40, .rlim_max = was.rlim_max};
    assert_int_equal(setrlimit(RLIMIT_FSIZE, &lim), 0);
    int rc = journal_append(j, &b, &err);
    assert_int_equal(setrlimit(RLIMIT_FSIZE, &was), 0);
    signal(SIGXFSZ, prev);
    assert_int_equal(rc, -EFBIG);
    if (!strstr(err.msg, "cannot write sample: File too large"))
        fail_msg("got '%s'", err.msg);
    assert_int_equal(size_of(path), whole);
    assert_int_equal(journal_append(j, &b, &err), 0);
    journal_close(j);
    free(old);
}

/* In the child: a 16 KiB tmpfs filled up. Exit 0 when the append reports
 * ENOSPC by name and leaves no partial record, 77 when no tmpfs can be
 * mounted here, 1 (with a message) otherwise. */
static int full_tmpfs_child(void)
{
    char mnt[300], path[320], filler[320];
    snprintf(mnt, sizeof mnt, "%s/tmpfs", dir);
    if (mkdir(mnt, 0700) != 0 || unshare(CLONE_NEWNS) != 0 ||
        /* "none": the kernel ignores both names here, memcheck wants them. */
        mount("none", "/", "none", MS_REC | MS_PRIVATE, NULL) != 0 ||
        mount("gonio-test", mnt, "tmpfs", 0, "size=16k") != 0) {
        fprintf(stderr, "SKIPPED: cannot mount a tmpfs here: %s\n", strerror(errno));
        return 77;
    }
    snprintf(path, sizeof path, "%s/samples.csv", mnt);
    snprintf(filler, sizeof filler, "%s/filler", mnt);
    struct journal_sample *old = NULL;
    size_t n = 0;
    struct gonio_err err = {0};
    journal *j = journal_open(path, &old, &n, &err);
    int i = 0, rc = 1;
    /* Every free page taken; the journal's last page has room for a few
     * records, then one stops short at its end. */
    int fd = open(filler, O_WRONLY | O_CREAT, 0600);
    static const char page[4096];
    while (fd >= 0 && syscall(SYS_write, fd, page, sizeof page) > 0)
        ;
    struct stat before = {0}, after = {0};
    int got = 0;
    while (j && got == 0 && i < 60) {
        struct journal_sample s = make(i++);
        stat(path, &before);
        got = journal_append(j, &s, &err);
        stat(path, &after);
    }
    if (!j)
        fprintf(stderr, "open: %s\n", err.msg);
    else if (got != -ENOSPC || !strstr(err.msg, "cannot write sample: No space left on device"))
        fprintf(stderr, "append on a full tmpfs: %d '%s' (%d records)\n", got, err.msg, i);
    else if (after.st_size != before.st_size)
        fprintf(stderr, "a partial record left: %lld -> %lld bytes\n",
                (long long)before.st_size, (long long)after.st_size);
    else
        rc = 0;
    journal_close(j);
    close(fd);
    umount(mnt);
    return rc;
}

static void test_full_tmpfs(void **state)
{
    (void)state;
    pid_t pid = gonio_test_fork();
    assert_true(pid >= 0);
    if (pid == 0)
        _exit(full_tmpfs_child());
    int st;
    assert_int_equal(waitpid(pid, &st, 0), pid);
    assert_true(WIFEXITED(st));
    if (WEXITSTATUS(st) == 77) {
        gonio_test_skip("no tmpfs to fill (needs root and a private mount namespace)");
        return;
    }
    assert_int_equal(WEXITSTATUS(st), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_short_write_then_enospc_names_the_disk),
        cmocka_unit_test(test_file_size_limit_names_its_cause),
        cmocka_unit_test(test_full_tmpfs),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
