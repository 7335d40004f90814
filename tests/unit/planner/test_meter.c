/* planner/meter.h: a point's integration is the one measured at the point
 * observed nearest it (as measured, never below the rig's fixed one, when
 * the host expects nothing; scaling the expectation where it has one), and
 * the host's expectation, or the fixed integration, before any. */
#include "tests/gonio_test.h"

#include <math.h>

#include "planner/meter.h"
#include "planner/planner.h"

static struct rig_profile rig;
static struct plan *ds3;

static int setup(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    if (rig_profile_load("default", &rig, &err) < 0 || plan_load("ds3", &rig, &ds3, &err) <= 0)
        return -1;
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    plan_free(ds3);
    return 0;
}

/* The plan's points with the smallest and the largest theta_i: far apart. */
static void extremes(size_t *lo, size_t *hi)
{
    *lo = *hi = 0;
    for (size_t i = 1; i < plan_count(ds3); i++) {
        if (plan_point(ds3, i)->theta_i < plan_point(ds3, *lo)->theta_i)
            *lo = i;
        if (plan_point(ds3, i)->theta_i > plan_point(ds3, *hi)->theta_i)
            *hi = i;
    }
}

/* The point other than `from` with the closest theta_i and theta_r. */
static size_t neighbour(size_t from)
{
    size_t best = from == 0 ? 1 : 0;
    double bd = INFINITY;
    const struct plan_point *f = plan_point(ds3, from);
    for (size_t i = 0; i < plan_count(ds3); i++) {
        const struct plan_point *p = plan_point(ds3, i);
        double d = hypot(p->theta_i - f->theta_i, p->theta_r - f->theta_r);
        if (i != from && d < bd) {
            bd = d;
            best = i;
        }
    }
    return best;
}

static void test_nearest_measured(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    plan_meter *m = plan_meter_new(ds3, &rig, NULL, &err);
    assert_non_null(m);
    size_t lo, hi;
    extremes(&lo, &hi);
    size_t nlo = neighbour(lo), nhi = neighbour(hi);
    /* before any measurement: the rig's fixed integration */
    assert_close(plan_meter_integration(m, nlo), rig.integration_s, 0);
    assert_int_equal(plan_meter_nearest(m, nlo), -1);
    plan_meter_observe(m, lo, 1.5);
    assert_close(plan_meter_integration(m, nhi), 1.5, 0); /* the only one measured */
    plan_meter_observe(m, hi, 3.0);
    assert_int_equal(plan_meter_nearest(m, nlo), (long)lo);
    assert_int_equal(plan_meter_nearest(m, nhi), (long)hi);
    assert_close(plan_meter_integration(m, nlo), 1.5, 0);
    assert_close(plan_meter_integration(m, nhi), 3.0, 0);
    assert_close(plan_meter_integration(m, hi), 3.0, 0);
    /* shorter than the rig's fixed integration: the fixed one */
    plan_meter_observe(m, nlo, rig.integration_s / 4);
    assert_close(plan_meter_integration(m, nlo), rig.integration_s, 0);
    plan_meter_free(m);
}

static void test_scales_the_expectation(void **state)
{
    (void)state;
    size_t n = plan_count(ds3), lo, hi;
    double *expected = malloc(n * sizeof *expected);
    for (size_t i = 0; i < n; i++)
        expected[i] = 0.1 * (double)(i + 1);
    struct gonio_err err = {0};
    plan_meter *m = plan_meter_new(ds3, &rig, expected, &err);
    assert_non_null(m);
    extremes(&lo, &hi);
    size_t nlo = neighbour(lo);
    assert_close(plan_meter_integration(m, nlo), expected[nlo], 0);
    /* the day's detector integrates twice what the host expected at lo */
    plan_meter_observe(m, lo, 2 * expected[lo]);
    assert_close(plan_meter_integration(m, nlo), 2 * expected[nlo], 1e-12);
    plan_meter_free(m);
    free(expected);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_nearest_measured),
        cmocka_unit_test(test_scales_the_expectation),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
