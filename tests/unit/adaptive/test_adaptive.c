/* The adaptive policy (adaptive/adaptive.h) run in a loop against an
 * analytic material, without the capture engine: what it picks, when it
 * stops, and what it refuses. */
#include "tests/gonio_test.h"

#include "adaptive/adaptive.h"
#include "adaptive/adaptive_private.h"
#include "brdf/abc.h"
#include "rig/motion.h"

/* A sharp glossy lobe on a dark base: most of the information sits near
 * the mirror direction. */
static const struct brdf_abc sharp = {
    .kd = {0.05, 0.04, 0.03}, .A = {4, 4, 4}, .B = 3000, .C = 0.7, .eta = 1.6,
};

/* A broad lobe on a bright base: no region of the plane stands out. */
static const struct brdf_abc broad = {
    .kd = {0.6, 0.5, 0.4}, .A = {0.05, 0.05, 0.05}, .B = 2, .C = 0.5, .eta = 1.5,
};

/* The analytic material samples come from. */
static const struct brdf_abc *lobe = &sharp;

#define MAX_PICKS 2000

struct run {
    long pick[MAX_PICKS];
    size_t n;
    double clock;     /* rig time when the policy stopped */
    double max_clock; /* the latest any measured point ended */
    struct adaptive_status st;
    int switches;     /* times the status's model changed */
};

static struct plan *load(const char *name, struct rig_profile *rig)
{
    struct gonio_err err = {0};
    struct plan *p = NULL;
    rig_profile_default(rig);
    if (plan_load(name, rig, &p, &err) <= 0) {
        print_error("plan %s: %s\n", name, err.msg);
        fail();
    }
    /* a pool as a capture holds it: as written (the travel order would
     * make the policy's ties follow the planner's heuristic) */
    assert_int_equal(plan_order(p, PLAN_ORDER_ADAPTIVE, rig), 0);
    return p;
}

/* The material samples come from: the sharp lobe, or (when set) a
 * material opened from the shared data. */
static brdf_material *truth;

static struct fit_sample measure(const struct plan *pool, long i)
{
    const struct plan_point *pt = plan_point(pool, (size_t)i);
    struct fit_sample s = {0};
    brdf_pair_inplane(pt->theta_i, pt->theta_r, &s.g);
    if (truth)
        brdf_material_eval(truth, &s.g, 1, s.rgb);
    else
        brdf_abc_eval(lobe, &s.g, s.rgb);
    return s;
}

/* The integration the detector chooses at a point, in units of the rig's
 * fixed one (1: it integrates what the rig profile says). */
static double (*detector)(const struct plan_point *pt);

/* An auto-exposing detector on a material darker back-scattered: three
 * to five times the rig's fixed integration. */
static double auto_exposure(const struct plan_point *pt)
{
    return pt->theta_r < 0 ? 5 : 3;
}

/* Rig seconds every point takes beyond its move, settle and integration
 * (a slow bus's retries), which no cost knows of. */
static double overhead_s;

/* A fault's retries: every fault_every-th point takes fault_s more (0:
 * never). */
static size_t fault_every;
static double fault_s;

/* Measure what the policy asks, one point at a time, on the rig clock,
 * telling it what each point took, until it stops or max picks. */
static void run_policy(const struct plan *pool, const struct rig_profile *rig,
                       const struct adaptive_options *o, size_t max, struct run *r)
{
    struct gonio_err err = {0};
    adaptive *a = adaptive_new(pool, rig, NULL, o, &err);
    assert_non_null(a);
    struct rig_axes at = {0, 0, 0};
    memset(r, 0, sizeof *r);
    while (r->n < max) {
        char was[sizeof r->st.model];
        memcpy(was, r->st.model, sizeof was);
        long i = adaptive_next(a, &at, r->clock, -1, &r->st, &err);
        r->switches += r->n > 0 && was[0] && strcmp(was, r->st.model) != 0;
        if (i == -1)
            break;
        assert_true(i >= 0 && (size_t)i < plan_count(pool));
        const struct plan_point *pt = plan_point(pool, (size_t)i);
        double integration = rig->integration_s * (detector ? detector(pt) : 1);
        double took =
            rig_move_time_backlash(rig, &at, &pt->ax) + rig->settle_s + integration + overhead_s;
        if (fault_every && (r->n + 1) % fault_every == 0)
            took += fault_s;
        r->clock += took;
        r->max_clock = fmax(r->max_clock, r->clock);
        at = pt->ax;
        r->pick[r->n++] = i;
        struct fit_sample s = measure(pool, i);
        assert_int_equal(adaptive_add(a, (size_t)i, &s, 0, &err), 0);
        assert_int_equal(adaptive_observe(a, (size_t)i, integration, took, &err), 0);
    }
    adaptive_free(a);
}

static void test_deterministic(void **state)
{
    (void)state;
    struct rig_profile rig;
    struct plan *pool = load("ds1", &rig);
    struct adaptive_options o = adaptive_default_options();
    static struct run r1, r2;
    run_policy(pool, &rig, &o, 30, &r1);
    run_policy(pool, &rig, &o, 30, &r2);
    assert_int_equal(r1.n, 30);
    assert_int_equal(r2.n, 30);
    assert_memory_equal(r1.pick, r2.pick, sizeof r1.pick);
    /* the same prediction to the last bit */
    assert_memory_equal(&r1.st.predicted_error, &r2.st.predicted_error, sizeof(double));
    plan_free(pool);
}

static void test_budget_never_exceeded(void **state)
{
    (void)state;
    struct rig_profile rig;
    struct plan *pool = load("ds1", &rig);
    struct adaptive_options o = adaptive_default_options();
    o.budget_s = 15;
    static struct run r;
    run_policy(pool, &rig, &o, MAX_PICKS, &r);
    assert_true(r.n >= 6);
    assert_true(r.max_clock <= o.budget_s);
    assert_string_equal(r.st.stop, "budget");
    plan_free(pool);
}

/* The first picks are DS4's six pairs in DS4's order (its travel order:
 * the arm sweeps once), and a budget of DS4's own estimated rig time
 * holds all six on a rig that keeps the planner's pace: an operator who
 * gives the adaptive capture DS4's time gets at least DS4's samples. */
static void test_seeds_fill_ds4_time(void **state)
{
    (void)state;
    struct rig_profile rig;
    struct plan *pool = load("ds1", &rig), *ds4 = load("ds4", &rig);
    struct plan_estimate est;
    plan_estimate(ds4, &rig, &est);
    struct adaptive_options o = adaptive_default_options();
    o.budget_s = est.total_s;
    static struct run r;
    run_policy(pool, &rig, &o, MAX_PICKS, &r);
    print_message("budget %.3f s: %zu picks in %.3f s\n", o.budget_s, r.n, r.max_clock);
    assert_int_equal(r.n, plan_count(ds4));
    for (size_t k = 0; k < r.n; k++) {
        const struct plan_point *p = plan_point(pool, (size_t)r.pick[k]), *q = plan_point(ds4, k);
        assert_true(fabs(p->theta_i - q->theta_i) < 1e-9 && fabs(p->theta_r - q->theta_r) < 1e-9);
    }
    assert_true(r.max_clock <= o.budget_s + 1e-6);
    assert_string_equal(r.st.stop, "budget");
    plan_free(ds4);
    plan_free(pool);
}

/* The detector integrates longer than the rig profile says, longer on
 * one side than the other, and every point takes a little more than its
 * move, settle and integration: the policy learns it from what the points
 * took and still ends within the budget, whichever it is. */
static void test_budget_held_on_a_slower_rig(void **state)
{
    (void)state;
    struct rig_profile rig;
    struct plan *pool = load("ds1", &rig);
    struct adaptive_options o = adaptive_default_options();
    static struct run r;
    detector = auto_exposure;
    overhead_s = 0.25;
    for (double budget = 15; budget <= 60; budget += 5) {
        o.budget_s = budget;
        run_policy(pool, &rig, &o, MAX_PICKS, &r);
        assert_true(r.n >= 5);
        assert_true(r.max_clock <= o.budget_s);
        assert_string_equal(r.st.stop, "budget");
    }
    detector = NULL;
    overhead_s = 0;
    plan_free(pool);
}

/* Now and then a point takes seconds more (a bus fault's retries), too
 * rarely for the latest points' pace to show it when it strikes again:
 * the reserve the policy keeps after the first holds the budget. */
static void test_budget_held_through_rare_faults(void **state)
{
    (void)state;
    struct rig_profile rig;
    struct plan *pool = load("ds1", &rig);
    struct adaptive_options o = adaptive_default_options();
    static struct run r;
    fault_every = 20;
    fault_s = 2;
    for (double budget = 60; budget <= 150; budget += 5) {
        o.budget_s = budget;
        run_policy(pool, &rig, &o, MAX_PICKS, &r);
        assert_true(r.n >= 20);
        assert_true(r.max_clock <= o.budget_s);
    }
    fault_every = 0;
    fault_s = 0;
    plan_free(pool);
}

/* A point's integration is the one measured at the observed point
 * nearest it: as measured, never below the rig's fixed one, or where
 * the host expected integrations, its expectation scaled by how the
 * measurement compared with the expectation there. */
static void test_cost_learns_integration(void **state)
{
    (void)state;
    struct rig_profile rig;
    struct plan *pool = load("ds1", &rig);
    struct gonio_err err = {0};
    const struct rig_axes home = {0, 0, 0};
    /* j, the pool point nearest it and the one farthest from it */
    size_t j = 11, i = j, far = j;
    double near_d = INFINITY, far_d = 0;
    for (size_t k = 0; k < plan_count(pool); k++) {
        const struct plan_point *p = plan_point(pool, k), *q = plan_point(pool, j);
        double d = fabs(p->theta_i - q->theta_i) + fabs(p->theta_r - q->theta_r);
        if (k != j && d < near_d) {
            near_d = d;
            i = k;
        }
        if (d > far_d) {
            far_d = d;
            far = k;
        }
    }
    double move_settle = rig_move_time_backlash(&rig, &home, &plan_point(pool, j)->ax) +
                         rig.settle_s;
    adaptive *a = adaptive_new(pool, &rig, NULL, NULL, &err);
    assert_non_null(a);
    assert_true(fabs(adaptive_point_cost(a, &home, j) - move_settle - rig.integration_s) < 1e-12);
    assert_int_equal(adaptive_observe(a, i, rig.integration_s + 0.4, 2, &err), 0);
    assert_true(fabs(adaptive_point_cost(a, &home, j) - move_settle - rig.integration_s - 0.4) <
                1e-12);
    adaptive_free(a);
    a = adaptive_new(pool, &rig, NULL, NULL, &err);
    assert_int_equal(adaptive_observe(a, i, rig.integration_s / 2, 1, &err), 0);
    assert_true(fabs(adaptive_point_cost(a, &home, j) - move_settle - rig.integration_s) < 1e-12);
    adaptive_free(a);

    double *integ = malloc(plan_count(pool) * sizeof *integ);
    for (size_t k = 0; k < plan_count(pool); k++)
        integ[k] = 0.2;
    integ[j] = 0.4;
    a = adaptive_new(pool, &rig, integ, NULL, &err);
    assert_non_null(a);
    assert_true(fabs(adaptive_point_cost(a, &home, j) - move_settle - 0.4) < 1e-12);
    assert_int_equal(adaptive_observe(a, i, 0.3, 2, &err), 0);
    assert_true(fabs(adaptive_point_cost(a, &home, j) - move_settle - 0.6) < 1e-12);
    /* an observation farther away does not replace the nearest one */
    assert_int_equal(adaptive_observe(a, far, 0.1, 2, &err), 0);
    assert_true(fabs(adaptive_point_cost(a, &home, j) - move_settle - 0.6) < 1e-12);
    adaptive_free(a);
    free(integ);
    plan_free(pool);
}

/* The error a minute on is below the error now by the gain, but never by
 * more than half of it, and not given where nothing is gained. */
static void test_predicted_next_sensible(void **state)
{
    (void)state;
    assert_true(fabs(adaptive_predicted_next(0.031, 0.006) - 0.025) < 1e-12);
    /* a steep early slope: 0.015 - 0.02 would be below zero */
    assert_true(fabs(adaptive_predicted_next(0.015, 0.02) - 0.0075) < 1e-12);
    assert_true(isnan(adaptive_predicted_next(0.015, 0)));
    assert_true(isnan(adaptive_predicted_next(0.015, -0.001)));
    assert_true(isnan(adaptive_predicted_next(0.015, NAN)));
    assert_true(isnan(adaptive_predicted_next(NAN, 0.001)));
}

static void test_exhausted_no_repeat(void **state)
{
    (void)state;
    struct rig_profile rig;
    struct plan *pool = load("ds3", &rig);
    struct adaptive_options o = adaptive_default_options();
    static struct run r;
    run_policy(pool, &rig, &o, MAX_PICKS, &r);
    assert_int_equal(r.n, plan_count(pool));
    assert_string_equal(r.st.stop, "exhausted");
    unsigned char seen[64] = {0};
    for (size_t k = 0; k < r.n; k++) {
        assert_int_equal(seen[r.pick[k]], 0);
        seen[r.pick[k]] = 1;
    }
    plan_free(pool);
}

/* A point being measured is never offered again, from the seeds on. */
static void test_pending_excluded(void **state)
{
    (void)state;
    struct rig_profile rig;
    struct plan *pool = load("ds1", &rig);
    struct gonio_err err = {0};
    adaptive *a = adaptive_new(pool, &rig, NULL, NULL, &err);
    assert_non_null(a);
    struct rig_axes at = {0, 0, 0};
    long pending = -1;
    for (int k = 0; k < 20; k++) {
        long i = adaptive_next(a, &at, 0, pending, NULL, &err);
        assert_true(i >= 0);
        assert_true(i != pending);
        /* the pending point's sample arrives now; i becomes pending */
        if (pending >= 0) {
            struct fit_sample s = measure(pool, pending);
            assert_int_equal(adaptive_add(a, (size_t)pending, &s, 0, &err), 0);
        }
        pending = i;
    }
    adaptive_free(a);
    plan_free(pool);
}

static void test_bad_input(void **state)
{
    (void)state;
    struct rig_profile rig;
    struct plan *pool = load("ds1", &rig);
    struct gonio_err err = {0};
    struct adaptive_options o = adaptive_default_options();
    o.budget_s = -1;
    assert_null(adaptive_new(pool, &rig, NULL, &o, &err));
    assert_int_equal(err.code, GONIO_EUSAGE);
    assert_non_null(strstr(err.msg, "budget -1"));
    o = adaptive_default_options();
    o.target = NAN;
    assert_null(adaptive_new(pool, &rig, NULL, &o, &err));
    assert_non_null(strstr(err.msg, "target nan"));
    o = adaptive_default_options();
    o.converge = 1;
    o.gain_tol = 0;
    assert_null(adaptive_new(pool, &rig, NULL, &o, &err));
    assert_non_null(strstr(err.msg, "gain tolerance 0"));
    o = adaptive_default_options();
    o.model = "phong";
    assert_null(adaptive_new(pool, &rig, NULL, &o, &err));
    assert_non_null(strstr(err.msg, "phong"));
    double *integ = calloc(plan_count(pool), sizeof *integ);
    integ[7] = -0.5;
    assert_null(adaptive_new(pool, &rig, integ, NULL, &err));
    assert_non_null(strstr(err.msg, "point 7 is -0.5 s"));
    free(integ);

    adaptive *a = adaptive_new(pool, &rig, NULL, NULL, &err);
    assert_non_null(a);
    struct fit_sample s = measure(pool, 3);
    assert_int_equal(adaptive_add(a, 3, &s, 0, &err), 0);
    assert_int_equal(adaptive_add(a, 3, &s, 0, &err), -GONIO_EUSAGE);
    assert_non_null(strstr(err.msg, "point 3 of pool ds1 given twice"));
    assert_int_equal(adaptive_add(a, plan_count(pool), &s, 0, &err), -GONIO_EUSAGE);
    assert_int_equal(adaptive_observe(a, plan_count(pool), 0.1, 1, &err), -GONIO_EUSAGE);
    assert_int_equal(adaptive_observe(a, 3, 0.1, -1, &err), -GONIO_EUSAGE);
    assert_non_null(strstr(err.msg, "point 3 observed with integration 0.1 s in -1 s"));
    assert_int_equal(adaptive_observe(a, 3, NAN, 1, &err), -GONIO_EUSAGE);
    struct rig_axes at = {0, 0, 0};
    assert_int_equal(adaptive_next(a, &at, 0, (long)plan_count(pool), NULL, &err),
                     -GONIO_EUSAGE);
    adaptive_free(a);
    plan_free(pool);
}

/* On a sharp lobe the policy spends its points near the mirror direction:
 * on a uniform 4-degree grid (so that the pool's own density does not
 * favour the mirror, as DS1's 1-degree glossy band would), a share of its
 * picks within 10 degrees of it well above the pool's share, and well
 * above its share on a broad lobe; yet without crowding its picks next to
 * each other. */
static void test_concentrates_on_specular(void **state)
{
    (void)state;
    char dir[64], path[96];
    assert_int_equal(gonio_test_dir_make(dir, sizeof dir, "adaptive"), 0);
    snprintf(path, sizeof path, "%s/uniform.yaml", dir);
    gonio_test_write_text(path,
                          "name: uniform\ngrid:\n  theta_i_step: 4\n  theta_i_max: 80\n"
                          "  diffuse_step: 4\n  glossy_step: 4\n  glossy_half_width: 12\n"
                          "  theta_r_min: -80\n  theta_r_max: 80\n  blind: 5\norder: travel\n"
                          "stop: all\n");
    struct rig_profile rig;
    struct plan *pool = load(path, &rig);
    struct adaptive_options o = adaptive_default_options();
    static struct run r;
    size_t picks = gonio_test_small() ? 30 : 60;
    size_t near_pool = 0;
    for (size_t i = 0; i < plan_count(pool); i++)
        near_pool += fabs(plan_point(pool, i)->theta_r - plan_point(pool, i)->theta_i) <= 10;
    double share_pool = (double)near_pool / (double)plan_count(pool), share[2];
    const struct brdf_abc *lobes[2] = {&sharp, &broad};
    for (int m = 1; m >= 0; m--) { /* the sharp lobe's run last: r is its run */
        lobe = lobes[m];
        run_policy(pool, &rig, &o, picks, &r);
        size_t near_picks = 0;
        for (size_t k = 6; k < r.n; k++) {
            const struct plan_point *pt = plan_point(pool, (size_t)r.pick[k]);
            near_picks += fabs(pt->theta_r - pt->theta_i) <= 10;
        }
        share[m] = (double)near_picks / (double)(r.n - 6);
    }
    lobe = &sharp;
    /* Picks next to an earlier pick (one grid step in both angles) on the
     * sharp lobe: the ensemble's spread hardly falls beside a measured
     * point, and the policy must not pile its samples there. */
    size_t crowded = 0;
    for (size_t k = 6; k < r.n; k++) {
        const struct plan_point *p = plan_point(pool, (size_t)r.pick[k]);
        for (size_t j = 0; j < k; j++) {
            const struct plan_point *q = plan_point(pool, (size_t)r.pick[j]);
            if (fabs(p->theta_i - q->theta_i) <= 4 && fabs(p->theta_r - q->theta_r) <= 4) {
                crowded++;
                break;
            }
        }
    }
    print_message("next to an earlier pick: %zu of %zu\n", crowded, r.n - 6);
    assert_true(4 * crowded <= 3 * (r.n - 6));
    print_message("near the mirror: %.2f of the picks (sharp lobe), %.2f (broad), %.2f of the "
                  "pool\n", share[0], share[1], share_pool);
    assert_true(share[0] > 2 * share_pool);
    /* the material, not the pool or the coverage, puts them there (by a
     * margin relative to the broad lobe's share: which pairs the policy
     * picks is sensitive to rounding, and a Debug build's picks differ
     * from a Release build's: 0.42 against 0.29 there, 0.62 against 0.08
     * here at the small size) */
    assert_true(share[0] > 1.25 * share[1]);
    plan_free(pool);
    gonio_test_dir_remove(dir);
}

/* Six samples, on a pool of grazing pairs only (theta_i 75 and 80): the
 * prediction is a finite positive number from the first fit on, and the
 * policy keeps choosing (no NaN score loses every comparison). */
static void test_predicted_finite_early_and_grazing(void **state)
{
    (void)state;
    char dir[64], path[96];
    assert_int_equal(gonio_test_dir_make(dir, sizeof dir, "adaptive"), 0);
    snprintf(path, sizeof path, "%s/grazing.yaml", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("name: grazing\npairs:\n", f);
    for (int ti = 75; ti <= 80; ti += 5)
        for (int tr = -80; tr <= 80; tr += 10)
            if (abs(ti + tr) >= 10)
                fprintf(f, "  - [%d, %d]\n", ti, tr);
    fputs("order: travel\nstop: all\n", f);
    fclose(f);
    struct rig_profile rig;
    struct plan *pool = load(path, &rig);
    struct adaptive_options o = adaptive_default_options();
    static struct run r;
    run_policy(pool, &rig, &o, 7, &r);
    /* the 7th decision is made on the first six samples */
    assert_int_equal(r.n, 7);
    assert_int_equal(r.st.samples, 6);
    assert_true(isfinite(r.st.predicted_error) && r.st.predicted_error > 0);
    run_policy(pool, &rig, &o, 20, &r);
    assert_int_equal(r.n, 20);
    assert_true(isfinite(r.st.predicted_error) && r.st.predicted_error > 0);
    plan_free(pool);
    gonio_test_dir_remove(dir);
}

/* Samples an ABC model fits exactly: the predicted error falls to about
 * 0 at once, yet the target stop waits for the samples below which the
 * prediction is not trusted. */
static void test_target_stop(void **state)
{
    (void)state;
    struct rig_profile rig;
    struct plan *pool = load("ds1", &rig);
    struct adaptive_options o = adaptive_default_options();
    o.target = 0.01;
    static struct run r;
    run_policy(pool, &rig, &o, MAX_PICKS, &r);
    assert_string_equal(r.st.stop, "target");
    assert_int_equal(r.n, 80);
    assert_true(r.st.predicted_error <= 0.01);
    plan_free(pool);
}

/* The same exact fit: the prediction stops moving, so the converge stop
 * ends the capture (not before 80 samples), and the gain it reports is
 * below the tolerance. */
static void test_converge_stop(void **state)
{
    (void)state;
    struct rig_profile rig;
    struct plan *pool = load("ds1", &rig);
    struct adaptive_options o = adaptive_default_options();
    o.converge = 1;
    static struct run r;
    run_policy(pool, &rig, &o, MAX_PICKS, &r);
    assert_string_equal(r.st.stop, "converged");
    assert_true(r.n >= 80 && r.n < plan_count(pool));
    assert_true(fabs(r.st.gain_per_min) < o.gain_tol);
    /* the converged gain may be of either sign: a minute on is predicted
     * only where it is positive */
    if (r.st.gain_per_min > 0)
        assert_true(r.st.predicted_next < r.st.predicted_error &&
                    r.st.predicted_next >= r.st.predicted_error / 2);
    else
        assert_true(isnan(r.st.predicted_next));
    plan_free(pool);
}

/* auto on a material the latent decoder does not know (the analytic sharp
 * lobe): the latent fit follows its samples worse than ABC predicts
 * held-out ones, so the policy follows ABC. */
static void test_auto_refuses_foreign_prior(void **state)
{
    (void)state;
    struct rig_profile rig;
    struct plan *pool = load("ds1", &rig);
    struct adaptive_options o = adaptive_default_options();
    o.model = "auto";
    static struct run r;
    run_policy(pool, &rig, &o, 30, &r);
    assert_string_equal(r.st.model, "abc");
    plan_free(pool);
}

/* auto on a material both models follow about equally well: the check
 * may change its mind as the samples grow, but it must not swing back and
 * forth with the policy's own state (its ensemble is weighted while it
 * follows ABC, not while it follows latent: compared with weighted fits'
 * held-out error, the latent fit won every other check). */
static void test_auto_check_does_not_swing(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    truth = brdf_material_open("analytic:rough-diffuse", &err);
    assert_non_null(truth);
    struct rig_profile rig;
    struct plan *pool = load("ds1", &rig);
    struct adaptive_options o = adaptive_default_options();
    o.model = "auto";
    static struct run r;
    run_policy(pool, &rig, &o, gonio_test_small() ? 80 : 120, &r);
    printf("the policy's model changed %d times in %zu picks, ending at %s\n", r.switches, r.n,
           r.st.model);
    assert_true(r.switches <= 1);
    brdf_material_free(truth);
    truth = NULL;
    plan_free(pool);
}

/* auto on a MERL material (held out from the decoder's training): the
 * latent fit follows it, and the policy follows the latent model. */
static void test_auto_follows_latent_on_merl(void **state)
{
    (void)state;
    if (!gonio_test_shared_or_skip())
        return;
    struct gonio_err err = {0};
    truth = brdf_material_open("nbrdf:red-plastic", &err);
    assert_non_null(truth);
    struct rig_profile rig;
    struct plan *pool = load("ds1", &rig);
    struct adaptive_options o = adaptive_default_options();
    o.model = "auto";
    static struct run r;
    run_policy(pool, &rig, &o, 30, &r);
    assert_string_equal(r.st.model, "latent");
    assert_true(isfinite(r.st.predicted_error) && r.st.predicted_error > 0);
    brdf_material_free(truth);
    truth = NULL;
    plan_free(pool);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_deterministic),
        cmocka_unit_test(test_budget_never_exceeded),
        cmocka_unit_test(test_seeds_fill_ds4_time),
        cmocka_unit_test(test_budget_held_on_a_slower_rig),
        cmocka_unit_test(test_budget_held_through_rare_faults),
        cmocka_unit_test(test_cost_learns_integration),
        cmocka_unit_test(test_predicted_next_sensible),
        cmocka_unit_test(test_exhausted_no_repeat),
        cmocka_unit_test(test_pending_excluded),
        cmocka_unit_test(test_bad_input),
        cmocka_unit_test(test_concentrates_on_specular),
        cmocka_unit_test(test_predicted_finite_early_and_grazing),
        cmocka_unit_test(test_target_stop),
        cmocka_unit_test(test_converge_stop),
        cmocka_unit_test(test_auto_refuses_foreign_prior),
        cmocka_unit_test(test_auto_check_does_not_swing),
        cmocka_unit_test(test_auto_follows_latent_on_merl),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}

