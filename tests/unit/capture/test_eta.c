/* capture/eta.h: before any point the ETA is the plan's estimate; after
 * points are journalled, each point left counts its move, the integration
 * measured nearest it and the mean overhead of the points measured (rig
 * time beyond their move estimate and integration), and a capture that
 * observes the same journal records again (a resume) has the same ETA. */
#include "tests/gonio_test.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "capture/eta.h"
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

static void test_first_eta_is_the_estimate(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    capture_eta *e = capture_eta_new(ds3, &rig, NULL, NULL, &err);
    assert_non_null(e);
    struct plan_estimate est;
    plan_estimate(ds3, &rig, &est);
    assert_close(capture_eta_left(e), est.total_s, 1e-9);
    assert_close(capture_eta_estimate(e), est.total_s, 1e-9);
    assert_close(capture_eta_overhead(e), rig.settle_s, 0);
    capture_eta_free(e);
}

static const struct rig_axes home = {0, 0, 0};

/* A journal record of point i measured after point `prev` (-1: from home)
 * ending at rig time `end`, integrating `integ`, with `extra` seconds
 * beyond the move, the settle and the integration. */
static struct journal_sample record(long prev, size_t i, double integ, double extra,
                                    double *end)
{
    const struct rig_axes *from = prev >= 0 ? &plan_point(ds3, (size_t)prev)->ax : &home;
    *end += rig_move_time_backlash(&rig, from, &plan_point(ds3, i)->ax) + rig.settle_s +
            integ + extra;
    struct journal_sample s;
    memset(&s, 0, sizeof s);
    s.point = (int)i;
    s.integration_s = integ;
    s.rig_time_s = *end;
    return s;
}

/* What the ETA should be: the points not done, in plan order, each its
 * move from its predecessor, the overhead and its nearest measured
 * integration (meter). */
static double expected_left(const unsigned char *done, const plan_meter *m, double overhead)
{
    double left = 0;
    const struct rig_axes *at = &home;
    for (size_t i = 0; i < plan_count(ds3); i++) {
        const struct rig_axes *to = &plan_point(ds3, i)->ax;
        if (!done[i])
            left += rig_move_time_backlash(&rig, at, to) + overhead +
                    plan_meter_integration(m, i);
        at = to;
    }
    return left;
}

static void test_nearest_integration_and_overhead(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    size_t n = plan_count(ds3);
    capture_eta *e = capture_eta_new(ds3, &rig, NULL, NULL, &err);
    plan_meter *m = plan_meter_new(ds3, &rig, NULL, &err);
    assert_non_null(e);
    assert_non_null(m);
    unsigned char done[64] = {0};
    assert_true(n <= sizeof done);
    /* a pre-scan-like start: points 4 and 40, then 0; overheads 0.5, 0.1, 0.3 s */
    const size_t pts[3] = {4, 40, 0};
    const double integ[3] = {2.0, 0.5, 1.0}, extra[3] = {0.5, 0.1, 0.3};
    struct journal_sample js[3];
    double end = 0;
    for (int k = 0; k < 3; k++) {
        js[k] = record(k ? (long)pts[k - 1] : -1, pts[k], integ[k], extra[k], &end);
        capture_eta_observe(e, &js[k]);
        plan_meter_observe(m, pts[k], integ[k]);
        done[pts[k]] = 1;
    }
    double overhead = rig.settle_s + (0.5 + 0.1 + 0.3) / 3;
    assert_close(capture_eta_overhead(e), overhead, 1e-9);
    assert_close(capture_eta_left(e), expected_left(done, m, overhead), 1e-9);
    /* not one global figure: the points next to 40 count its short
     * integration, those next to 4 its long one */
    assert_int_equal(plan_meter_nearest(m, 41), 40);
    assert_int_equal(plan_meter_nearest(m, 5), 4);
    double near40 = 0, near4 = 0;
    for (size_t i = 0; i < n; i++) {
        if (plan_meter_nearest(m, i) == 40 && !done[i])
            near40++;
        if (plan_meter_nearest(m, i) == 4 && !done[i])
            near4++;
    }
    assert_true(near40 > 0 && near4 > 0);

    /* a resumed capture observes the journal again: the same ETA */
    capture_eta *r = capture_eta_new(ds3, &rig, NULL, NULL, &err);
    assert_non_null(r);
    for (int k = 0; k < 3; k++)
        capture_eta_observe(r, &js[k]);
    assert_close(capture_eta_left(r), capture_eta_left(e), 0);
    capture_eta_free(r);
    capture_eta_free(e);
    plan_meter_free(m);
}

/* The capture's order moves: a pre-scan's points first, then the rest. */
static void test_order_counts_the_moves(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    size_t n = plan_count(ds3);
    long *order = malloc(n * sizeof *order);
    order[0] = (long)n - 1; /* the last point first, then 0, 1, ... */
    for (size_t i = 0; i + 1 < n; i++)
        order[i + 1] = (long)i;
    capture_eta *e = capture_eta_new(ds3, &rig, order, NULL, &err);
    assert_non_null(e);
    double want = 0;
    const struct rig_axes *at = &home;
    for (size_t k = 0; k < n; k++) {
        const struct rig_axes *to = &plan_point(ds3, (size_t)order[k])->ax;
        want += rig_move_time_backlash(&rig, at, to) + rig.settle_s + rig.integration_s;
        at = to;
    }
    assert_close(capture_eta_left(e), want, 1e-9);
    assert_close(capture_eta_estimate(e), want, 1e-9); /* the order's detour included */
    struct plan_estimate est;
    plan_estimate(ds3, &rig, &est);
    assert_true(want > est.total_s);
    capture_eta_free(e);
    free(order);
}

/* A capture that starts where the last one left the axes (the arm at
 * 140 deg): the planner's estimate from that start and the ETA told the
 * axes' positions count the first move from there, each by hand here;
 * the first record measured from there shows no overhead beyond the
 * settle; a resumed capture's next point counts its move from the axes,
 * not from the last record's point, and its record is metered so. */
static void test_start_position(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    const struct rig_axes start = {-20, 140, 0};
    size_t n = plan_count(ds3);
    double want = 0;
    const struct rig_axes *at = &start;
    for (size_t i = 0; i < n; i++) {
        const struct rig_axes *to = &plan_point(ds3, i)->ax;
        want += rig_move_time_backlash(&rig, at, to) + rig.settle_s + rig.integration_s;
        at = to;
    }
    struct plan_estimate home_est, est;
    plan_estimate(ds3, &rig, &home_est);
    plan_estimate_from(ds3, &rig, &start, NULL, NULL, NULL, &est);
    assert_close(est.total_s, want, 1e-9);
    assert_true(est.total_s > home_est.total_s + 1); /* the arm's long way back */
    plan_estimate_from(ds3, &rig, NULL, NULL, NULL, NULL, &est);
    assert_close(est.total_s, home_est.total_s, 0); /* no start: home */

    capture_eta *e = capture_eta_new(ds3, &rig, NULL, NULL, &err);
    assert_non_null(e);
    capture_eta_start(e, &start);
    assert_close(capture_eta_estimate(e), want, 1e-9);
    assert_close(capture_eta_left(e), want, 1e-9);
    double end = rig_move_time_backlash(&rig, &start, &plan_point(ds3, 0)->ax) + rig.settle_s +
                 rig.integration_s;
    struct journal_sample s0;
    memset(&s0, 0, sizeof s0);
    s0.point = 0;
    s0.integration_s = rig.integration_s;
    s0.rig_time_s = end;
    capture_eta_observe(e, &s0);
    assert_close(capture_eta_overhead(e), rig.settle_s, 1e-9);
    assert_close(capture_eta_left(e), want - end, 1e-9);

    /* resumed with the axes moved away since: point 1 from there */
    const struct rig_axes away = {10, -60, 0};
    double before = capture_eta_left(e);
    capture_eta_start(e, &away);
    const struct rig_axes *p0 = &plan_point(ds3, 0)->ax, *p1 = &plan_point(ds3, 1)->ax;
    assert_close(capture_eta_left(e),
                 before - rig_move_time_backlash(&rig, p0, p1) +
                     rig_move_time_backlash(&rig, &away, p1),
                 1e-9);
    assert_close(capture_eta_estimate(e), want, 1e-9); /* the whole capture's, as it began */
    /* point 1 measured from there shows no overhead beyond the settle */
    struct journal_sample s1 = s0;
    s1.point = 1;
    s1.rig_time_s = end + rig_move_time_backlash(&rig, &away, p1) + rig.settle_s +
                    rig.integration_s;
    capture_eta_observe(e, &s1);
    assert_close(capture_eta_overhead(e), rig.settle_s, 1e-9);
    capture_eta_free(e);
}

/* A plan of 12,322 points meters every seventh record and counts the points
 * off in between: from the first metered record on the ETA stays within
 * 1 % of what is left, and it ends at 0 with every point done. Each point
 * integrates 0.2 s and takes 0.1 s beyond its move and settle. */
static void test_large_plan_counts_off(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    struct plan *full = NULL;
    assert_true(plan_load("inplane-1deg", &rig, &full, &err) > 0); /* kept as written */
    size_t n = plan_count(full);
    assert_true(n > 4096);
    /* what is left after point i: the later points' moves, settle + 0.1
     * and 0.2 each */
    double *exact = malloc(n * sizeof *exact);
    assert_non_null(exact);
    exact[n - 1] = 0;
    for (size_t j = n - 1; j > 0; j--)
        exact[j - 1] = exact[j] + rig_move_time_backlash(&rig, &plan_point(full, j - 1)->ax,
                                                         &plan_point(full, j)->ax) +
                       rig.settle_s + 0.3;
    capture_eta *e = capture_eta_new(full, &rig, NULL, NULL, &err);
    assert_non_null(e);
    double end = 0, worst = 0;
    const struct rig_axes *at = &home;
    for (size_t i = 0; i < n; i++) {
        const struct rig_axes *to = &plan_point(full, i)->ax;
        end += rig_move_time_backlash(&rig, at, to) + rig.settle_s + 0.2 + 0.1;
        at = to;
        struct journal_sample s;
        memset(&s, 0, sizeof s);
        s.point = (int)i;
        s.integration_s = 0.2;
        s.rig_time_s = end;
        capture_eta_observe(e, &s);
        if (i + 1 >= n / 2048 + 1) /* from the first metered record on (eta.c) */
            worst = fmax(worst, fabs(capture_eta_left(e) - exact[i]) / fmax(exact[i], 1));
    }
    print_message("%zu points: the ETA within %.2f %% of what was left\n", n, 100 * worst);
    assert_true(worst < 0.01);
    assert_close(capture_eta_left(e), 0, 0);
    capture_eta_free(e);
    free(exact);
    plan_free(full);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_first_eta_is_the_estimate),
        cmocka_unit_test(test_nearest_integration_and_overhead),
        cmocka_unit_test(test_order_counts_the_moves),
        cmocka_unit_test(test_large_plan_counts_off),
        cmocka_unit_test(test_start_position),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
