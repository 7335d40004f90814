/* Scene files: every shipped scene loads; effect parameters land where
 * docs/scenes.md says; unknown effects, bad and missing parameters are
 * refused with path:line:col: key and the problem. */
#include <string.h>
#include <unistd.h>

#include "sim/scene.h"
#include "tests/gonio_test.h"

static char path[256];

static void write_scene(const char *text)
{
    snprintf(path, sizeof path, "/tmp/gonio-scene-%d.yaml", (int)getpid());
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

/* The error must be exactly at path:line:col, name the key and say what. */
static void expect_error(const char *text, int line, int col, const char *key, const char *what)
{
    write_scene(text);
    struct sim_scene sc;
    struct gonio_err err = {0};
    int rc = sim_scene_load(path, &sc, &err);
    unlink(path);
    if (rc != -GONIO_EBADCONFIG)
        print_error("rc %d, message '%s'\n", rc, err.msg);
    assert_int_equal(rc, -GONIO_EBADCONFIG);
    char where[400];
    snprintf(where, sizeof where, "%s:%d:%d: key '%s': ", path, line, col, key);
    if (strncmp(err.msg, where, strlen(where)) != 0 || !strstr(err.msg, what)) {
        print_error("message '%s'\nwanted '%s...%s'\n", err.msg, where, what);
        fail();
    }
}

static void test_shipped_scenes_load(void **state)
{
    (void)state;
    static const char *names[] = {"ideal", "ideal-nylon", "ideal-brass", "ideal-blue-acrylic",
                                  "ideal-tungsten-carbide", "lab", "bad-day", "spectral-gold",
                                  "spectral-cyan", "spectral-magenta", "spectral-gonio",
                                  "spectral-lab", "ideal-specular-black-phenolic",
                                  "ideal-gold-metallic-paint", "ideal-white-diffuse-bball",
                                  "ideal-red-plastic", "ideal-alum-bronze", "ideal-pearl-paint"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        struct sim_scene sc;
        struct gonio_err err = {0};
        if (sim_scene_load(names[i], &sc, &err) != 0) {
            print_error("%s: %s\n", names[i], err.msg);
            fail();
        }
        assert_string_equal(sc.name, names[i]);
        if (!strncmp(names[i], "ideal", 5)) {
            assert_int_equal(sc.n_effects, 0);
            assert_int_equal(sc.detector, SIM_DETECTOR_RGB);
        } else if (sc.detector == SIM_DETECTOR_RGB) {
            /* A realistic scene hands the engine what a real detector
             * would: counts through an ADC, and a monitor of the lamp. */
            int adc = 0, monitor = 0;
            for (int k = 0; k < sc.n_effects; k++) {
                adc += sc.effects[k].kind == SIM_FX_ADC;
                monitor += sc.effects[k].kind == SIM_FX_LAMP_MONITOR;
            }
            if (adc != 1 || monitor != 1)
                fail_msg("%s: a realistic scene without raw counts or a lamp monitor", names[i]);
        }
    }
    struct sim_scene sc;
    assert_int_equal(sim_scene_load("lab", &sc, NULL), 0);
    assert_int_equal(sc.n_effects, 10);
    assert_int_equal(sc.effects[8].kind, SIM_FX_ADC);
    assert_int_equal(sc.effects[8].bits, 16);
    assert_close(sc.effects[8].gain, 0.8, 0);
    assert_close(sc.effects[8].offset, 1000, 0);
    assert_close(sc.effects[8].nonlinearity, 0.02, 0);
    assert_int_equal(sc.effects[9].kind, SIM_FX_LAMP_MONITOR);
    assert_close(sc.effects[9].level, 1e7, 0);
    assert_int_equal(sim_scene_load("spectral-gold", &sc, NULL), 0);
    assert_int_equal(sc.detector, SIM_DETECTOR_SPECTRAL);
    assert_int_equal(sc.n_bands, 35); /* 390-730 nm */
    assert_close(sc.bands_nm[0], 390, 0);
    assert_close(sc.bands_nm[34], 730, 0);
    assert_int_equal(sim_scene_load("spectral-cyan", &sc, NULL), 0);
    assert_int_equal(sc.n_bands, 31);
    assert_close(sc.bands_nm[30], 700, 0);
}

static void test_parameters_parsed(void **state)
{
    (void)state;
    write_scene("material: default\n"
                "seed: 42\n"
                "detector: {kind: spectral, responsivity: 5.0e5, target_e: 1000}\n"
                "effects:\n"
                "  - {name: saturation, full_well_e: 70000}\n"
                "  - shot_noise\n"
                "  - {name: lamp_drift, sigma: 0.01}\n"
                "  - {name: jitter, sigma_deg: 0.03, axes: [arm]}\n"
                "  - {name: stall, at_moves: [3, 9], rate: 0.001}\n"
                "  - {name: alarm, rate: 0.5, code: 33, axes: [sample, azimuth]}\n"
                "  - {name: comm_faults, drop: 0.1, late: 0.05}\n");
    struct sim_scene sc;
    struct gonio_err err = {0};
    int rc = sim_scene_load(path, &sc, &err);
    unlink(path);
    if (rc)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);
    assert_int_equal(sc.seed, 42);
    assert_int_equal(sc.n_bands, 31); /* the design's default layout */
    assert_close(sc.bands_nm[0], 400, 0);
    assert_close(sc.responsivity, 5e5, 0);
    assert_close(sc.target_e, 1000, 0);
    assert_int_equal(sc.n_effects, 7);
    assert_int_equal(sc.effects[0].kind, SIM_FX_SATURATION);
    assert_close(sc.effects[0].level, 70000, 0);
    assert_int_equal(sc.effects[1].kind, SIM_FX_SHOT_NOISE);
    assert_int_equal(sc.effects[2].kind, SIM_FX_LAMP_DRIFT);
    assert_close(sc.effects[2].tau_s, 600, 0); /* default */
    assert_int_equal(sc.effects[3].axes, 0x2u);
    assert_int_equal(sc.effects[4].n_at_moves, 2);
    assert_int_equal(sc.effects[4].at_moves[1], 9);
    assert_int_equal(sc.effects[4].code, 0x10); /* default stall code */
    assert_int_equal(sc.effects[5].code, 0x21);
    assert_int_equal(sc.effects[5].axes, 0x5u);
    assert_close(sc.effects[6].drop, 0.1, 0);
    assert_close(sc.effects[6].corrupt, 0, 0);
    assert_close(sc.effects[6].timeout_s, 0.1, 0);
    assert_int_equal(sc.effects[6].retries, 3);
    for (int i = 0; i < 7; i++)
        assert_int_equal(sc.effects[i].index, i);
}

static void test_bad_effects_refused_at_their_position(void **state)
{
    (void)state;
    const char *head = "material: default\neffects:\n";
    char buf[512];
#define CASE(body, line, col, key, what)                                   \
    snprintf(buf, sizeof buf, "%s%s", head, body);                          \
    expect_error(buf, line, col, key, what)
    CASE("  - name: warp_drive\n", 3, 11, "name", "unknown effect 'warp_drive'");
    CASE("  - {name: shot_noise}\n  - {name: gamma_rays}\n", 4, 12, "name", "unknown effect");
    CASE("  - {name: read_noise, sigma_e: -3}\n", 3, 33, "sigma_e", "-3");
    CASE("  - {name: read_noise}\n", 3, 5, "sigma_e", "missing");
    CASE("  - {name: stray_light, floor: 0.1, colour: red}\n", 3, 37, "colour", "");
    CASE("  - {name: jitter, sigma_deg: 0.1, axes: [elbow]}\n", 3, 43, "axes",
         "unknown axis 'elbow'");
    CASE("  - {name: stall, axes: [arm]}\n", 3, 5, "rate", "never happen");
    CASE("  - {name: stall, at_moves: [2.5]}\n", 3, 30, "at_moves", "not an integer");
    CASE("  - {name: comm_faults, drop: 0.9}\n", 3, 31, "drop", "0.9");
    CASE("  - {name: comm_faults, timeout_s: 1}\n", 3, 5, "drop", "above 0");
    CASE("  - {name: comm_faults, drop: 0.5, corrupt: 0.5, late: 0.5}\n", 3, 5, "drop",
         "drop + corrupt + late is 0.5 + 0.5 + 0.5 = 1.5, more than 1");
    CASE("  - dark\n", 3, 5, "rate_e_per_s", "needs parameters");
    CASE("  - shot_noise\n  - shot_noise\n", 4, 5, "name", "named twice (first at line 3)");
    CASE("  - {name: lamp_drift, sigma: \"0.1\"}\n", 3, 31, "sigma", "");
    CASE("  - {name: adc, bits: 16}\n", 3, 5, "gain_adu_per_e", "missing");
    CASE("  - {name: adc, gain_adu_per_e: 1, bits: 40}\n", 3, 42, "bits", "40");
    CASE("  - {name: adc, gain_adu_per_e: 1, nonlinearity: 0.6}\n", 3, 50, "nonlinearity",
         "0.6");
    CASE("  - {name: adc, gain_adu_per_e: 1, bits: 12, offset_adu: 3000}\n", 3, 58,
         "offset_adu", "3000 ADU leaves less than half of the 12-bit range (4095)");
    CASE("  - lamp_monitor\n", 3, 5, "rate_counts_per_s", "needs parameters");
#undef CASE
    expect_error("material: default\ndetector: {kind: spectral, bands: [400, 450, 480]}\n"
                 "effects:\n  - shot_noise\n  - {name: adc, gain_adu_per_e: 1}\n",
                 5, 12, "name", "its counts' 595 nm and up bin is empty");
    expect_error("material: default\ndetector: {kind: spectral, bands: {first_nm: 400, "
                 "last_nm: 705, step_nm: 10}}\n",
                 2, 35, "bands", "whole steps");
    expect_error("material: default\ndetector: infrared\n", 2, 11, "detector", "infrared");
    expect_error("material: default\ndetector: {kind: rgb, bands: [400, 500, 600]}\n", 2, 30,
                 "bands", "kind: spectral");
}

/* gold's n, k table covers 390-730 nm: wider bands are refused at load */
static void test_bands_beyond_the_material_refused(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    expect_error("material: spectral:gold\n"
                 "detector:\n"
                 "  kind: spectral\n"
                 "  bands: {first_nm: 380, last_nm: 700, step_nm: 10}\n",
                 4, 10, "bands", "spectral:gold is defined on 390-730 nm");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_shipped_scenes_load),
        cmocka_unit_test(test_parameters_parsed),
        cmocka_unit_test(test_bad_effects_refused_at_their_position),
        cmocka_unit_test(test_bands_beyond_the_material_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
