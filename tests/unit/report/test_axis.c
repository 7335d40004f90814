/* Axis ranges and ticks: known ranges give known ticks and labels. */
#include "tests/gonio_test.h"

#include <string.h>

#include "report/axis.h"

static void assert_ticks(const struct plot_axis *a, const double *want, size_t n)
{
    assert_int_equal(a->n_ticks, n);
    for (size_t i = 0; i < n; i++)
        assert_close(a->ticks[i], want[i], 1e-9 * (fabs(want[i]) + 1e-300));
}

static void linear_rounds_out_to_nice_steps(void **state)
{
    (void)state;
    struct plot_axis a;
    assert_int_equal(plot_axis_fit(&a, PLOT_LINEAR, 0.013, 0.87, 6), 0);
    /* range 0.857 / 5 = 0.17 -> step 0.2: 0 .. 1 */
    const double want[] = {0, 0.2, 0.4, 0.6, 0.8, 1.0};
    assert_ticks(&a, want, 6);
    assert_close(a.lo, 0, 1e-12);
    assert_close(a.hi, 1.0, 1e-12);
    assert_string_equal(a.labels[0], "0.0");
    assert_string_equal(a.labels[3], "0.6");
    assert_int_equal(plot_axis_fit(&a, PLOT_LINEAR, -37, 112, 8), 0);
    /* 149 / 7 = 21.3 -> 50: -50 .. 150 */
    const double want2[] = {-50, 0, 50, 100, 150};
    assert_ticks(&a, want2, 5);
    assert_string_equal(a.labels[0], "-50");
    assert_string_equal(a.labels[1], "0");
}

static void linear_respects_max_ticks(void **state)
{
    (void)state;
    struct plot_axis a;
    /* 0.9 .. 10.1 with 4 ticks: step 5 would need 0,5,10,15 -> 4 ticks. */
    for (int max = 3; max <= 12; max++) {
        assert_int_equal(plot_axis_fit(&a, PLOT_LINEAR, 0.9, 10.1, max), 0);
        assert_true(a.n_ticks <= (size_t)max);
        assert_true(a.n_ticks >= 2);
        assert_true(a.lo <= 0.9 && a.hi >= 10.1);
        assert_close(a.ticks[0], a.lo, 1e-12);
        assert_close(a.ticks[a.n_ticks - 1], a.hi, 1e-12);
    }
}

static void fixed_keeps_the_range(void **state)
{
    (void)state;
    struct plot_axis a;
    assert_int_equal(plot_axis_fixed(&a, PLOT_LINEAR, -80, 80, 9), 0);
    const double want[] = {-80, -60, -40, -20, 0, 20, 40, 60, 80};
    assert_ticks(&a, want, 9);
    assert_close(a.lo, -80, 0);
    assert_close(a.hi, 80, 0);
    assert_int_equal(plot_axis_fixed(&a, PLOT_LINEAR, -75, 75, 9), 0);
    assert_close(a.lo, -75, 0);
    assert_close(a.ticks[0], -60, 1e-12); /* step 20, inside the range */
}

static void log_decades_and_labels(void **state)
{
    (void)state;
    struct plot_axis a;
    assert_int_equal(plot_axis_fit(&a, PLOT_LOG, 0.0123, 456, 7), 0);
    const double want[] = {0.01, 0.1, 1, 10, 100, 1000};
    assert_ticks(&a, want, 6);
    assert_string_equal(a.labels[0], "0.01");
    assert_string_equal(a.labels[5], "1000");
    assert_int_equal(a.n_minor, 0); /* five decades: no 2..9 minor ticks */
    assert_int_equal(plot_axis_fit(&a, PLOT_LOG, 3e-6, 2e-4, 7), 0);
    const double want2[] = {1e-6, 1e-5, 1e-4, 1e-3};
    assert_ticks(&a, want2, 4);
    assert_string_equal(a.labels[0], "10⁻⁶");
    assert_string_equal(a.labels[2], "10⁻⁴");
    assert_int_equal(a.n_minor, 3 * 8); /* 2..9 in each of three decades */
    /* Twelve decades with at most 5 labels: every third decade. */
    assert_int_equal(plot_axis_fit(&a, PLOT_LOG, 1e-6, 1e6, 5), 0);
    assert_true(a.n_ticks <= 5);
    assert_close(a.ticks[1] / a.ticks[0], 1e3, 1e-6);
    assert_string_equal(a.labels[a.n_ticks - 1], "10⁶");
}

static void log_within_one_decade(void **state)
{
    (void)state;
    struct plot_axis a;
    assert_int_equal(plot_axis_fit(&a, PLOT_LOG, 0.021, 0.085, 6), 0);
    const double want[] = {0.01, 0.02, 0.05, 0.1};
    assert_ticks(&a, want, 4);
    assert_string_equal(a.labels[1], "0.02");
    /* lo == hi widens instead of failing */
    assert_int_equal(plot_axis_fit(&a, PLOT_LOG, 5, 5, 6), 0);
    assert_true(a.lo < 5 && a.hi > 5);
}

static void duration_in_human_units(void **state)
{
    (void)state;
    struct plot_axis a;
    /* DS4 (about 10 s) to oop200k (days) */
    assert_int_equal(plot_axis_fit(&a, PLOT_DURATION, 12, 3.1e5, 8), 0);
    assert_close(a.lo, 10, 0);
    assert_close(a.hi, 864000, 0);
    const char *want[] = {"10 s", "1 min", "10 min", "1 h", "1 d", "10 d"};
    assert_int_equal(a.n_ticks, 6);
    for (size_t i = 0; i < 6; i++)
        assert_string_equal(a.labels[i], want[i]);
    /* A narrow range gets the fine units too, at least three labels. */
    assert_int_equal(plot_axis_fit(&a, PLOT_DURATION, 70, 400, 8), 0);
    assert_true(a.n_ticks >= 3);
    assert_string_equal(a.labels[0], "1 min");
    assert_string_equal(a.labels[a.n_ticks - 1], "10 min");
}

static void bad_ranges_are_refused(void **state)
{
    (void)state;
    struct plot_axis a;
    assert_int_equal(plot_axis_fit(&a, PLOT_LOG, 0, 1, 5), -1);
    assert_int_equal(plot_axis_fit(&a, PLOT_LOG, -1, 1, 5), -1);
    assert_int_equal(plot_axis_fit(&a, PLOT_LINEAR, 2, 1, 5), -1);
    assert_int_equal(plot_axis_fit(&a, PLOT_LINEAR, NAN, 1, 5), -1);
    assert_int_equal(plot_axis_fit(&a, PLOT_LINEAR, 0, INFINITY, 5), -1);
}

static void frac_maps_the_range(void **state)
{
    (void)state;
    struct plot_axis a;
    plot_axis_fit(&a, PLOT_LOG, 1, 100, 5);
    assert_close(plot_axis_frac(&a, 1), 0, 1e-12);
    assert_close(plot_axis_frac(&a, 10), 0.5, 1e-12);
    assert_close(plot_axis_frac(&a, 100), 1, 1e-12);
    assert_true(isnan(plot_axis_frac(&a, 0)));
    plot_axis_fixed(&a, PLOT_LINEAR, -80, 80, 9);
    assert_close(plot_axis_frac(&a, 0), 0.5, 1e-12);
    assert_close(plot_axis_frac(&a, 40), 0.75, 1e-12);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(linear_rounds_out_to_nice_steps),
        cmocka_unit_test(linear_respects_max_ticks),
        cmocka_unit_test(fixed_keeps_the_range),
        cmocka_unit_test(log_decades_and_labels),
        cmocka_unit_test(log_within_one_decade),
        cmocka_unit_test(duration_in_human_units),
        cmocka_unit_test(bad_ranges_are_refused),
        cmocka_unit_test(frac_maps_the_range),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
