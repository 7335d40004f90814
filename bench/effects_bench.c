/* effects_bench: the cost per sample of the scene effects pipeline.
 *
 *   effects_bench [N]     (default N = 2000000 samples per row)
 *
 * Rows: the bare pipeline (a scene with no effects) and each effect alone,
 * at the place it acts: detector effects on a 3-channel reading
 * (sim_effects_light + sim_effects_sensor), move effects on a move command
 * (sim_effects_move), comm_faults per exchange (sim_faults_next); then whole
 * in-process readings (sim_rig_acquire, embedded default material) of the
 * ideal, lab and bad-day parameter sets and a 31-band spectral reading.
 * Times are wall-clock nanoseconds per sample; reported, never asserted. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "brdf/material.h"
#include "rig/rig.h"
#include "sim/effects.h"
#include "sim/scene.h"
#include "sim/sim.h"

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static volatile double sink;

static void one_effect(struct sim_scene *sc, enum sim_effect_kind kind)
{
    sim_scene_ideal(sc, "default");
    if ((int)kind < 0)
        return;
    struct sim_effect_spec *fx = &sc->effects[sc->n_effects++];
    memset(fx, 0, sizeof *fx);
    fx->kind = kind;
    fx->axes = SIM_AXES_ALL;
    fx->sigma = kind == SIM_FX_LAMP_DRIFT ? 0.01 : kind == SIM_FX_JITTER ? 0.02 : 10;
    fx->tau_s = 600;
    fx->level = kind == SIM_FX_SATURATION ? 1e5 : kind == SIM_FX_BACKLASH ? 0.05 : 0.001;
    if (kind == SIM_FX_DARK)
        fx->level = 500;
    if (kind == SIM_FX_LAMP_MONITOR)
        fx->level = 1e7;
    fx->gain = 0.8; /* adc: lab's */
    fx->bits = 16;
    fx->offset = 1000;
    fx->nonlinearity = 0.02;
    fx->rate = 1e-6;
    fx->code = 0x10;
    fx->drop = 0.01;
    fx->corrupt = 0.01;
    fx->late = 0.01;
    fx->timeout_s = 0.1;
    fx->retries = 3;
}

static double bench_signal(const struct sim_scene *sc, long n)
{
    sim_effects *fx = sim_effects_new(sc, NULL);
    double t0 = now_s();
    for (long i = 0; i < n; i++) {
        double v[3] = {0.1 + 1e-9 * (double)(i & 1023), 0.2, 0.3};
        struct sim_signal s = {.v = v, .n = 3, .cos_i = 0.8, .integration_s = 0.1,
                               .now_s = 0.5 * (double)i, .responsivity = 1e6};
        sim_effects_light(fx, &s);
        sim_effects_sensor(fx, &s);
        sink += v[0];
    }
    double t = now_s() - t0;
    sim_effects_free(fx);
    return 1e9 * t / (double)n;
}

static double bench_move(const struct sim_scene *sc, long n)
{
    sim_effects *fx = sim_effects_new(sc, NULL);
    double hidden = 0;
    int dir = 0;
    double t0 = now_s();
    for (long i = 0; i < n; i++) {
        double target = (i & 1) ? 10.0 : 20.0;
        struct sim_move m = {.axis = 0, .number = i + 1, .commanded_prev = 30.0 - target,
                             .target = target, .motor_target = target, .hidden_deg = hidden,
                             .last_dir = dir};
        sim_effects_move(fx, &m);
        hidden = m.hidden_deg;
        dir = m.last_dir;
        sink += m.motor_target;
    }
    double t = now_s() - t0;
    sim_effects_free(fx);
    return 1e9 * t / (double)n;
}

static double bench_faults(const struct sim_scene *sc, long n)
{
    sim_effects *fx = sim_effects_new(sc, NULL);
    sim_faults *f = sim_effects_faults(fx);
    double t0 = now_s();
    for (long i = 0; i < n; i++)
        sink += sim_faults_next(f, NULL);
    double t = now_s() - t0;
    sim_effects_free(fx);
    return 1e9 * t / (double)n;
}

static double bench_rig(const struct sim_scene *sc, const struct rig_profile *rig,
                        const brdf_material *m, long n)
{
    sim_rig *r = sim_rig_new_scene(rig, m, sc, NULL, NULL);
    if (!r)
        return -1;
    sim_rig_start_move(r, SIM_AXIS_SAMPLE, 30, NULL);
    sim_rig_start_move(r, SIM_AXIS_ARM, 65, NULL);
    sim_rig_wait(r, SIM_AXIS_SAMPLE, NULL);
    sim_rig_wait(r, SIM_AXIS_ARM, NULL);
    struct sim_reading rd;
    double t0 = now_s();
    for (long i = 0; i < n; i++) {
        sim_rig_read(r, 0.05, &rd, NULL);
        sink += rd.rgb[0];
    }
    double t = now_s() - t0;
    sim_rig_free(r);
    return 1e9 * t / (double)n;
}

int main(int argc, char **argv)
{
    long n = argc > 1 ? atol(argv[1]) : 2000000;
    if (n <= 0) {
        fprintf(stderr, "usage: effects_bench [N]\n");
        return 2;
    }
    struct sim_scene sc;
    one_effect(&sc, (enum sim_effect_kind)-1);
    double bare_sig = bench_signal(&sc, n), bare_move = bench_move(&sc, n);
    printf("| row | ns/sample | added to bare |\n|---|---:|---:|\n");
    printf("| bare detector pipeline (3 channels) | %.1f | |\n", bare_sig);
    for (int k = SIM_FX_LAMP_DRIFT; k <= SIM_FX_LAMP_MONITOR; k++) {
        one_effect(&sc, (enum sim_effect_kind)k);
        double t = bench_signal(&sc, n);
        printf("| %s | %.1f | %+.1f |\n", sim_effect_name((enum sim_effect_kind)k), t,
               t - bare_sig);
    }
    printf("| bare move pipeline | %.1f | |\n", bare_move);
    for (int k = SIM_FX_JITTER; k <= SIM_FX_ALARM; k++) {
        one_effect(&sc, (enum sim_effect_kind)k);
        double t = bench_move(&sc, n);
        printf("| %s | %.1f | %+.1f |\n", sim_effect_name((enum sim_effect_kind)k), t,
               t - bare_move);
    }
    one_effect(&sc, SIM_FX_COMM_FAULTS);
    printf("| comm_faults (per exchange) | %.1f | |\n", bench_faults(&sc, n));

    struct rig_profile rig;
    rig_profile_default(&rig);
    brdf_material *m = brdf_material_open("default", NULL);
    if (!m)
        return 1;
    long nr = n / 10;
    const char *scenes[] = {"ideal", "lab", "bad-day", "spectral-lab"};
    for (size_t i = 0; i < sizeof scenes / sizeof scenes[0]; i++) {
        struct gonio_err err = {0};
        if (sim_scene_load(scenes[i], &sc, &err) < 0) {
            fprintf(stderr, "effects_bench: %s\n", err.msg);
            continue;
        }
        printf("| whole reading, scene %s (%d effects) | %.1f | |\n", scenes[i], sc.n_effects,
               bench_rig(&sc, &rig, m, nr));
    }
    brdf_material_free(m);
    return 0;
}
