/* Helpers shared by gonio's cmocka tests. cmocka 1.1.5 (Debian 12) compares
 * floats in single precision only, so doubles get their own checks. */
#ifndef GONIO_TEST_H
#define GONIO_TEST_H

#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <signal.h>
#include <sys/prctl.h>
#include <sys/types.h>
#include <unistd.h>

#include <cmocka.h>
#include <valgrind/valgrind.h>

#include "common/paths.h"

/* |a - b| <= tol, with both values printed on failure. */
#define assert_close(a, b, tol)                                                         \
    do {                                                                                \
        double a_ = (a), b_ = (b), t_ = (tol);                                          \
        if (!(fabs(a_ - b_) <= t_)) {                                                   \
            print_error("%s = %.17g, expected %s = %.17g within %g\n", #a, a_, #b, b_, t_); \
            fail();                                                                     \
        }                                                                               \
    } while (0)

/* |a - b| <= rel * |b| */
#define assert_rel_close(a, b, rel)                                                     \
    do {                                                                                \
        double a_ = (a), b_ = (b), r_ = (rel);                                          \
        if (!(fabs(a_ - b_) <= r_ * fabs(b_))) {                                        \
            print_error("%s = %.17g, expected %s = %.17g within %g relative\n", #a, a_, #b, \
                        b_, r_);                                                        \
            fail();                                                                     \
        }                                                                               \
    } while (0)

/* Skips that show. cmocka's skip() only marks the test, and the group still
 * exits 0, which ctest reports as Passed though nothing ran. Here skip()
 * counts, and cmocka_run_group_tests returns 77 (ctest's SKIP_RETURN_CODE,
 * set for every test in cmake/GonioTest.cmake) when a test skipped and none
 * failed: a partly skipped group is not a pass either. The "SKIPPED: why"
 * lines are what scripts/ctest-skips.sh lists after make check. */
static int gonio_test_n_skipped;

#undef skip
#define skip() (gonio_test_n_skipped++, _skip(__FILE__, __LINE__))

/* Skip the calling test, printing "SKIPPED: " and the reason (printf). */
#define gonio_test_skip(...)                      \
    do {                                          \
        fprintf(stderr, "SKIPPED: " __VA_ARGS__); \
        fputc('\n', stderr);                      \
        skip();                                   \
    } while (0)

static inline int gonio_test_exit(int failed)
{
    if (failed || !gonio_test_n_skipped)
        return failed;
    fprintf(stderr, "%d test(s) skipped, none failed: exit 77 (reported as skipped)\n",
            gonio_test_n_skipped);
    return 77;
}

#undef cmocka_run_group_tests
#define cmocka_run_group_tests(group, setup, teardown)                                       \
    gonio_test_exit(_cmocka_run_group_tests(#group, group, sizeof(group) / sizeof((group)[0]), \
                                            setup, teardown))

/* The shared data folder, or skip the calling test with a visible message.
 * With GONIO_REQUIRE_SHARED set (CI, which has the data: .ci/run) a missing
 * folder fails the test instead, so that no data test is skipped unseen. */
static inline const char *gonio_test_shared_or_skip(void)
{
    const char *dir = gonio_shared_dir();
    if (!dir) {
        const char *req = getenv("GONIO_REQUIRE_SHARED");
        if (req && *req && strcmp(req, "0") != 0) {
            print_error("shared data folder not found, and GONIO_REQUIRE_SHARED is set\n");
            fail();
        }
        gonio_test_skip("shared data folder not found (set GONIO_SHARED or put ../shared "
                        "beside the repository)");
    }
    return dir;
}

/* fork() for a test's helper process: the child gets SIGKILL when the test
 * process dies (PR_SET_PDEATHSIG), so a test that crashes or hits its ctest
 * TIMEOUT leaves no helper behind holding a lock, a port or ctest's output
 * pipe. A child that changes its credentials loses the setting (Linux clears
 * it) and calls gonio_test_die_with_parent() again after setuid. */
static inline int gonio_test_die_with_parent(pid_t parent)
{
    if (prctl(PR_SET_PDEATHSIG, SIGKILL) != 0)
        return -1;
    /* The parent may have died before the prctl: then nobody is left to
     * signal us. */
    return getppid() == parent ? 0 : -1;
}

static inline pid_t gonio_test_fork(void)
{
    pid_t parent = getpid();
    pid_t pid = fork();
    if (pid == 0 && gonio_test_die_with_parent(parent) != 0)
        _exit(127);
    return pid;
}

/* A test group's scratch folder: made fresh in setup as
 * /tmp/gonio-TAG-XXXXXX, removed with everything in it in teardown. */
static inline int gonio_test_dir_make(char *dir, size_t size, const char *tag)
{
    snprintf(dir, size, "/tmp/gonio-%s-XXXXXX", tag);
    return mkdtemp(dir) ? 0 : -1;
}

static inline int gonio_test_dir_remove(const char *dir)
{
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd);
}

/* Writes text to path (a test's input file), failing the test if it cannot. */
static inline void gonio_test_write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    assert_true(fputs(text, f) >= 0);
    assert_int_equal(fclose(f), 0);
}

/* Runs a gonio subcommand (cmd_fit, cmd_plan, ...) in process with its
 * stdout and stderr sent to files; returns its status and the two texts
 * (malloc'd), so a test checks what the operator would read. */
static inline int gonio_test_run_cli(int (*cmd)(int, char **), char **argv, int argc,
                                     char **out, char **errtext)
{
    char opath[] = "/tmp/gonio-cmdoutXXXXXX", epath[] = "/tmp/gonio-cmderrXXXXXX";
    int ofd = mkstemp(opath), efd = mkstemp(epath);
    assert_true(ofd >= 0 && efd >= 0);
    fflush(stdout);
    fflush(stderr);
    int save_out = dup(1), save_err = dup(2);
    dup2(ofd, 1);
    dup2(efd, 2);
    int status = cmd(argc, argv);
    fflush(stdout);
    fflush(stderr);
    dup2(save_out, 1);
    dup2(save_err, 2);
    close(save_out);
    close(save_err);
    char **texts[2] = {out, errtext};
    int fds[2] = {ofd, efd};
    for (int k = 0; k < 2; k++) {
        off_t len = lseek(fds[k], 0, SEEK_END);
        *texts[k] = calloc((size_t)len + 1, 1);
        assert_int_equal(pread(fds[k], *texts[k], (size_t)len, 0), len);
        close(fds[k]);
    }
    unlink(opath);
    unlink(epath);
    return status;
}

/* Nonzero when the test should run at its small size: under valgrind
 * (make check-valgrind; memcheck costs some 50x in CPU) or with
 * GONIO_TEST_SMALL=1 (to run the small size natively or under ASan).
 * A test's small size runs the same code on less (fewer materials, a
 * coarser plan, a sample of a domain) and asserts real values all the
 * same; the full size runs natively and under ASan in make check and make
 * check-asan. docs/testing-memory.md lists what each test shrinks. */
static inline int gonio_test_small(void)
{
    static int small = -1;
    if (small < 0) {
        const char *e = getenv("GONIO_TEST_SMALL");
        small = RUNNING_ON_VALGRIND || (e && *e && strcmp(e, "0") != 0);
        if (small)
            fprintf(stderr, "gonio_test_small: small size (%s)\n",
                    RUNNING_ON_VALGRIND ? "under valgrind" : "GONIO_TEST_SMALL");
    }
    return small;
}

/* capture_config.assess_nodes for a test's captures: their truth errors
 * on all ~924k nodes of the full domain (0), or at the small size on a
 * seeded sample of 20000 of them, which memcheck evaluates in seconds
 * instead of a minute per capture. */
static inline size_t gonio_test_assess_nodes(void)
{
    return gonio_test_small() ? 20000 : 0;
}

/* The factor Modbus timeouts, and the delays that provoke them, stretch
 * by: 1 natively, 4 under valgrind, where the test's side of an exchange
 * runs some 20-50x slower and would miss a deadline of a few tens of
 * milliseconds that it meets natively. */
static inline double gonio_test_time_factor(void)
{
    return RUNNING_ON_VALGRIND ? 4.0 : 1.0;
}

#endif
