/* Scene effects: a scene with none returns the material's exact values and
 * positions bit for bit; each effect changes only what it should; and the
 * random ones have the statistics their parameters say (fixed seeds, many
 * draws, tolerances of about four standard errors). */
#include <string.h>

#include "brdf/material.h"
#include "drivers/drv_sim.h"
#include "rig/rig.h"
#include "sim/effects.h"
#include "sim/exposure.h"
#include "sim/sim.h"
#include "tests/gonio_test.h"
#include "tests/unit/sim/effects_fixture.h"

/* The points of a small in-plane sweep, with back-and-forth moves so both
 * approach directions occur. */
static const double sweep[][2] = {{0, 10},  {10, 30}, {20, 40},  {5, 35},  {40, 85},
                                  {30, 50}, {60, 125}, {15, 20}, {45, 100}, {25, 70}};
#define N_SWEEP (sizeof sweep / sizeof sweep[0])

struct run {
    double s[N_SWEEP], a[N_SWEEP];
    double rgb[N_SWEEP][3];
    double t[N_SWEEP];
    unsigned flags[N_SWEEP];
};

static void run_sweep(const struct sim_scene *sc, struct run *out)
{
    struct gonio_err err = {0};
    sim_rig *rig = sim_rig_new_scene(&rig_profile, material, sc, NULL, &err);
    assert_non_null(rig);
    for (size_t i = 0; i < N_SWEEP; i++) {
        assert_int_equal(sim_rig_start_move(rig, SIM_AXIS_SAMPLE, sweep[i][0], &err), 0);
        assert_int_equal(sim_rig_start_move(rig, SIM_AXIS_ARM, sweep[i][1], &err), 0);
        assert_int_equal(sim_rig_wait(rig, SIM_AXIS_SAMPLE, &err), 0);
        assert_int_equal(sim_rig_wait(rig, SIM_AXIS_ARM, &err), 0);
        struct sim_reading r;
        assert_int_equal(sim_rig_acquire(rig, rig_profile.integration_s, &r, &err), 0);
        out->s[i] = sim_rig_position(rig, SIM_AXIS_SAMPLE);
        out->a[i] = sim_rig_position(rig, SIM_AXIS_ARM);
        memcpy(out->rgb[i], r.rgb, sizeof r.rgb);
        out->t[i] = r.integration_s;
        out->flags[i] = r.flags;
    }
    sim_rig_free(rig);
}

static void material_at(double s, double a, double rgb[3])
{
    struct brdf_pair p;
    brdf_pair_inplane(s, a - s, &p);
    brdf_material_eval(material, &p, 1, rgb);
}

static void test_no_effects_is_the_material_bit_for_bit(void **state)
{
    (void)state;
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    struct run r;
    run_sweep(&sc, &r);
    for (size_t i = 0; i < N_SWEEP; i++) {
        double want[3];
        material_at(sweep[i][0], sweep[i][1], want);
        assert_memory_equal(&r.s[i], &sweep[i][0], sizeof(double));
        assert_memory_equal(&r.a[i], &sweep[i][1], sizeof(double));
        assert_memory_equal(r.rgb[i], want, sizeof want);
        assert_memory_equal(&r.t[i], &rig_profile.integration_s, sizeof(double));
        assert_int_equal(r.flags[i], 0);
    }
    sim_effects *fx = sim_effects_new(&sc, NULL);
    assert_int_equal(sim_effects_count(fx), 0);
    assert_null(sim_effects_faults(fx));
    sim_effects_free(fx);
}

static void test_stray_light_adds_exactly_its_floor(void **state)
{
    (void)state;
    struct sim_scene ideal, sc;
    sim_scene_ideal(&ideal, "default");
    sim_scene_ideal(&sc, "default");
    add(&sc, SIM_FX_STRAY_LIGHT)->level = 0.0123;
    struct run a, b;
    run_sweep(&ideal, &a);
    run_sweep(&sc, &b);
    assert_memory_equal(a.s, b.s, sizeof a.s);
    assert_memory_equal(a.a, b.a, sizeof a.a);
    assert_memory_equal(a.t, b.t, sizeof a.t);
    for (size_t i = 0; i < N_SWEEP; i++)
        for (int c = 0; c < 3; c++) {
            double want = a.rgb[i][c] + 0.0123;
            assert_memory_equal(&b.rgb[i][c], &want, sizeof want);
        }
}

static void test_shot_noise_changes_values_not_positions(void **state)
{
    (void)state;
    struct sim_scene ideal, sc;
    sim_scene_ideal(&ideal, "default");
    sim_scene_ideal(&sc, "default");
    add(&sc, SIM_FX_SHOT_NOISE);
    struct run a, b;
    run_sweep(&ideal, &a);
    run_sweep(&sc, &b);
    assert_memory_equal(a.s, b.s, sizeof a.s);
    assert_memory_equal(a.a, b.a, sizeof a.a);
    int differ = 0;
    for (size_t i = 0; i < N_SWEEP; i++)
        for (int c = 0; c < 3; c++) {
            differ += a.rgb[i][c] != b.rgb[i][c];
            /* ~30000 e- in the brightest channel: within 1% (> 5 sigma) */
            assert_rel_close(b.rgb[i][c], a.rgb[i][c], 0.03);
        }
    assert_true(differ >= 25);
}

static void test_jitter_changes_positions_and_values_follow(void **state)
{
    (void)state;
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    add(&sc, SIM_FX_JITTER)->sigma = 0.05;
    struct run r;
    run_sweep(&sc, &r);
    int moved = 0;
    for (size_t i = 0; i < N_SWEEP; i++) {
        moved += r.s[i] != sweep[i][0];
        assert_close(r.s[i], sweep[i][0], 0.3);
        assert_close(r.a[i], sweep[i][1], 0.3);
        double want[3];
        material_at(r.s[i], r.a[i], want); /* the encoder sees jitter: values match it */
        assert_memory_equal(r.rgb[i], want, sizeof want);
    }
    assert_true(moved >= (int)N_SWEEP - 1);
}

static void test_jitter_statistics(void **state)
{
    (void)state;
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    add(&sc, SIM_FX_JITTER)->sigma = 0.05;
    sim_rig *rig = sim_rig_new_scene(&rig_profile, material, &sc, NULL, NULL);
    const int n = 4000;
    double sum = 0, sum2 = 0;
    for (int i = 0; i < n; i++) {
        double target = (i % 2) ? 20 : 10;
        assert_int_equal(sim_rig_start_move(rig, SIM_AXIS_SAMPLE, target, NULL), 0);
        assert_int_equal(sim_rig_wait(rig, SIM_AXIS_SAMPLE, NULL), 0);
        double d = sim_rig_position(rig, SIM_AXIS_SAMPLE) - target;
        sum += d;
        sum2 += d * d;
        /* the same command again is no move: no new draw */
        double here = sim_rig_position(rig, SIM_AXIS_SAMPLE);
        assert_int_equal(sim_rig_start_move(rig, SIM_AXIS_SAMPLE, target, NULL), 0);
        assert_int_equal(sim_rig_wait(rig, SIM_AXIS_SAMPLE, NULL), 0);
        assert_memory_equal(&here, &(double){sim_rig_position(rig, SIM_AXIS_SAMPLE)},
                            sizeof here);
    }
    double mean = sum / n, sd = sqrt(sum2 / n - mean * mean);
    assert_close(mean, 0, 4 * 0.05 / sqrt(n));
    assert_rel_close(sd, 0.05, 4 * sqrt(0.5 / n));
    sim_rig_free(rig);
}

static void test_backlash_only_on_negative_approach(void **state)
{
    (void)state;
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    struct sim_effect_spec *b = add(&sc, SIM_FX_BACKLASH);
    b->level = 0.25;
    b->axes = 1u << SIM_AXIS_SAMPLE;
    sim_rig *rig = sim_rig_new_scene(&rig_profile, material, &sc, NULL, NULL);
    /* s: 0 -> 20 (positive), -> 10 (negative), -> 15 (positive); arm fixed
     * at 60 (one positive move) */
    const double targets[] = {20, 10, 15};
    const double slack[] = {0, 0.25, 0};
    for (int i = 0; i < 3; i++) {
        assert_int_equal(sim_rig_start_move(rig, SIM_AXIS_SAMPLE, targets[i], NULL), 0);
        assert_int_equal(sim_rig_start_move(rig, SIM_AXIS_ARM, 60, NULL), 0);
        assert_int_equal(sim_rig_wait(rig, SIM_AXIS_SAMPLE, NULL), 0);
        assert_int_equal(sim_rig_wait(rig, SIM_AXIS_ARM, NULL), 0);
        /* the motor's encoder reports the target: backlash is hidden */
        assert_close(sim_rig_position(rig, SIM_AXIS_SAMPLE), targets[i], 0);
        struct sim_reading r;
        assert_int_equal(sim_rig_acquire(rig, 0.05, &r, NULL), 0);
        double want[3];
        material_at(targets[i] + slack[i], 60, want);
        assert_memory_equal(r.rgb, want, sizeof want);
    }
    sim_rig_free(rig);
}

/* A signal of three levels read nd times through the sensor stages. */
static void sensor_stats(sim_effects *fx, const double level[3], double scale_cos,
                         double scale_t, double mean[3], double var[3])
{
    const int nd = 20000;
    double s1[3] = {0}, s2[3] = {0};
    for (int i = 0; i < nd; i++) {
        double v[3] = {level[0], level[1], level[2]};
        struct sim_signal s = {.v = v, .n = 3, .cos_i = scale_cos, .integration_s = scale_t,
                               .responsivity = 1000};
        sim_effects_sensor(fx, &s);
        for (int c = 0; c < 3; c++) {
            s1[c] += v[c];
            s2[c] += v[c] * v[c];
        }
    }
    for (int c = 0; c < 3; c++) {
        mean[c] = s1[c] / nd;
        var[c] = s2[c] / nd - mean[c] * mean[c];
    }
}

static void test_shot_noise_variance_proportional_to_signal(void **state)
{
    (void)state;
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    add(&sc, SIM_FX_SHOT_NOISE);
    sim_effects *fx = sim_effects_new(&sc, NULL);
    assert_true(sim_effects_noisy(fx));
    /* scale = 1000 e-/s * 0.5 * 0.4 s = 200 e- per 1/sr: 20, 400, 8000 e- */
    const double level[3] = {0.1, 2, 40};
    double mean[3], var[3];
    sensor_stats(fx, level, 0.5, 0.4, mean, var);
    for (int c = 0; c < 3; c++) {
        double e = level[c] * 200, want_var = level[c] / 200; /* Poisson: var e = e */
        assert_close(mean[c], level[c], 4 * sqrt(want_var / 20000));
        assert_rel_close(var[c], want_var, 4 * sqrt(2.0 / 20000) + 1.0 / e);
    }
    sim_effects_free(fx);
}

static void test_read_noise_and_dark(void **state)
{
    (void)state;
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    add(&sc, SIM_FX_READ_NOISE)->sigma = 30; /* electrons */
    sim_effects *fx = sim_effects_new(&sc, NULL);
    const double level[3] = {0.01, 1, 100};
    double mean[3], var[3];
    sensor_stats(fx, level, 1, 0.1, mean, var); /* 100 e- per 1/sr */
    for (int c = 0; c < 3; c++) {
        double sd = 30.0 / 100; /* independent of the signal */
        assert_close(mean[c], level[c], 4 * sd / sqrt(20000));
        assert_rel_close(var[c], sd * sd, 4 * sqrt(2.0 / 20000));
    }
    sim_effects_free(fx);

    /* dark: rate * t electrons, i.e. rate / (R cos) in 1/sr, exactly */
    sim_scene_ideal(&sc, "default");
    add(&sc, SIM_FX_DARK)->level = 250;
    fx = sim_effects_new(&sc, NULL);
    double v[3] = {0.5, 1.5, 0};
    struct sim_signal s = {.v = v, .n = 3, .cos_i = 0.5, .integration_s = 0.2,
                           .responsivity = 1000};
    sim_effects_sensor(fx, &s);
    double off = 250 * 0.2 / (1000 * 0.5 * 0.2);
    assert_rel_close(v[0], 0.5 + off, 1e-15);
    assert_rel_close(v[1], 1.5 + off, 1e-15);
    assert_rel_close(v[2], off, 1e-15);
    sim_effects_free(fx);
}

static void test_saturation_clips_and_flags(void **state)
{
    (void)state;
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    add(&sc, SIM_FX_SATURATION)->level = 1000;
    sim_effects *fx = sim_effects_new(&sc, NULL);
    double v[3] = {0.5, 1.0, 2.5}; /* x 1000 e- per 1/sr */
    struct sim_signal s = {.v = v, .n = 3, .cos_i = 1, .integration_s = 1, .responsivity = 1000};
    sim_effects_sensor(fx, &s);
    assert_close(v[0], 0.5, 0);
    assert_close(v[1], 1.0, 0);
    assert_close(v[2], 1.0, 0);
    assert_int_equal(s.flags, SIM_SIGNAL_SATURATED);
    double w[3] = {0.5, 0.9, 0.99};
    s = (struct sim_signal){.v = w, .n = 3, .cos_i = 1, .integration_s = 1, .responsivity = 1000};
    sim_effects_sensor(fx, &s);
    assert_int_equal(s.flags, 0);
    sim_effects_free(fx);

    /* through the in-process driver: the reading's flag */
    sim_scene_ideal(&sc, "default");
    sc.responsivity = 1e9;
    add(&sc, SIM_FX_SATURATION)->level = 1000;
    sim_rig *rig = sim_rig_new_scene(&rig_profile, material, &sc, NULL, NULL);
    drv_detector *det = drv_detector_new_sim(rig);
    struct drv_reading r;
    assert_int_equal(drv_detector_acquire(det, 0.05, &r, NULL), 0);
    assert_int_equal(r.flags, DRV_READING_SATURATED);
    assert_close(r.rgb[0], 1000 / (1e9 * 0.05), 1e-18); /* normal incidence */
    drv_detector_free(det);
    sim_rig_free(rig);
}

static void test_lamp_drift(void **state)
{
    (void)state;
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    struct sim_effect_spec *d = add(&sc, SIM_FX_LAMP_DRIFT);
    d->sigma = 0.02;
    d->tau_s = 1;
    sim_effects *fx = sim_effects_new(&sc, NULL);
    const int n = 5000;
    double s1 = 0, s2 = 0;
    for (int i = 0; i < n; i++) {
        double v = 2.0;
        struct sim_signal s = {.v = &v, .n = 1, .now_s = 100.0 * i};
        sim_effects_light(fx, &s);
        if (i == 0)
            assert_close(v, 2.0, 0); /* calibrated at the start */
        double g = v / 2.0 - 1;
        s1 += g;
        s2 += g * g;
    }
    /* readings 100 tau apart: independent N(0, sigma^2) */
    double mean = s1 / n, sd = sqrt(s2 / n - mean * mean);
    assert_close(mean, 0, 4 * 0.02 / sqrt(n));
    assert_rel_close(sd, 0.02, 4 * sqrt(0.5 / n));
    sim_effects_free(fx);

    /* slow: over 1 s with tau 1e6 s the lamp hardly moves */
    d->tau_s = 1e6;
    fx = sim_effects_new(&sc, NULL);
    double prev = 1;
    for (int i = 0; i < 1000; i++) {
        double v = 1.0;
        struct sim_signal s = {.v = &v, .n = 1, .now_s = i};
        sim_effects_light(fx, &s);
        assert_close(v, prev, 5 * 0.02 * sqrt(2.0 / 1e6));
        prev = v;
    }
    sim_effects_free(fx);
}

/* The drift's size over the spacing of a capture's readings, not only its
 * long-run spread: x(t + dt) - a x(t), a = exp(-dt / tau), is N(0, sigma^2
 * (1 - a^2)) whatever x(t) was. Checked at the lab scene's tau (1800 s)
 * with readings 2 s apart, where a drift 30 times slower (or weaker) moves
 * the lamp 30 times less, and at dt = tau; the residual variance within
 * six standard errors (6 sqrt(2 / n): 6%) both ways. */
static void check_drift_steps(double sigma, double tau_s, double dt)
{
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    struct sim_effect_spec *d = add(&sc, SIM_FX_LAMP_DRIFT);
    d->sigma = sigma;
    d->tau_s = tau_s;
    sim_effects *fx = sim_effects_new(&sc, NULL);
    const int n = 20000;
    const double a = exp(-dt / tau_s), want = sigma * sigma * -expm1(-2 * dt / tau_s);
    double prev = 0, s1 = 0, s2 = 0;
    for (int i = 0; i <= n; i++) {
        double v = 3.0;
        struct sim_signal s = {.v = &v, .n = 1, .now_s = 1000 + dt * i};
        sim_effects_light(fx, &s);
        double x = v / 3.0 - 1;
        if (i > 0) {
            double r = x - a * prev;
            s1 += r;
            s2 += r * r;
        }
        prev = x;
    }
    sim_effects_free(fx);
    double mean = s1 / n, var = s2 / n - mean * mean;
    assert_close(mean, 0, 6 * sqrt(want / n));
    assert_rel_close(var, want, 6 * sqrt(2.0 / n));
}

static void test_lamp_drift_steps(void **state)
{
    (void)state;
    check_drift_steps(0.005, 1800, 2);    /* the lab scene, a reading every 2 s */
    check_drift_steps(0.03, 300, 300);    /* bad-day's, a tau apart */
    check_drift_steps(0.02, 1e9, 1e-7);   /* 1 - a^2 = 2e-16: 1 - a * a is 11% off */
}

/* A lamp emits no negative light: at the largest sigma (0.5) the output
 * holds at 0 when x < -1, as often as a normal draw is below -2 sigma. */
static void test_lamp_drift_never_negative(void **state)
{
    (void)state;
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    struct sim_effect_spec *d = add(&sc, SIM_FX_LAMP_DRIFT);
    d->sigma = 0.5;
    d->tau_s = 1;
    sim_effects *fx = sim_effects_new(&sc, NULL);
    const int n = 20000;
    int dark = 0;
    for (int i = 0; i <= n; i++) {
        double v = 1.0;
        struct sim_signal s = {.v = &v, .n = 1, .now_s = 100.0 * i};
        sim_effects_light(fx, &s);
        assert_true(v >= 0);
        dark += i > 0 && v == 0;
    }
    sim_effects_free(fx);
    const double p = 0.0227501319481792; /* P(z < -2) */
    assert_close(dark / (double)n, p, 6 * sqrt(p * (1 - p) / n));
}

/* Streams are the effect's own: same seed, same draws; another effect in
 * the scene (here one that draws but changes nothing) leaves them alone;
 * another seed changes them. */
static void test_streams_reproducible_and_independent(void **state)
{
    (void)state;
    struct sim_scene a, b, c;
    sim_scene_ideal(&a, "default");
    add(&a, SIM_FX_SHOT_NOISE);
    b = a;
    add(&b, SIM_FX_READ_NOISE)->sigma = 0; /* draws N(0, 0) = 0 */
    c = a;
    c.seed = 2;
    sim_effects *fa = sim_effects_new(&a, NULL), *fa2 = sim_effects_new(&a, NULL);
    sim_effects *fb = sim_effects_new(&b, NULL), *fc = sim_effects_new(&c, NULL);
    int differ_c = 0;
    for (int i = 0; i < 200; i++) {
        double va[3] = {1, 2, 3}, va2[3] = {1, 2, 3}, vb[3] = {1, 2, 3}, vc[3] = {1, 2, 3};
        struct sim_signal s = {.n = 3, .cos_i = 1, .integration_s = 1, .responsivity = 100};
        s.v = va;
        sim_effects_sensor(fa, &s);
        s.v = va2;
        sim_effects_sensor(fa2, &s);
        s.v = vb;
        sim_effects_sensor(fb, &s);
        s.v = vc;
        sim_effects_sensor(fc, &s);
        assert_memory_equal(va, va2, sizeof va);
        for (int k = 0; k < 3; k++)
            assert_true(va[k] == vb[k]);
        differ_c += memcmp(va, vc, sizeof va) != 0;
    }
    assert_true(differ_c > 150);
    sim_effects_free(fa);
    sim_effects_free(fa2);
    sim_effects_free(fb);
    sim_effects_free(fc);
}

static void test_stall_fails_the_wait_naming_the_alarm(void **state)
{
    (void)state;
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    struct sim_effect_spec *st = add(&sc, SIM_FX_STALL);
    st->axes = 1u << SIM_AXIS_ARM;
    st->at_moves[st->n_at_moves++] = 3;
    st->code = 0x10;
    struct rig_profile no_tries = rig_profile; /* recovery: tests/unit/drivers/test_axis_mechanics.c */
    no_tries.mech.move_retries = 0;
    sim_rig *rig = sim_rig_new_scene(&no_tries, material, &sc, NULL, NULL);
    drv_axis *arm = drv_axis_new_sim(rig, SIM_AXIS_ARM);
    struct gonio_err err = {0};
    const double targets[] = {20, 40, 80};
    for (int i = 0; i < 2; i++) {
        assert_int_equal(drv_axis_start_move(arm, targets[i], &err), 0);
        assert_int_equal(drv_axis_wait(arm, &err), 0);
    }
    assert_int_equal(drv_axis_start_move(arm, 80, &err), 0);
    assert_int_equal(drv_axis_wait(arm, &err), -GONIO_EDEVICE);
    assert_int_equal(err.code, GONIO_EDEVICE);
    assert_string_equal(err.msg, "axis arm: drive alarm 0x10 (excessive position deviation)");
    double pos;
    assert_int_equal(drv_axis_position(arm, &pos, NULL), 0);
    assert_true(pos > 40 + 0.19 * 40 && pos < 40 + 0.81 * 40); /* stopped part-way */
    assert_int_equal(sim_rig_alarm(rig, SIM_AXIS_ARM), 0x10);
    assert_int_equal(drv_axis_start_move(arm, 10, &err), -GONIO_EDEVICE);
    assert_non_null(strstr(err.msg, "in alarm"));
    sim_rig_reset_alarm(rig, SIM_AXIS_ARM);
    assert_int_equal(drv_axis_start_move(arm, 10, &err), 0);
    assert_int_equal(drv_axis_wait(arm, &err), 0);
    assert_close(sim_rig_position(rig, SIM_AXIS_ARM), 10, 0);
    drv_axis_free(arm);
    sim_rig_free(rig);
}

static void test_alarm_rate(void **state)
{
    (void)state;
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    struct sim_effect_spec *al = add(&sc, SIM_FX_ALARM);
    al->rate = 0.2;
    al->code = 0x30;
    al->axes = 1u << SIM_AXIS_SAMPLE;
    sim_rig *rig = sim_rig_new_scene(&rig_profile, material, &sc, NULL, NULL);
    const int n = 5000;
    int alarms = 0;
    for (int i = 0; i < n; i++) {
        double from = sim_rig_position(rig, SIM_AXIS_SAMPLE);
        assert_int_equal(sim_rig_start_move(rig, SIM_AXIS_SAMPLE, (i % 2) ? 30 : -30, NULL), 0);
        if (sim_rig_wait(rig, SIM_AXIS_SAMPLE, NULL) < 0) {
            alarms++;
            assert_int_equal(sim_rig_alarm(rig, SIM_AXIS_SAMPLE), 0x30);
            assert_close(sim_rig_position(rig, SIM_AXIS_SAMPLE), from, 0); /* never moved */
            sim_rig_reset_alarm(rig, SIM_AXIS_SAMPLE);
        }
    }
    assert_close((double)alarms / n, 0.2, 4 * sqrt(0.2 * 0.8 / n));
    sim_rig_free(rig);
}

static void test_comm_faults(void **state)
{
    (void)state;
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    struct sim_effect_spec *f = add(&sc, SIM_FX_COMM_FAULTS);
    f->drop = 0.1;
    f->corrupt = 0.05;
    f->late = 0.02;
    f->timeout_s = 0.25;
    f->retries = 0;
    sim_effects *fx = sim_effects_new(&sc, NULL);
    sim_faults *faults = sim_effects_faults(fx);
    assert_non_null(faults);
    const int n = 100000;
    long counts[4];
    for (int i = 0; i < n; i++)
        sim_faults_next(faults, NULL);
    sim_faults_counts(faults, counts);
    const double want[4] = {0.83, 0.1, 0.05, 0.02};
    for (int k = 0; k < 4; k++)
        assert_close((double)counts[k] / n, want[k], 4 * sqrt(want[k] * (1 - want[k]) / n));
    sim_effects_free(fx);

    /* in-process driver, no retries: a dropped or late reply fails the
     * call after the timeout, a corrupted one at once */
    sim_rig *rig = sim_rig_new_scene(&rig_profile, material, &sc, NULL, NULL);
    drv_axis *ax = drv_axis_new_sim(rig, SIM_AXIS_SAMPLE);
    int fails = 0;
    for (int i = 0; i < 2000; i++) {
        struct gonio_err err = {0};
        double before = sim_rig_now(rig), pos;
        if (drv_axis_position(ax, &pos, &err) < 0) {
            fails++;
            assert_int_equal(err.code, GONIO_EDEVICE);
            double cost = sim_rig_now(rig) - before;
            if (strstr(err.msg, "corrupted"))
                assert_close(cost, 0, 0);
            else
                assert_close(cost, 0.25, 1e-12);
        }
    }
    assert_close(fails / 2000.0, 0.17, 4 * sqrt(0.17 * 0.83 / 2000));
    drv_axis_free(ax);
    sim_rig_free(rig);

    /* three retries: a call fails only when four exchanges in a row fail */
    sc.effects[0].drop = 0.5;
    sc.effects[0].corrupt = sc.effects[0].late = 0;
    sc.effects[0].retries = 3;
    rig = sim_rig_new_scene(&rig_profile, material, &sc, NULL, NULL);
    drv_detector *det = drv_detector_new_sim(rig);
    fails = 0;
    for (int i = 0; i < 4000; i++) {
        struct drv_reading r;
        fails += drv_detector_acquire(det, 0.01, &r, NULL) < 0;
    }
    assert_close(fails / 4000.0, 0.0625, 4 * sqrt(0.0625 * 0.9375 / 4000));
    drv_detector_free(det);
    sim_rig_free(rig);
}

static void test_auto_exposure(void **state)
{
    (void)state;
    struct sim_scene sc;
    sim_scene_ideal(&sc, "default");
    add(&sc, SIM_FX_READ_NOISE)->sigma = 0; /* noise in the scene, none in the values */
    sc.target_e = 30000;
    const double resp[] = {1e6, 1e3, 1e12};
    for (int i = 0; i < 3; i++) {
        sc.responsivity = resp[i];
        sim_rig *rig = sim_rig_new_scene(&rig_profile, material, &sc, NULL, NULL);
        assert_int_equal(sim_rig_start_move(rig, SIM_AXIS_SAMPLE, 30, NULL), 0);
        assert_int_equal(sim_rig_start_move(rig, SIM_AXIS_ARM, 70, NULL), 0);
        assert_int_equal(sim_rig_wait(rig, SIM_AXIS_SAMPLE, NULL), 0);
        assert_int_equal(sim_rig_wait(rig, SIM_AXIS_ARM, NULL), 0);
        double rgb[3];
        material_at(30, 70, rgb);
        double peak = fmax(rgb[0], fmax(rgb[1], rgb[2]));
        double t = 30000 / (peak * resp[i] * cos(30 * BRDF_DEG));
        t = fmin(fmax(t, rig_profile.auto_min_s), rig_profile.auto_max_s);
        double before = sim_rig_now(rig);
        struct sim_reading r;
        assert_int_equal(sim_rig_acquire(rig, 0.05, &r, NULL), 0);
        assert_rel_close(r.integration_s, t, 1e-12);
        assert_rel_close(sim_rig_now(rig) - before, t, 1e-12);
        if (i == 1)
            assert_close(r.integration_s, rig_profile.auto_max_s, 0); /* weak: capped */
        if (i == 2)
            assert_close(r.integration_s, rig_profile.auto_min_s, 0);
        sim_rig_free(rig);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_no_effects_is_the_material_bit_for_bit),
        cmocka_unit_test(test_stray_light_adds_exactly_its_floor),
        cmocka_unit_test(test_shot_noise_changes_values_not_positions),
        cmocka_unit_test(test_jitter_changes_positions_and_values_follow),
        cmocka_unit_test(test_jitter_statistics),
        cmocka_unit_test(test_backlash_only_on_negative_approach),
        cmocka_unit_test(test_shot_noise_variance_proportional_to_signal),
        cmocka_unit_test(test_read_noise_and_dark),
        cmocka_unit_test(test_saturation_clips_and_flags),
        cmocka_unit_test(test_lamp_drift),
        cmocka_unit_test(test_lamp_drift_steps),
        cmocka_unit_test(test_lamp_drift_never_negative),
        cmocka_unit_test(test_streams_reproducible_and_independent),
        cmocka_unit_test(test_stall_fails_the_wait_naming_the_alarm),
        cmocka_unit_test(test_alarm_rate),
        cmocka_unit_test(test_comm_faults),
        cmocka_unit_test(test_auto_exposure),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
