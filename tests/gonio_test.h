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

#include <cmocka.h>

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

#endif
