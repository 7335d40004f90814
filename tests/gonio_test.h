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

/* The shared data folder, or skip the calling test with a visible message. */
static inline const char *gonio_test_shared_or_skip(void)
{
    const char *dir = gonio_shared_dir();
    if (!dir) {
        fprintf(stderr, "SKIPPED: shared data folder not found (set GONIO_SHARED or put "
                        "../shared beside the repository)\n");
        skip();
    }
    return dir;
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
