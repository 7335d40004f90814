/* The grid rule of DESIGN.md section 3, checked against an independent
 * brute force: every (theta_i, theta_r) on a fine integer lattice is tested
 * against the rule as written in the design, and the planner must produce
 * exactly that set. */
#include "tests/gonio_test.h"

#include <string.h>

#include "planner/planner.h"

/* Rule in half-degree units (h = 2 * degrees) so that 2.5-degree steps are
 * integers too. */
struct rule {
    int ti_step, ti_max, diffuse, glossy, w, tr_min, tr_max, blind;
};

static int in_rule(const struct rule *r, int ti, int tr)
{
    if (ti < 0 || ti > r->ti_max || ti % r->ti_step)
        return 0;
    if (tr < r->tr_min || tr > r->tr_max)
        return 0;
    if (abs(ti + tr) < r->blind)
        return 0;
    int d = tr - ti;
    int diffuse = (tr - r->tr_min) % r->diffuse == 0 && abs(d) > r->w;
    int glossy = d % r->glossy == 0 && abs(d) <= r->w;
    return diffuse || glossy;
}

static int brute_count(const struct rule *r)
{
    int n = 0;
    for (int ti = 0; ti <= 180; ti++)
        for (int tr = -180; tr <= 180; tr++)
            n += in_rule(r, ti, tr);
    return n;
}

static int half(double deg)
{
    double h = deg * 2;
    int i = (int)lround(h);
    assert_close(h, i, 1e-9); /* every pair lies on the half-degree lattice */
    return i;
}

static void check_plan(const char *name, const struct rule *r, int expected)
{
    struct rig_profile rig;
    struct gonio_err err = {0};
    assert_int_equal(rig_profile_load("default", &rig, &err), 0);
    struct plan *p;
    int n = plan_load(name, &rig, &p, &err);
    if (n < 0)
        print_error("%s\n", err.msg);
    assert_int_equal(n, expected);
    assert_int_equal(brute_count(r), expected);
    assert_int_equal(plan_count(p), (size_t)expected);
    /* every point obeys the rule, appears once, and sits on its axes */
    static char seen[181][361];
    memset(seen, 0, sizeof seen);
    for (size_t i = 0; i < plan_count(p); i++) {
        const struct plan_point *pt = plan_point(p, i);
        int ti = half(pt->theta_i), tr = half(pt->theta_r);
        if (!in_rule(r, ti, tr)) {
            print_error("%s: pair (%g, %g) breaks the grid rule\n", name, pt->theta_i,
                        pt->theta_r);
            fail();
        }
        assert_int_equal(seen[ti][tr + 180], 0);
        seen[ti][tr + 180] = 1;
        assert_close(pt->ax.s, pt->theta_i, 1e-12);
        assert_close(pt->ax.a, pt->theta_i + pt->theta_r, 1e-12);
        assert_false(pt->out_of_plane);
    }
    plan_free(p);
}

static void test_ds1(void **state)
{
    (void)state;
    struct rule r = {10, 160, 10, 2, 30, -160, 160, 10};
    check_plan("ds1", &r, 912);
}

static void test_ds2(void **state)
{
    (void)state;
    struct rule r = {30, 160, 20, 4, 30, -160, 160, 10};
    check_plan("ds2", &r, 160);
}

static void test_ds3(void **state)
{
    (void)state;
    struct rule r = {60, 160, 40, 6, 30, -160, 160, 10};
    check_plan("ds3", &r, 52);
}

static void test_ds4(void **state)
{
    (void)state;
    static const double tr[] = {-60, -20, 20, 28, 36, 60};
    struct rig_profile rig;
    rig_profile_default(&rig);
    struct plan *p;
    struct gonio_err err = {0};
    assert_int_equal(plan_load("ds4", &rig, &p, &err), 6);
    assert_int_equal(plan_kind(p), PLAN_KIND_PAIRS);
    int found[6] = {0};
    for (size_t i = 0; i < 6; i++) {
        const struct plan_point *pt = plan_point(p, i);
        assert_close(pt->theta_i, 30, 0);
        for (int k = 0; k < 6; k++)
            found[k] += pt->theta_r == tr[k];
        assert_close(pt->ax.a, 30 + pt->theta_r, 1e-12);
    }
    for (int k = 0; k < 6; k++)
        assert_int_equal(found[k], 1);
    plan_free(p);
}

/* Non-integer steps and an asymmetric range through plan_grid_generate. */
static void test_fractional_grid(void **state)
{
    (void)state;
    struct plan_grid g = {.theta_i_step = 7.5, .theta_i_max = 70, .diffuse_step = 2.5,
                          .glossy_step = 0.5, .glossy_half_width = 10, .theta_r_min = -70,
                          .theta_r_max = 75, .blind = 6};
    struct rule r = {15, 140, 5, 1, 20, -140, 150, 12};
    struct plan_point *pts;
    int n = plan_grid_generate(&g, &pts);
    assert_int_equal(n, brute_count(&r));
    for (int i = 0; i < n; i++) {
        assert_true(in_rule(&r, half(pts[i].theta_i), half(pts[i].theta_r)));
        if (i) /* written order: theta_i, then theta_r, strictly increasing */
            assert_true(pts[i - 1].theta_i < pts[i].theta_i ||
                        (pts[i - 1].theta_i == pts[i].theta_i &&
                         pts[i - 1].theta_r < pts[i].theta_r));
    }
    free(pts);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ds1),
        cmocka_unit_test(test_ds2),
        cmocka_unit_test(test_ds3),
        cmocka_unit_test(test_ds4),
        cmocka_unit_test(test_fractional_grid),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
