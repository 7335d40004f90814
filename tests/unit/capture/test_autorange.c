/* Auto-ranging on a detector that gives counts (the lab scene): a
 * capture without a calibration is refused before anything is written,
 * naming the fix; with --uncalibrated every sample is counts, none is kept
 * clipped while a shorter integration exists, none sits below the floor
 * while a longer one exists unless it came down from a clip, every
 * integration used has its dark frame in the journal, the retakes' time is
 * recorded and charged to the rig clock, and results.json says why nothing
 * was fitted; the ETA's model of the ladder walks the journal as the
 * readings did; a rig profile without a shutter takes no dark frames.
 * Runs without the shared data. */
#include <jansson.h>
#include <math.h>
#include <string.h>
#include <sys/stat.h>

#include "capture/autorange.h"
#include "capture/capture.h"
#include "common/paths.h"
#include "journal/journal.h"
#include "sim_source/sim_source.h"
#include "tests/gonio_test.h"

static char dir[256];
static char rig_path[400];

/* The default rig starting at its longest integration, so that a metal's
 * bright points clip and must come down. */
static int setup(void **state)
{
    (void)state;
    if (gonio_test_dir_make(dir, sizeof dir, "autorange") != 0)
        return -1;
    char src[4200];
    snprintf(src, sizeof src, "%s/rigs/default.yaml", gonio_config_dir());
    FILE *in = fopen(src, "r");
    snprintf(rig_path, sizeof rig_path, "%s/long.yaml", dir);
    FILE *out = fopen(rig_path, "w");
    if (!in || !out)
        return -1;
    char line[512];
    while (fgets(line, sizeof line, in))
        fputs(strstr(line, "fixed_s:") ? "  fixed_s: 2\n" : line, out);
    fclose(in);
    fclose(out);
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

static struct capture_config config(const char *out)
{
    return (struct capture_config){.plan = "ds3", .model = "abc", .out_dir = out, .quiet = 1,
                                   .rig = rig_path,
                                   .material = "builtin:gold-metallic-paint",
                                   .assess_nodes = gonio_test_assess_nodes()};
}

static void test_counts_without_calibration_refused(void **state)
{
    (void)state;
    char out[300];
    snprintf(out, sizeof out, "%s/refused", dir);
    struct capture_config cfg = config(out);
    struct capture_summary sum;
    struct gonio_err err = {0};
    int rc = sim_source_capture("lab", &cfg, NULL, &sum, &err);
    assert_int_equal(rc, -GONIO_EUSAGE);
    assert_int_equal(gonio_exit_status(rc), 2);
    assert_non_null(strstr(err.msg, "--calibration ID"));
    assert_non_null(strstr(err.msg, "--uncalibrated"));
    struct stat st;
    assert_int_not_equal(stat(out, &st), 0); /* nothing written, nothing moved */
    /* a detector that reports BRDF needs no calibration */
    snprintf(out, sizeof out, "%s/brdf", dir);
    cfg = config(out);
    cfg.plan = "ds4";
    assert_int_equal(sim_source_capture("ideal", &cfg, NULL, &sum, &err), 0);
}

static const double *dark_of(const struct journal_sample *js, size_t n, double t)
{
    for (size_t i = 0; i < n; i++)
        if ((js[i].flags & JOURNAL_FLAG_DARK) && js[i].integration_s == t)
            return js[i].raw;
    return NULL;
}

static void test_uncalibrated_capture_ranges(void **state)
{
    (void)state;
    char out[300], path[400];
    snprintf(out, sizeof out, "%s/ranged", dir);
    struct capture_config cfg = config(out);
    cfg.uncalibrated = 1;
    struct capture_summary sum;
    struct gonio_err err = {0};
    int rc = sim_source_capture("lab", &cfg, NULL, &sum, &err);
    if (rc)
        fail_msg("%s", err.msg);
    snprintf(path, sizeof path, "%s/samples.csv", out);
    struct journal_sample *js;
    size_t n;
    assert_int_equal(journal_read(path, &js, &n, &err), 0);
    struct rig_profile rig;
    assert_int_equal(rig_profile_load(rig_path, &rig, &err), 0);
    const double fs = 65535; /* lab's 16-bit ADC */
    size_t samples = 0, darks = 0, retaken = 0, down = 0;
    double detector_s = 0;
    for (size_t i = 0; i < n; i++) {
        const struct journal_sample *s = &js[i];
        assert_true(s->counts);
        assert_true(isnan(s->rgb[0]));
        if (s->flags & JOURNAL_FLAG_DARK) {
            darks++;
            continue;
        }
        samples++;
        detector_s += s->integration_total_s;
        assert_true(s->integration_total_s >= s->integration_s);
        retaken += s->integration_total_s > s->integration_s;
        if (s->flags & JOURNAL_FLAG_SATURATED) /* only at the shortest integration */
            assert_true(s->integration_s == rig.auto_min_s);
        const double *dk = dark_of(js, n, s->integration_s);
        if (!dk)
            fail_msg("point %d: no dark frame at %g s", s->point, s->integration_s);
        double peak = fmax(fmax(s->raw[0] - dk[0], s->raw[1] - dk[1]), s->raw[2] - dk[2]);
        /* below the floor only at the longest integration, or after coming
         * down from a clip (its total holds a longer try) */
        int came_down = s->integration_total_s > 4 * s->integration_s;
        down += came_down;
        if (peak < AUTORANGE_FLOOR * fs && s->integration_s < rig.auto_max_s && !came_down)
            fail_msg("point %d: peak %g counts at %g s", s->point, peak, s->integration_s);
    }
    assert_int_equal(samples, sum.samples);
    assert_int_equal(darks, sum.darks);
    assert_true(retaken > 0 && down > 0); /* both ways exercised */
    assert_true(sum.retakes >= retaken);
    assert_true(sum.rig_time_s > detector_s); /* every try charged to the rig clock */
    free(js);
    snprintf(path, sizeof path, "%s/results.json", out);
    json_t *res = json_load_file(path, 0, NULL);
    assert_non_null(res);
    assert_non_null(strstr(json_string_value(json_object_get(res, "not_fitted")),
                           "uncalibrated"));
    json_decref(res);
    /* setup.json: the ADC as the detector states it, and the ladder used */
    snprintf(path, sizeof path, "%s/setup.json", out);
    json_t *setup = json_load_file(path, 0, NULL);
    json_t *counts = json_object_get(setup, "counts");
    assert_true(json_real_value(json_object_get(counts, "full_scale")) == fs);
    assert_true(json_real_value(json_object_get(counts, "nonlinearity")) == 0.02);
    json_t *ladder = json_object_get(counts, "integration_ladder");
    assert_int_equal(json_array_size(ladder), 7); /* 2 s / 4^k held to 0.001..2 */
    assert_true(json_real_value(json_array_get(ladder, 0)) == rig.auto_min_s);
    assert_true(json_real_value(json_array_get(ladder, 6)) == rig.auto_max_s);
    json_decref(setup);
}

/* A rig profile without a shutter (shutter: false, as the USB
 * spectrometer's): the capture takes no dark frame at any rung, though the
 * simulated detector has a shutter it could close; the profile is what
 * the rig has. */
static void test_no_shutter_no_dark_frames(void **state)
{
    (void)state;
    char out[300], path[400], noshut[400];
    snprintf(noshut, sizeof noshut, "%s/noshutter.yaml", dir);
    FILE *in = fopen(rig_path, "r"), *o = fopen(noshut, "w");
    assert_non_null(in);
    assert_non_null(o);
    char line[512];
    while (fgets(line, sizeof line, in))
        fputs(line, o);
    fputs("shutter: false\n", o);
    fclose(in);
    fclose(o);
    snprintf(out, sizeof out, "%s/noshutter", dir);
    struct capture_config cfg = config(out);
    cfg.rig = noshut;
    cfg.uncalibrated = 1;
    struct capture_summary sum;
    struct gonio_err err = {0};
    if (sim_source_capture("lab", &cfg, NULL, &sum, &err))
        fail_msg("%s", err.msg);
    snprintf(path, sizeof path, "%s/samples.csv", out);
    struct journal_sample *js;
    size_t n, darks = 0, samples = 0;
    assert_int_equal(journal_read(path, &js, &n, &err), 0);
    for (size_t i = 0; i < n; i++) {
        darks += (js[i].flags & JOURNAL_FLAG_DARK) != 0;
        samples += !(js[i].flags & JOURNAL_FLAG_DARK);
    }
    free(js);
    assert_true(samples > 0);
    assert_int_equal(samples, sum.samples);
    assert_int_equal(darks, 0);
    assert_int_equal(sum.darks, 0);
}

/* The ETA's model of the ladder (autorange_model_point) walks a capture's
 * journal as the readings did: given each point's signal rate, read back
 * from its counts, it keeps the integration the capture kept and costs the
 * tries and first dark frames the capture spent. */
static void test_model_walks_the_journal(void **state)
{
    (void)state;
    char out[300], path[400];
    snprintf(out, sizeof out, "%s/walked", dir);
    struct capture_config cfg = config(out);
    cfg.uncalibrated = 1;
    struct capture_summary sum;
    struct gonio_err err = {0};
    if (sim_source_capture("lab", &cfg, NULL, &sum, &err))
        fail_msg("%s", err.msg);
    snprintf(path, sizeof path, "%s/samples.csv", out);
    struct journal_sample *js;
    size_t n;
    assert_int_equal(journal_read(path, &js, &n, &err), 0);
    struct rig_profile rig;
    assert_int_equal(rig_profile_load(rig_path, &rig, &err), 0);
    struct autorange known; /* every dark frame, for the rates */
    autorange_init(&known, &rig);
    known.full_scale = 65535;
    double spent = 0, walked = 0;
    for (size_t i = 0; i < n; i++)
        if (js[i].flags & JOURNAL_FLAG_DARK) {
            autorange_note(&known, &js[i]);
            spent += js[i].integration_s;
        }
    struct autorange_model m;
    assert_int_equal(autorange_model_start(&known, &m), 1);
    m.n_dark = 0; /* the walk takes its dark frames as the capture did */
    size_t samples = 0, kept_as_taken = 0;
    for (size_t i = 0; i < n; i++) {
        if (js[i].flags & JOURNAL_FLAG_DARK)
            continue;
        samples++;
        spent += js[i].integration_total_s;
        walked += autorange_model_point(&known, &m, autorange_rate(&known, &js[i]));
        kept_as_taken += m.t == js[i].integration_s;
        m.t = js[i].integration_s; /* the next point starts where the capture's did */
    }
    free(js);
    printf("model: %zu of %zu kept as taken, %.3f s walked, %.3f s spent\n", kept_as_taken,
           samples, walked, spent);
    assert_true(kept_as_taken >= samples - samples / 20);
    assert_true(fabs(walked / spent - 1) < 0.02);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_counts_without_calibration_refused),
        cmocka_unit_test(test_uncalibrated_capture_ranges),
        cmocka_unit_test(test_model_walks_the_journal),
        cmocka_unit_test(test_no_shutter_no_dark_frames),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
