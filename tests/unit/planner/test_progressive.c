/* Progressive DS1: every prefix a capture could stop at is well spread.
 * The coarse levels come first and hold every theta_i of their plan; the
 * finest level starts in the middle of the theta_i range and reaches both
 * sides of it long before its end, instead of sweeping from one end. */
#include "tests/gonio_test.h"

#include <math.h>
#include <string.h>

#include "planner/planner.h"

static struct rig_profile rig;

static int setup(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    return rig_profile_load("default", &rig, &err);
}

static int holds(const struct plan *p, double ti, double tr)
{
    for (size_t i = 0; i < plan_count(p); i++)
        if (fabs(plan_point(p, i)->theta_i - ti) < 1e-9 &&
            fabs(plan_point(p, i)->theta_r - tr) < 1e-9)
            return 1;
    return 0;
}

static void test_prefixes_spread(void **state)
{
    (void)state;
    struct plan *ds1, *ds2, *ds3;
    struct gonio_err err = {0};
    assert_true(plan_load("ds1", &rig, &ds1, &err) > 0);
    assert_true(plan_load("ds2", &rig, &ds2, &err) > 0);
    assert_true(plan_load("ds3", &rig, &ds3, &err) > 0);
    assert_int_equal(plan_order(ds1, PLAN_ORDER_PROGRESSIVE, &rig), 0);
    size_t n = plan_count(ds1), n3 = plan_count(ds3);

    /* level 0: exactly DS3, so every theta_i of DS3 is measured first */
    for (size_t i = 0; i < n3; i++) {
        const struct plan_point *pt = plan_point(ds1, i);
        assert_true(holds(ds3, pt->theta_i, pt->theta_r));
    }
    for (size_t k = 0; k < n3; k++) {
        double ti = plan_point(ds3, k)->theta_i;
        int seen = 0;
        for (size_t i = 0; i < n3 && !seen; i++)
            seen = plan_point(ds1, i)->theta_i == ti;
        assert_true(seen);
    }
    /* level 1: DS2's remaining pairs; after it every DS2 theta_i is there */
    size_t l1 = n3;
    while (l1 < n && holds(ds2, plan_point(ds1, l1)->theta_i, plan_point(ds1, l1)->theta_r))
        l1++;
    for (size_t k = 0; k < plan_count(ds2); k++) {
        const struct plan_point *q = plan_point(ds2, k);
        int seen = 0;
        for (size_t i = 0; i < l1 && !seen; i++)
            seen = plan_point(ds1, i)->theta_i == q->theta_i &&
                   plan_point(ds1, i)->theta_r == q->theta_r;
        assert_true(seen);
    }
    /* the finest level: within its first 40 % the new rows span theta_i
     * from 20 to 60 (a sweep from one end would stay on one side), and the
     * first row it takes is an interior one, not 0 or 80 */
    size_t rest = n - l1, lim = l1 + rest * 2 / 5;
    double lo = 1e9, hi = -1e9;
    for (size_t i = l1; i < lim; i++) {
        double ti = plan_point(ds1, i)->theta_i;
        lo = fmin(lo, ti);
        hi = fmax(hi, ti);
    }
    assert_true(lo <= 20 + 1e-9);
    assert_true(hi >= 60 - 1e-9);
    double first = plan_point(ds1, l1)->theta_i;
    assert_true(first > 20 && first < 60);
    /* and it measures whole rows: the first row is complete (all of DS1's
     * pairs at that theta_i) before another DS1-only row starts */
    size_t in_row = 0, row_total = 0;
    for (size_t i = 0; i < n; i++) {
        const struct plan_point *pt = plan_point(ds1, i);
        if (pt->theta_i == first && i >= l1)
            row_total++;
    }
    for (size_t i = l1; i < n && plan_point(ds1, i)->theta_i == first; i++)
        in_row++;
    assert_int_equal(in_row, row_total);
    plan_free(ds1);
    plan_free(ds2);
    plan_free(ds3);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_prefixes_spread),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
