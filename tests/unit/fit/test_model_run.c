/* Every model of the registry through the one fit step (fit/model_run.h):
 * a capture's final fit, the study and `gonio fit` all fit this way. Each
 * RGB model fits a DS3 capture of the ideal scene (the spectral one the
 * spectra of a DS4 capture of spectral-cyan), writes its model file, and
 * reads it back as a material whose error at the samples is small; an ABC
 * fit's report holds the parameters its file holds. A warm start
 * (fit_model_options.warm_start) is taken by the models that start from
 * ABC parameters, which record it in their file; every other model's file
 * is byte for byte its cold fit's. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "capture/capture.h"
#include "fit/abc_model.h"
#include "fit/journal_samples.h"
#include "fit/mlp.h"
#include "fit/model_file.h"
#include "fit/model_run.h"
#include "fit/models.h"
#include "sim_source/sim_source.h"
#include "tests/gonio_test.h"

static char dir[64];

static int setup(void **state)
{
    (void)state;
    return gonio_test_dir_make(dir, sizeof dir, "model-run");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

static void capture(const char *scene, const char *plan, const char *out)
{
    struct capture_config cfg = {.plan = plan, .model = "abc", .out_dir = out, .quiet = 1,
                                 .measure_only = 1};
    struct capture_summary sum;
    struct gonio_err err = {0};
    if (sim_source_capture(scene, &cfg, NULL, &sum, &err) < 0)
        fail_msg("capture %s on %s: %s", plan, scene, err.msg);
}

static char *slurp(const char *path)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    rewind(f);
    char *text = malloc((size_t)len + 1);
    assert_non_null(text);
    assert_int_equal(fread(text, 1, (size_t)len, f), (size_t)len);
    text[len] = '\0';
    fclose(f);
    return text;
}

struct samples {
    struct fit_journal_data rgb;
    struct fit_spectral_sample *spectral;
    size_t n_spectral;
};

static struct fit_data data_for(const struct samples *s, const struct fit_model_kind *kind)
{
    struct fit_data d = fit_journal_data_for(&s->rgb, kind, FIT_SATURATED_DEFAULT, NULL, 0);
    if (kind->spectral) {
        d.spectral = s->spectral;
        d.n_spectral = s->n_spectral;
    }
    return d;
}

/* kind fitted cold into DIR/NAME.model, checked; its ABC parameters, when
 * its report has them, into *abc (returns 1). */
static int fit_cold(const struct samples *s, const struct fit_model_kind *kind,
                    struct brdf_abc *abc)
{
    struct fit_data data = data_for(s, kind);
    struct fit_model_options mo = fit_model_default_options();
    struct fit_model_report rep;
    struct gonio_err err = {0};
    char path[256];
    snprintf(path, sizeof path, "%s/%s.model", dir, kind->name);
    brdf_material *m = NULL;
    int rc = fit_model_run(kind, &data, &mo, path, &rep, kind->spectral ? NULL : &m, &err);
    if (rc < 0)
        fail_msg("%s: %s", kind->name, err.msg);
    assert_true(rep.fitted);
    assert_true(rep.fit_s >= 0 && rep.cpu_s >= 0);
    struct fit_model_file *f = fit_model_file_read(path, &err);
    assert_non_null(f);
    if (!kind->spectral) {
        assert_non_null(m);
        struct brdf_errors e;
        assert_int_equal(fit_sample_errors(m, s->rgb.rgb, s->rgb.n, &e, &err), 0);
        print_message("%-12s in-sample log error %.4f, %s\n", kind->name, e.log,
                      fit_status_name(fit_status_code(&rep.status)));
        assert_true(isfinite(e.log) && e.log < 0.1);
    }
    if (rep.has_abc) { /* the report's parameters are the file's */
        struct brdf_abc p;
        assert_int_equal(fit_abc_model_params(f, path, &p, &err), 0);
        assert_memory_equal(&p, &rep.abc, sizeof p);
        *abc = rep.abc;
    }
    fit_model_file_free(f);
    brdf_material_free(m);
    return rep.has_abc;
}

/* kind warm started from abc: a model that takes the start says so in its
 * file, any other writes its cold fit's file. */
static void fit_warm(const struct samples *s, const struct fit_model_kind *kind,
                     const struct brdf_abc *abc)
{
    struct fit_data data = data_for(s, kind);
    struct fit_model_options mo = fit_model_default_options();
    mo.warm_start = abc;
    mo.warm_start_from = "test start";
    struct fit_model_report rep;
    struct gonio_err err = {0};
    char cold[256], warm[256];
    snprintf(cold, sizeof cold, "%s/%s.model", dir, kind->name);
    snprintf(warm, sizeof warm, "%s/%s-warm.model", dir, kind->name);
    if (fit_model_run(kind, &data, &mo, warm, &rep, NULL, &err) < 0)
        fail_msg("%s warm: %s", kind->name, err.msg);
    struct fit_model_file *f = fit_model_file_read(warm, &err);
    assert_non_null(f);
    const char *from = fit_model_file_get(f, "warm_start");
    if (from) {
        assert_string_equal(from, "test start");
        assert_true(rep.has_abc); /* only the fits of ABC parameters start from one */
        int starts = 0; /* the note's "N starts": a warm fit refines the one it was given */
        assert_int_equal(sscanf(rep.note, "%d starts", &starts), 1);
        assert_int_equal(starts, 1);
    } else {
        char *a = slurp(cold), *b = slurp(warm);
        if (strcmp(a, b))
            fail_msg("%s: the warm start changed a model that does not take it", kind->name);
        free(a);
        free(b);
    }
    print_message("%-12s warm start %s: %s\n", kind->name, from ? "taken" : "ignored", rep.note);
    fit_model_file_free(f);
}

static void test_every_model(void **state)
{
    (void)state;
    gonio_test_shared_or_skip(); /* the latent decoder, the MLP's DS1 */
    char rgb_dir[128], spec_dir[128], path[256];
    snprintf(rgb_dir, sizeof rgb_dir, "%s/ds3", dir);
    snprintf(spec_dir, sizeof spec_dir, "%s/spectral", dir);
    capture("ideal", "ds3", rgb_dir);
    capture("spectral-cyan", "ds4", spec_dir);
    struct samples s = {0};
    struct gonio_err err = {0};
    struct journal_sample *js = NULL;
    size_t n = 0;
    snprintf(path, sizeof path, "%s/samples.csv", rgb_dir);
    assert_int_equal(journal_read(path, &js, &n, &err), 0);
    assert_int_equal(fit_data_from_journal(js, n, &s.rgb, &err), 0);
    assert_int_equal(s.rgb.n, 52);
    free(js);
    snprintf(path, sizeof path, "%s/spectra.csv", spec_dir);
    assert_true(fit_spectral_samples_read(path, &s.spectral, &s.n_spectral, &err) >= 0);
    assert_true(s.n_spectral > 0);

    struct brdf_abc abc;
    int have_abc = 0, models = 0;
    for (size_t i = 0; fit_model_at(i); i++, models++)
        have_abc |= fit_cold(&s, fit_model_at(i), &abc);
    assert_true(have_abc);
    assert_int_equal(models, 8);
    for (size_t i = 0; fit_model_at(i); i++)
        fit_warm(&s, fit_model_at(i), &abc);
    fit_journal_data_free(&s.rgb);
    free(s.spectral);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_model),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
