/* The adaptive order choosing sample azimuths as well as pairs
 * (adaptive/aniso_info.h, docs/adaptive.md "Sample azimuths"): on the
 * rotating rig, with the DS3 grid at three turns of the sample as the
 * pool and model aniso-ggx, the policy turns the sample, and an
 * anisotropic GGX read with 1% noise is fitted within 1.25 times the
 * full-domain error of the fixed three-azimuth plan in 75% of its rig
 * time. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "adaptive/adaptive.h"
#include "adaptive/aniso_info.h"
#include "brdf/analytic_aniso.h"
#include "brdf/domain.h"
#include "brdf/metrics.h"
#include "fit/aniso_ggx_model.h"
#include "rig/motion.h"
#include "tests/gonio_test.h"

/* roughness ratio 3, the grain 30 deg off the plane of incidence */
static const struct brdf_aniso_ggx truth = {
    .rho = {0.1, 0.08, 0.06}, .f0 = {0.9, 0.8, 0.7}, .ax = 0.08, .ay = 0.24, .phi_deg = 30,
};
#define NOISE 0.01
#define POOL                                                                              \
    "name: ds3-az3\n"                                                                     \
    "grid: {theta_i_step: 30, theta_i_max: 80, diffuse_step: 20, glossy_step: 3,\n"      \
    "       glossy_half_width: 15, theta_r_min: -80, theta_r_max: 80, blind: 5}\n"        \
    "sample_azimuths: 3\n"

static char dir[64];

static int setup(void **state)
{
    (void)state;
    return gonio_test_dir_make(dir, sizeof dir, "adaptive-azimuths");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

static struct plan *load(struct rig_profile *rig, enum plan_order_mode order)
{
    char path[128];
    snprintf(path, sizeof path, "%s/pool.yaml", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(POOL, f);
    fclose(f);
    struct gonio_err err = {0};
    if (rig_profile_load("rotating", rig, &err) < 0)
        fail_msg("rig rotating: %s", err.msg);
    struct plan *p = NULL;
    if (plan_load(path, rig, &p, &err) <= 0)
        fail_msg("plan: %s", err.msg);
    assert_int_equal(plan_order(p, order, rig), 0);
    return p;
}

/* The reading at pool point i: the truth on the turned sample, times
 * 1 + NOISE of a normal deviate drawn from the pair and the turn (the same
 * reading in either order). */
static uint64_t noise_seed;

static struct fit_sample measure(const struct plan *pool, size_t i)
{
    const struct plan_point *pt = plan_point(pool, i);
    struct fit_sample s = {.u = {NAN, NAN, NAN}};
    brdf_pair_inplane(pt->theta_i, pt->theta_r, &s.g);
    brdf_pair_rotate(&s.g, pt->rotation);
    brdf_aniso_ggx_eval(&truth, &s.g, s.rgb);
    uint64_t st = (uint64_t)(pt->theta_i * 1000 + 1) * 1000003u +
                  (uint64_t)((pt->theta_r + 90) * 1000) * 7919u + (uint64_t)(pt->rotation * 1000) +
                  noise_seed * 0x9e3779b97f4a7c15ull;
    double u1 = ((double)(brdf_splitmix64(&st) >> 11) + 0.5) / 9007199254740992.0;
    double u2 = (double)(brdf_splitmix64(&st) >> 11) / 9007199254740992.0;
    double z = sqrt(-2 * log(u1)) * cos(2 * 3.14159265358979 * u2);
    for (int k = 0; k < 3; k++)
        s.rgb[k] *= 1 + NOISE * z;
    return s;
}

/* The full-domain log error (every node turned, brdf/domain.h) of the
 * aniso-ggx fit to s[0..n). */
static double full_error(const struct fit_sample *s, size_t n)
{
    double x[9], rms;
    assert_int_equal(fit_aniso_ggx_solve(s, n, 1, x, &rms), 0);
    struct brdf_aniso_ggx a = {.ax = exp(x[6]), .ay = exp(x[7]), .phi_deg = x[8] / BRDF_DEG};
    for (int k = 0; k < 3; k++) {
        a.rho[k] = exp(x[k]);
        a.f0[k] = exp(x[3 + k]);
    }
    struct brdf_domain d;
    struct gonio_err err = {0};
    assert_int_equal(brdf_domain_oop_random(&d, 20000, 7, &err), 0);
    brdf_domain_turn(&d);
    double *f = malloc(6 * d.n * sizeof *f), *g = f ? f + 3 * d.n : NULL;
    assert_non_null(f);
    for (size_t i = 0; i < d.n; i++) {
        brdf_aniso_ggx_eval(&a, &d.pairs[i], f + 3 * i);
        brdf_aniso_ggx_eval(&truth, &d.pairs[i], g + 3 * i);
    }
    struct brdf_errors e;
    brdf_errors_compute(d.pairs, g, f, d.n, &e);
    assert_int_equal(e.n_skipped, 0);
    free(f);
    brdf_domain_free(&d);
    return e.log;
}

/* The policy run on the pool until it stops (options o), the samples into
 * s; its rig time, the turns of the sample it made, the azimuths it
 * measured at and its status when it stopped. */
struct run {
    size_t n, turns, azimuths;
    double clock;
    double at[512];  /* the rig time after each sample */
    struct adaptive_status st;
};

static void run_policy(const struct plan *pool, const struct rig_profile *rig,
                       const struct adaptive_options *o, struct fit_sample *s, struct run *r)
{
    struct gonio_err err = {0};
    adaptive *a = adaptive_new(pool, rig, NULL, o, &err);
    assert_non_null(a);
    struct rig_axes at = {0, 0, 0};
    double turn = 0, seen[8];
    memset(r, 0, sizeof *r);
    for (;;) {
        long i = adaptive_next(a, &at, r->clock, -1, &r->st, &err);
        if (i < 0)
            break;
        const struct plan_point *pt = plan_point(pool, (size_t)i);
        double move = rig_move_time_backlash(rig, &at, &pt->ax);
        if (pt->rotation != turn) {
            move = fmax(move, rig_axis_time(pt->rotation - turn, rig->rotation.speed,
                                            rig->rotation.accel));
            r->turns++;
        }
        size_t k = 0;
        while (k < r->azimuths && seen[k] != pt->rotation)
            k++;
        if (k == r->azimuths && k < 8)
            seen[r->azimuths++] = pt->rotation;
        double took = move + rig->settle_s + rig->integration_s;
        r->clock += took;
        r->at[r->n] = r->clock;
        at = pt->ax;
        turn = pt->rotation;
        s[r->n] = measure(pool, (size_t)i);
        assert_int_equal(adaptive_add(a, (size_t)i, &s[r->n++], 0, &err), 0);
        assert_int_equal(adaptive_observe(a, (size_t)i, rig->integration_s, took, &err), 0);
    }
    adaptive_free(a);
}

/* Over four draws of the noise, the adaptive order on a budget of 75% of
 * the fixed plan's rig time fits the material to within 1.25 times the
 * fixed plan's full-domain error (means over the draws: one draw's error
 * is as much the noise's as the design's), measuring at every azimuth of
 * the pool; stopping on convergence, it turns the sample too. */
static void test_adaptive_turns_the_sample(void **state)
{
    (void)state;
    struct rig_profile rig;
    struct plan *fixed = load(&rig, PLAN_ORDER_TRAVEL);
    struct plan *pool = load(&rig, PLAN_ORDER_ADAPTIVE);
    size_t n = plan_count(fixed);
    struct fit_sample *s = malloc(n * sizeof *s);
    assert_non_null(s);
    struct plan_estimate est;
    plan_estimate(fixed, &rig, &est);
    struct adaptive_options o = adaptive_default_options();
    o.model = "aniso-ggx";
    o.budget_s = 0.75 * est.total_s;
    double fixed_mean = 0, adaptive_mean = 0;
    struct run r;
    for (noise_seed = 0; noise_seed < 4; noise_seed++) {
        for (size_t i = 0; i < n; i++)
            s[i] = measure(fixed, i);
        double fixed_err = full_error(s, n);
        run_policy(pool, &rig, &o, s, &r);
        double err = full_error(s, r.n);
        print_message("noise %d: fixed plan %zu pairs, %.0f s, error %.5f; adaptive %zu pairs, "
                      "%zu turns, %.0f s, error %.5f\n", (int)noise_seed, n, est.total_s,
                      fixed_err, r.n, r.turns, r.clock, err);
        assert_int_equal(r.azimuths, 3);
        assert_string_equal(r.st.stop, "budget");
        fixed_mean += fixed_err / 4;
        adaptive_mean += err / 4;
    }
    print_message("means: fixed %.5f, adaptive at 75%% of its rig time %.5f (%.2fx)\n",
                  fixed_mean, adaptive_mean, adaptive_mean / fixed_mean);
    assert_true(adaptive_mean <= 1.25 * fixed_mean);

    o.budget_s = 0;
    o.converge = 1;
    run_policy(pool, &rig, &o, s, &r);
    print_message("converged: %zu pairs, %zu turns, %.0f s, error %.5f (predicted %.5f)\n", r.n,
                  r.turns, r.clock, full_error(s, r.n), r.st.predicted_error);
    assert_string_equal(r.st.stop, "converged");
    assert_int_equal(r.azimuths, 3);
    plan_free(fixed);
    plan_free(pool);
    free(s);
}

/* A sample the fit drops (a non-finite reading) adds nothing to the
 * posterior: with one appended, the covariance is the one without. */
static void test_posterior_skips_unusable(void **state)
{
    (void)state;
    struct fit_sample s[61];
    size_t n = 0;
    for (int i = 0; i < 3; i++)
        for (int r = 0; r < 20; r++, n++) {
            s[n] = (struct fit_sample){.u = {NAN, NAN, NAN}};
            brdf_pair_inplane(10 + 25 * i, -70 + 7 * r, &s[n].g);
            brdf_pair_rotate(&s[n].g, 60 * i);
            brdf_aniso_ggx_eval(&truth, &s[n].g, s[n].rgb);
        }
    s[n] = s[0];
    s[n].rgb[1] = NAN;
    struct aniso_info a, b;
    aniso_info_init(&a);
    aniso_info_init(&b);
    assert_int_equal(aniso_info_update(&a, s, n), 0);
    assert_int_equal(aniso_info_update(&b, s, n + 1), 0);
    for (int j = 0; j < ANISO_INFO_NPAR; j++)
        for (int k = 0; k < ANISO_INFO_NPAR; k++)
            assert_true(fabs(a.cov[j][k] - b.cov[j][k]) <= 1e-9 * (1 + fabs(a.cov[j][k])));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_adaptive_turns_the_sample),
        cmocka_unit_test(test_posterior_skips_unusable),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
