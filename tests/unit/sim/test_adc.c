/* Raw detectors: the adc effect turns electrons into counts with the
 * statistics its parameters say (offset + gain x electrons, the dark,
 * shot and read noise carried through, the nonlinearity, the clip flagged),
 * the shutter leaves only dark and offset, the lamp monitor follows the
 * lamp, and the in-process driver reports counts with what the ADC states.
 * Statistical checks use fixed seeds, many draws and tolerances of four
 * standard errors. */
#include <math.h>
#include <string.h>

#include "brdf/material.h"
#include "drivers/drv_sim.h"
#include "rig/rig.h"
#include "sim/effects.h"
#include "sim/sim.h"
#include "tests/gonio_test.h"
#include "tests/unit/sim/effects_fixture.h"

static void add_adc(struct sim_scene *sc, double gain, double offset, int bits, double k)
{
    struct sim_effect_spec *a = add(sc, SIM_FX_ADC);
    a->gain = gain;
    a->offset = offset;
    a->bits = bits;
    a->nonlinearity = k;
}

/* The quantisation of a count rounded to the nearest integer adds 1/12 to
 * the variance. */
#define QUANT_VAR (1.0 / 12)

/* counts = offset + gain (S + D) on average, variance gain^2 (S + D +
 * sigma_r^2) + 1/12: Poisson signal and dark, Gaussian read noise. */
static void test_counts_mean_and_variance(void **state)
{
    (void)state;
    enum { N = 20000 };
    const double resp = 1e5, t = 0.2, rate = 2000, sigma_r = 15, g = 0.8, off = 1000;
    const double level[3] = {0.5, 0.05, 0}; /* 1/sr: 1e4, 1e3 and 0 signal electrons */
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    sc.seed = 11;
    add(&sc, SIM_FX_DARK)->level = rate;
    add(&sc, SIM_FX_SHOT_NOISE);
    add(&sc, SIM_FX_READ_NOISE)->sigma = sigma_r;
    add_adc(&sc, g, off, 16, 0);
    sim_effects *fx = sim_effects_new(&sc, NULL);
    assert_non_null(fx);
    double sum[3] = {0}, sum2[3] = {0};
    for (int i = 0; i < N; i++) {
        double v[3] = {level[0], level[1], level[2]};
        struct sim_signal s = {.v = v, .n = 3, .cos_i = 1, .integration_s = t,
                               .responsivity = resp, .monitor = NAN};
        sim_effects_sensor(fx, &s);
        assert_int_equal(s.counts, 1);
        assert_int_equal(s.flags, 0);
        assert_true(isnan(s.monitor)); /* no lamp_monitor: nothing written */
        for (int c = 0; c < 3; c++) {
            assert_close(v[c], round(v[c]), 0); /* whole counts */
            sum[c] += v[c];
            sum2[c] += v[c] * v[c];
        }
    }
    for (int c = 0; c < 3; c++) {
        double e = level[c] * resp * t + rate * t;
        double want_mean = off + g * e, want_var = g * g * (e + sigma_r * sigma_r) + QUANT_VAR;
        double mean = sum[c] / N, var = (sum2[c] - N * mean * mean) / (N - 1);
        assert_close(mean, want_mean, 4 * sqrt(want_var / N));
        assert_rel_close(var, want_var, 4 * sqrt(2.0 / (N - 1)));
    }
    sim_effects_free(fx);
}

/* Noise-free, the count is the nonlinear response rounded, exactly; at
 * 2^bits - 1 it clips and says so, just below it does not. */
static void test_nonlinearity_and_clip(void **state)
{
    (void)state;
    const double g = 20, off = 1000, k = 0.02, full = 65535;
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    add_adc(&sc, g, off, 16, k);
    sim_effects *fx = sim_effects_new(&sc, NULL);
    struct sim_adc_info info;
    assert_int_equal(sim_effects_adc(fx, &info), 1);
    assert_close(info.full_scale, full, 0);
    assert_close(info.nonlinearity, k, 0);
    /* x 1000 e- per 1/sr, x 20 ADU per e-: x = 20000, 60000, 80000, 64500 ADU */
    double v[4] = {1.0, 3.0, 4.0, 3.225};
    struct sim_signal s = {.v = v, .n = 4, .cos_i = 1, .integration_s = 1,
                           .responsivity = 1000, .monitor = NAN};
    sim_effects_sensor(fx, &s);
    for (int c = 0; c < 2; c++) {
        double x = g * 1000 * (c == 0 ? 1.0 : 3.0);
        assert_close(v[c], floor(off + x - k * x * x / full + 0.5), 0);
    }
    assert_close(v[0], 20878, 0); /* 21000 - 0.02 * 4e8 / 65535 = 20877.93 */
    assert_close(v[2], full, 0);
    assert_int_equal(s.flags, SIM_SIGNAL_SATURATED);
    /* 1000 + 64500 - 1269.6 = 64230: below the clip, not flagged */
    double w[1] = {3.225};
    s = (struct sim_signal){.v = w, .n = 1, .cos_i = 1, .integration_s = 1,
                            .responsivity = 1000, .monitor = NAN};
    sim_effects_sensor(fx, &s);
    assert_close(w[0], 64230, 0);
    assert_int_equal(s.flags, 0);
    sim_effects_free(fx);

    /* an 8-bit ADC clips at 255 */
    sim_scene_ideal(&sc, "default");
    add_adc(&sc, 1, 10, 8, 0);
    fx = sim_effects_new(&sc, NULL);
    double u[2] = {0.244, 0.246}; /* 254 and 256 counts before the clip */
    s = (struct sim_signal){.v = u, .n = 2, .cos_i = 1, .integration_s = 1,
                            .responsivity = 1000, .monitor = NAN};
    sim_effects_sensor(fx, &s);
    assert_close(u[0], 254, 0);
    assert_close(u[1], 255, 0);
    assert_int_equal(s.flags, SIM_SIGNAL_SATURATED);
    sim_effects_free(fx);
}

/* A raw scene on the in-process rig. */
static sim_rig *raw_rig(struct sim_scene *sc, double rate, double sigma_r, double monitor)
{
    sim_scene_ideal(sc, "default");
    sc->seed = 5;
    add(sc, SIM_FX_DARK)->level = rate;
    add(sc, SIM_FX_SHOT_NOISE);
    add(sc, SIM_FX_READ_NOISE)->sigma = sigma_r;
    add_adc(sc, 0.8, 1000, 16, 0.02);
    if (monitor > 0)
        add(sc, SIM_FX_LAMP_MONITOR)->level = monitor;
    sim_rig *rig = sim_rig_new_scene(&rig_profile, material, sc, NULL, NULL);
    assert_non_null(rig);
    return rig;
}

/* Shutter closed: offset + gain x dark, with the dark's shot noise and the
 * read noise, at the integration asked; the monitor still sees the lamp.
 * Open, the material's light is back. */
static void test_shutter_leaves_dark_and_offset(void **state)
{
    (void)state;
    enum { N = 4000 };
    const double rate = 2000, sigma_r = 15, t = 0.2, mon = 1e6;
    struct sim_scene sc;
    sim_rig *rig = raw_rig(&sc, rate, sigma_r, mon);
    drv_detector *det = drv_detector_new_sim(rig);
    struct drv_reading r;
    assert_int_equal(drv_detector_shutter(det, 1, NULL), 0);
    double sum = 0, sum2 = 0, msum = 0;
    for (int i = 0; i < N; i++) {
        assert_int_equal(drv_detector_acquire(det, t, &r, NULL), 0);
        assert_close(r.integration_s, t, 0);
        for (int c = 0; c < 3; c++) {
            sum += r.rgb[c];
            sum2 += r.rgb[c] * r.rgb[c];
        }
        msum += r.monitor;
    }
    /* the default material's x = gain S + ... would be tens of thousands */
    double e = rate * t, x = 0.8 * e;
    double want_mean = 1000 + x - 0.02 * x * x / 65535; /* the k term: 0.03 */
    double want_var = 0.64 * (e + sigma_r * sigma_r) + QUANT_VAR;
    double mean = sum / (3 * N), var = (sum2 - 3 * N * mean * mean) / (3 * N - 1);
    assert_close(mean, want_mean, 4 * sqrt(want_var / (3 * N)));
    assert_rel_close(var, want_var, 4 * sqrt(2.0 / (3 * N - 1)));
    assert_close(msum / N, mon * t, 4 * sqrt(mon * t / N));

    /* open, off the specular peak */
    assert_int_equal(drv_detector_shutter(det, 0, NULL), 0);
    assert_int_equal(sim_rig_start_move(rig, SIM_AXIS_ARM, 60, NULL), 0);
    assert_int_equal(sim_rig_wait(rig, SIM_AXIS_ARM, NULL), 0);
    assert_int_equal(drv_detector_acquire(det, t, &r, NULL), 0);
    double lit[3];
    sim_rig_sample(rig, lit);
    for (int c = 0; c < 3; c++) {
        double el = lit[c] * 1e6 * t + e; /* normal incidence: the sample axis at 0 */
        double xe = 0.8 * el;
        assert_true(xe > 10 * x);
        assert_close(r.rgb[c], 1000 + xe - 0.02 * xe * xe / 65535,
                     5 * 0.8 * sqrt(el + sigma_r * sigma_r) + 1);
    }
    drv_detector_free(det);
    sim_rig_free(rig);
}

/* The monitor follows the lamp's drift: its counts over rate x t track the
 * signal's change to within its own Poisson noise, while the lamp itself
 * wanders by tens of percent; and that noise is Poisson. */
static void test_lamp_monitor_follows_the_lamp(void **state)
{
    (void)state;
    enum { N = 4000 };
    const double rate = 1e6, t = 0.1, v0 = 0.3;
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    struct sim_effect_spec *drift = add(&sc, SIM_FX_LAMP_DRIFT);
    drift->sigma = 0.2;
    drift->tau_s = 10;
    add(&sc, SIM_FX_LAMP_MONITOR)->level = rate;
    sim_effects *fx = sim_effects_new(&sc, NULL);
    double z2 = 0, spread = 0;
    for (int i = 0; i < N; i++) {
        double v = v0;
        struct sim_signal s = {.v = &v, .n = 1, .cos_i = 1, .integration_s = t,
                               .now_s = 5.0 * i, .responsivity = 1e3, .monitor = NAN};
        sim_effects_light(fx, &s);
        sim_effects_sensor(fx, &s);
        double lamp = v / v0, mean = rate * t * lamp;
        double z = (s.monitor - mean) / sqrt(mean);
        z2 += z * z;
        spread += (lamp - 1) * (lamp - 1);
    }
    assert_true(sqrt(spread / N) > 0.1);          /* the lamp did drift */
    assert_close(z2 / N, 1, 4 * sqrt(2.0 / N));    /* and the monitor saw it, Poisson */
    sim_effects_free(fx);
}

/* The in-process driver reports what the scene's ADC states, at the
 * integration asked (a raw detector has no ideal meter); a scene without
 * an adc keeps its calibrated BRDF and no monitor. */
static void test_driver_reports_counts(void **state)
{
    (void)state;
    struct sim_scene sc;
    sim_rig *rig = raw_rig(&sc, 500, 12, 1e7);
    drv_detector *det = drv_detector_new_sim(rig);
    struct drv_reading r;
    assert_int_equal(drv_detector_acquire(det, 0.037, &r, NULL), 0);
    assert_int_equal(r.unit, DRV_UNIT_COUNTS);
    assert_close(r.full_scale, 65535, 0);
    assert_close(r.nonlinearity, 0.02, 0);
    assert_close(r.integration_s, 0.037, 0);
    assert_int_equal(r.gain_state, 0);
    assert_close(r.monitor, 1e7 * 0.037, 5 * sqrt(1e7 * 0.037));
    for (int c = 0; c < 3; c++) {
        assert_close(r.rgb[c], round(r.rgb[c]), 0);
        assert_true(r.rgb[c] > 1000 && r.rgb[c] <= 65535);
    }
    drv_detector_free(det);
    sim_rig_free(rig);

    sim_scene_ideal(&sc, "default");
    add(&sc, SIM_FX_SHOT_NOISE);
    rig = sim_rig_new_scene(&rig_profile, material, &sc, NULL, NULL);
    det = drv_detector_new_sim(rig);
    assert_int_equal(drv_detector_acquire(det, 0.037, &r, NULL), 0);
    assert_int_equal(r.unit, DRV_UNIT_BRDF);
    assert_close(r.full_scale, 0, 0);
    assert_true(isnan(r.monitor));
    assert_true(r.integration_s != 0.037); /* the ideal meter chose it */
    drv_detector_free(det);
    sim_rig_free(rig);
}

/* The lab scene reads out raw counts with the parameters docs/scenes.md gives. */
static void test_lab_scene(void **state)
{
    (void)state;
    struct sim_scene sc;
    struct gonio_err err = {0};
    if (sim_scene_load("lab", &sc, &err) != 0) {
        print_error("%s\n", err.msg);
        fail();
    }
    sim_effects *fx = sim_effects_new(&sc, NULL);
    struct sim_adc_info info;
    assert_int_equal(sim_effects_adc(fx, &info), 1);
    assert_close(info.gain, 0.8, 0);
    assert_close(info.offset, 1000, 0);
    assert_close(info.full_scale, 65535, 0);
    assert_close(info.nonlinearity, 0.02, 0);
    sim_effects_free(fx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_counts_mean_and_variance),
        cmocka_unit_test(test_nonlinearity_and_clip),
        cmocka_unit_test(test_shutter_leaves_dark_and_offset),
        cmocka_unit_test(test_lamp_monitor_follows_the_lamp),
        cmocka_unit_test(test_driver_reports_counts),
        cmocka_unit_test(test_lab_scene),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
