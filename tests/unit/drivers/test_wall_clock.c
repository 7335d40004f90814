/* The wall clock of hardware whose devices keep no rig time (goniod with
 * the USB spectrometer): it follows the monotonic clock, and a settle
 * asks the host's cancel check, so that an abort or SIGTERM does not wait
 * out a long settle. */
#include <errno.h>

#include "common/clock.h"
#include "drivers/drivers.h"
#include "tests/gonio_test.h"

static double stop_at;

static int stop_requested(void *user)
{
    (void)user;
    return gonio_monotonic_s() >= stop_at;
}

static void test_sleep_runs_its_length(void **state)
{
    (void)state;
    stop_at = INFINITY;
    drv_clock *c = drv_clock_new_wall(stop_requested, NULL);
    assert_non_null(c);
    double t0 = drv_clock_now(c);
    assert_int_equal(drv_clock_sleep(c, 0.2), 0);
    assert_true(drv_clock_now(c) - t0 >= 0.2);
    drv_clock_free(c);
}

static void test_sleep_ends_on_cancel(void **state)
{
    (void)state;
    drv_clock *c = drv_clock_new_wall(stop_requested, NULL);
    assert_non_null(c);
    double t0 = gonio_monotonic_s();
    stop_at = t0 + 0.1;
    assert_int_equal(drv_clock_sleep(c, 30), -ECANCELED);
    double took = gonio_monotonic_s() - t0;
    /* the request, then at most one 50 ms slice (stretched under valgrind) */
    assert_true(took >= 0.1 && took < 0.1 + 1.0 * gonio_test_time_factor());
    drv_clock_free(c);
}

static void test_no_check_no_cancel(void **state)
{
    (void)state;
    drv_clock *c = drv_clock_new_wall(NULL, NULL);
    assert_non_null(c);
    assert_int_equal(drv_clock_sleep(c, 0.06), 0);
    drv_clock_free(c);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sleep_runs_its_length),
        cmocka_unit_test(test_sleep_ends_on_cancel),
        cmocka_unit_test(test_no_check_no_cancel),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
