/* Poisson counts over every mean a scene can produce (1e-3 to 1e15
 * electrons and beyond): whole, never negative, with the mean and the
 * variance of a Poisson count, and every draw returning at once. GSL's
 * own sampler wraps its counts from a mean of about 4.3e9 (4.4e9 gave
 * 1.05e8) and does not return past about 1e10; the shot noise of a scene
 * at the top of its ranges (responsivity 1e15, a dark rate of 1e12 e-/s)
 * goes through the same counts, and every effect at both ends of its
 * documented range reads at once through the in-process rig.
 *
 * Fixed seeds, and bounds of six standard errors: a seed that moved them
 * would have to be a one-in-a-billion draw. A sampler that hangs ends the
 * test at its alarm (60 s; the whole test takes well under a second). */
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include <gsl/gsl_rng.h>

#include "brdf/material.h"
#include "rig/rig.h"
#include "sim/effects.h"
#include "sim/poisson.h"
#include "sim/sim.h"
#include "tests/gonio_test.h"

/* n counts of mean mu: every one whole and >= 0; the sample mean within
 * six standard errors of mu, the sample variance within six of its own
 * (var of s^2 for a Poisson count: (mu + 2 mu^2) / n) plus the 1/12 the
 * normal approximation's rounding adds. */
static void check_counts(double mu, int n)
{
    gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
    gsl_rng_set(r, 20261203);
    double s1 = 0, s2 = 0;
    for (int i = 0; i < n; i++) {
        double k = sim_poisson(r, mu);
        if (!(k >= 0 && k == floor(k)))
            fail_msg("mean %g: count %.17g is not a whole number >= 0", mu, k);
        double d = k - mu; /* about the true mean: no cancellation at 1e15 */
        s1 += d;
        s2 += d * d;
    }
    gsl_rng_free(r);
    double mean_dev = s1 / n, var = s2 / n - mean_dev * mean_dev;
    if (fabs(mean_dev) > 6 * sqrt(mu / n))
        fail_msg("mean %g: sample mean off by %g (6 standard errors: %g)", mu, mean_dev,
                 6 * sqrt(mu / n));
    double var_tol = 6 * sqrt((mu + 2 * mu * mu) / n) + 1.0 / 12;
    if (fabs(var - mu) > var_tol)
        fail_msg("mean %g: sample variance %g (within %g of the mean expected)", mu, var,
                 var_tol);
}

static void test_small_means_exact(void **state)
{
    (void)state;
    /* many draws where the relative spread of the variance is large */
    const double mu[] = {1e-3, 0.1, 1, 30, 1e3};
    for (size_t i = 0; i < sizeof mu / sizeof *mu; i++)
        check_counts(mu[i], 400000);
}

static void test_large_means(void **state)
{
    (void)state;
    /* both sides of where GSL hands over, GSL's wrap (4.4e9) and hang
     * (1e10 and up), and the top of the scene ranges */
    const double mu[] = {1e6,  SIM_POISSON_GSL_MAX, nextafter(SIM_POISSON_GSL_MAX, INFINITY),
                         4.4e9, 1e10, 1e12, 1e15, 1e20};
    for (size_t i = 0; i < sizeof mu / sizeof *mu; i++)
        check_counts(mu[i], 40000);
}

static void test_degenerate_means(void **state)
{
    (void)state;
    gsl_rng *r = gsl_rng_alloc(gsl_rng_mt19937);
    assert_true(sim_poisson(r, 0) == 0);
    assert_true(sim_poisson(r, -5) == 0);
    assert_true(sim_poisson(r, NAN) == 0);
    assert_true(isinf(sim_poisson(r, INFINITY)));
    gsl_rng_free(r);
}

/* The shot noise of a reading e electrons deep: mean the signal, relative
 * variance 1/e, through the sensor pipeline (dark first when rate > 0). */
static void check_shot(double responsivity, double dark_rate, double level)
{
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    struct sim_effect_spec *fx_spec = &sc.effects[sc.n_effects];
    memset(fx_spec, 0, sizeof *fx_spec);
    if (dark_rate > 0) {
        fx_spec->kind = SIM_FX_DARK;
        fx_spec->level = dark_rate;
        fx_spec->index = sc.n_effects++;
        fx_spec = &sc.effects[sc.n_effects];
        memset(fx_spec, 0, sizeof *fx_spec);
    }
    fx_spec->kind = SIM_FX_SHOT_NOISE;
    fx_spec->index = sc.n_effects++;
    sim_effects *fx = sim_effects_new(&sc, NULL);
    assert_non_null(fx);
    const double t = 2, cos_i = 0.5, scale = responsivity * cos_i * t;
    const double want = level + dark_rate * t / scale, e = want * scale;
    const int n = 20000;
    double s1 = 0, s2 = 0;
    for (int i = 0; i < n; i++) {
        double v = level;
        struct sim_signal s = {.v = &v, .n = 1, .cos_i = cos_i, .integration_s = t,
                               .responsivity = responsivity};
        sim_effects_sensor(fx, &s);
        s1 += v / want - 1;
        s2 += (v / want - 1) * (v / want - 1);
    }
    sim_effects_free(fx);
    double m = s1 / n, var = s2 / n - m * m, rel_var = 1 / e;
    assert_close(m, 0, 6 * sqrt(rel_var / n));
    assert_rel_close(var, rel_var, 6 * sqrt(2.0 / n) + 1 / e);
}

static void test_shot_noise_at_the_top_of_the_scene_ranges(void **state)
{
    (void)state;
    check_shot(1e15, 0, 0.3);    /* 3e14 e- */
    check_shot(1e6, 1e12, 0.3);  /* 2e12 e- of dark, 3e5 of signal */
    check_shot(1e15, 1e12, 1e3); /* 1e18 e- */
}

/* Through the in-process rig: a scene at responsivity 1e15 with shot noise
 * reads the material, to six times its relative shot noise 1/sqrt(e). */
static void test_rig_reads_at_responsivity_1e15(void **state)
{
    (void)state;
    struct rig_profile rig;
    rig_profile_default(&rig);
    brdf_material *m = brdf_material_open("default", NULL);
    assert_non_null(m);
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    sc.responsivity = 1e15;
    sc.effects[0] = (struct sim_effect_spec){.kind = SIM_FX_SHOT_NOISE};
    sc.n_effects = 1;
    sim_rig *r = sim_rig_new_scene(&rig, m, &sc, NULL, NULL);
    assert_non_null(r);
    assert_int_equal(sim_rig_start_move(r, SIM_AXIS_SAMPLE, 20, NULL), 0);
    assert_int_equal(sim_rig_start_move(r, SIM_AXIS_ARM, 60, NULL), 0);
    assert_int_equal(sim_rig_wait(r, SIM_AXIS_SAMPLE, NULL), 0);
    assert_int_equal(sim_rig_wait(r, SIM_AXIS_ARM, NULL), 0);
    double exact[3];
    struct brdf_pair p;
    brdf_pair_inplane(20, 40, &p);
    brdf_material_eval(m, &p, 1, exact);
    for (int i = 0; i < 100; i++) {
        struct sim_reading rd;
        assert_int_equal(sim_rig_acquire(r, 0.05, &rd, NULL), 0);
        for (int c = 0; c < 3; c++) {
            double e = exact[c] * 1e15 * cos(20 * BRDF_DEG) * rd.integration_s;
            assert_true(e > 1e10); /* where GSL's counts wrapped or hung */
            assert_rel_close(rd.rgb[c], exact[c], 6 / sqrt(e));
        }
    }
    sim_rig_free(r);
    brdf_material_free(m);
}

/* Every effect at both ends of its documented range, loaded from a scene
 * file (the loader accepts what docs/scenes.md documents) and read through
 * the in-process rig: every reading comes back at once, finite and >= 0
 * where nothing can take it below (no read noise: it is the one effect
 * that may). */
static void read_scene(const char *text, int read_noise)
{
    char path[256];
    snprintf(path, sizeof path, "/tmp/gonio-range-%d.yaml", (int)getpid());
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
    struct sim_scene sc;
    struct gonio_err err = {0};
    int rc = sim_scene_load(path, &sc, &err);
    unlink(path);
    if (rc != 0)
        fail_msg("%s", err.msg);
    struct rig_profile rig;
    rig_profile_default(&rig);
    rig.auto_max_s = 600; /* the longest a rig profile allows */
    brdf_material *m = brdf_material_open("default", NULL);
    sim_rig *r = sim_rig_new_scene(&rig, m, &sc, NULL, &err);
    assert_non_null(r);
    const double at[][2] = {{0, 10}, {40, 85}, {80, 165}, {20, 60}};
    for (int i = 0; i < 40; i++) {
        assert_int_equal(sim_rig_start_move(r, SIM_AXIS_SAMPLE, at[i % 4][0], NULL), 0);
        assert_int_equal(sim_rig_start_move(r, SIM_AXIS_ARM, at[i % 4][1], NULL), 0);
        assert_int_equal(sim_rig_wait(r, SIM_AXIS_SAMPLE, NULL), 0);
        assert_int_equal(sim_rig_wait(r, SIM_AXIS_ARM, NULL), 0);
        struct sim_reading rd;
        assert_int_equal(sim_rig_acquire(r, 0.05, &rd, NULL), 0);
        for (int c = 0; c < 3; c++) {
            assert_true(isfinite(rd.rgb[c]));
            if (!read_noise)
                assert_true(rd.rgb[c] >= 0);
        }
    }
    sim_rig_free(r);
    brdf_material_free(m);
}

static void test_every_range_at_both_ends(void **state)
{
    (void)state;
    read_scene("material: default\n"
               "detector: {kind: rgb, responsivity: 1.0e15, target_e: 1.0e15}\n"
               "effects:\n"
               "  - {name: lamp_drift, sigma: 0.5, tau_s: 1.0e-3}\n"
               "  - {name: stray_light, floor: 1000}\n"
               "  - {name: dark, rate_e_per_s: 1.0e12}\n"
               "  - shot_noise\n"
               "  - {name: read_noise, sigma_e: 1.0e9}\n"
               "  - {name: saturation, full_well_e: 1.0e15}\n",
               1);
    read_scene("material: default\n"
               "detector: {kind: rgb, responsivity: 1.0e-6, target_e: 1}\n"
               "effects:\n"
               "  - {name: lamp_drift, sigma: 0.5, tau_s: 1.0e9}\n"
               "  - {name: dark, rate_e_per_s: 1.0e12}\n"
               "  - shot_noise\n"
               "  - {name: saturation, full_well_e: 1}\n",
               0);
    read_scene("material: default\n"
               "detector: {kind: spectral, responsivity: 1.0e15, target_e: 1}\n"
               "effects:\n"
               "  - {name: dark, rate_e_per_s: 1.0e12}\n"
               "  - shot_noise\n",
               0);
}

int main(void)
{
    alarm(60);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_small_means_exact),
        cmocka_unit_test(test_large_means),
        cmocka_unit_test(test_degenerate_means),
        cmocka_unit_test(test_shot_noise_at_the_top_of_the_scene_ranges),
        cmocka_unit_test(test_rig_reads_at_responsivity_1e15),
        cmocka_unit_test(test_every_range_at_both_ends),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
