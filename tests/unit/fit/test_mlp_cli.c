/* gonio fit (cli/cmd_fit.c, compiled in) on a capture directory made with
 * sim_source_capture (ideal scene, plan ds2): the model files it writes
 * open as materials that match the samples, abc equals fit_abc called
 * directly, abc-pseudo writes an abc file, the spectral CSV route, and bad
 * input gives exit status 2 with one message; gonio export merl of a
 * model file. */
#include "tests/gonio_test.h"

#include <fcntl.h>
#include <string.h>
#include <unistd.h>

#include "capture/capture.h"
#include "sim_source/sim_source.h"
#include "journal/journal.h"
#include "fit/fit.h"
#include "fit/abc_model.h"
#include "fit/model_file.h"

#include "brdf/domain.h"
/* Both commands have a static usage(): rename the export one. */
#define usage export_usage
#include "cli/cmd_export.c"
#undef usage
#include "cli/cmd_fit.c"
#include "cli/output_path.c" /* cmd_fit.c's output path */

static char dir[] = "/tmp/gonio-fitcliXXXXXX";
static char cap[300];

static int setup(void **state)
{
    (void)state;
    if (!mkdtemp(dir))
        return -1;
    snprintf(cap, sizeof cap, "%s/cap", dir);
    struct capture_config cfg = {
        .plan = "ds2", .model = "abc", .out_dir = cap, .quiet = 1,
        .assess_nodes = gonio_test_assess_nodes()};
    struct capture_summary s;
    struct gonio_err err = {0};
    if (sim_source_capture("ideal", &cfg, NULL, &s, &err) != 0) {
        fprintf(stderr, "capture: %s\n", err.msg);
        return -1;
    }
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    return system(cmd) == 0 ? 0 : -1;
}

static int run(char **argv, int argc, char **out, char **errtext)
{
    return gonio_test_run_cli(cmd_fit, argv, argc, out, errtext);
}

static struct journal_sample *samples(size_t *n)
{
    char path[400];
    snprintf(path, sizeof path, "%s/samples.csv", cap);
    struct journal_sample *js;
    assert_int_equal(journal_read(path, &js, n, NULL), 0);
    assert_int_equal(*n, 160);
    return js;
}

/* Mean log error of a model file against the journal, computed here. */
static double model_log_error(const char *model_path)
{
    char spec[400];
    snprintf(spec, sizeof spec, "model:%s", model_path);
    struct gonio_err err = {0};
    brdf_material *m = fit_material_open(spec, &err);
    if (!m)
        print_error("%s\n", err.msg);
    assert_non_null(m);
    size_t n;
    struct journal_sample *js = samples(&n);
    double sum = 0;
    for (size_t i = 0; i < n; i++) {
        struct brdf_pair g;
        brdf_pair_inplane(js[i].theta_i, js[i].theta_r, &g);
        double rgb[3], c = cos(js[i].theta_i * BRDF_DEG);
        brdf_material_eval(m, &g, 1, rgb);
        for (int k = 0; k < 3; k++)
            sum += fabs(log1p(rgb[k] * c) - log1p(js[i].rgb[k] * c));
    }
    free(js);
    brdf_material_free(m);
    return sum / (3.0 * (double)n);
}

static void test_mlp_on_capture(void **state)
{
    (void)state;
    char model[400];
    snprintf(model, sizeof model, "%s/m.model", dir);
    /* small (valgrind): 100 epochs, a third of the training */
    char *argv[] = {"fit", cap, "--model", "mlp", "--epochs", gonio_test_small() ? "100" : "300",
                    "-o", model, "--seed", "3", NULL};
    char *out, *errtext;
    int rc = run(argv, 10, &out, &errtext);
    if (rc)
        print_error("%s", errtext);
    assert_int_equal(rc, 0);
    assert_non_null(strstr(out, "samples    160"));
    assert_non_null(strstr(out, "wrote"));
    double e = model_log_error(model);
    print_message("mlp log error on the ds2 samples: %.4f\n", e);
    assert_true(e < 0.03);
    struct fit_model_file *f = fit_model_file_read(model, NULL);
    assert_non_null(f);
    assert_string_equal(f->kind, "mlp");
    assert_string_equal(fit_model_file_get(f, "seed"), "3");
    fit_model_file_free(f);
    free(out);
    free(errtext);
}

/* --model abc without -o writes CAPTURE/abc.model, holding exactly what
 * fit_abc gives with its default options on the journal's samples. */
static void test_abc_default_output(void **state)
{
    (void)state;
    char *argv[] = {"fit", cap, "--model", "abc", NULL};
    char *out, *errtext;
    assert_int_equal(run(argv, 4, &out, &errtext), 0);
    size_t n;
    struct journal_sample *js = samples(&n);
    struct fit_sample *fs = calloc(n, sizeof *fs);
    for (size_t i = 0; i < n; i++) {
        journal_sample_pair(&js[i], &fs[i].g);
        memcpy(fs[i].rgb, js[i].rgb, sizeof fs[i].rgb);
    }
    struct brdf_abc p;
    assert_int_equal(fit_abc(fs, n, NULL, &p, NULL, NULL), 0);
    char path[400];
    snprintf(path, sizeof path, "%s/abc.model", cap);
    struct fit_model_file *f = fit_model_file_read(path, NULL);
    assert_non_null(f);
    assert_string_equal(f->kind, "abc");
    double want[9] = {p.kd[0], p.kd[1], p.kd[2], p.A[0], p.A[1], p.A[2], p.B, p.C, p.eta};
    assert_int_equal(f->n_data, 9);
    assert_memory_equal(f->data, want, sizeof want);
    fit_model_file_free(f);
    free(fs);
    free(js);
    free(out);
    free(errtext);
}

static void test_abc_pseudo(void **state)
{
    (void)state;
    char model[400];
    snprintf(model, sizeof model, "%s/pseudo.model", dir);
    char *argv[] = {"fit", cap, "--model", "abc-pseudo", "--epochs",
                    gonio_test_small() ? "40" : "100", "-o", model, NULL};
    char *out, *errtext;
    int rc = run(argv, 8, &out, &errtext);
    if (rc)
        print_error("%s", errtext);
    assert_int_equal(rc, 0);
    struct fit_model_file *f = fit_model_file_read(model, NULL);
    assert_non_null(f);
    assert_string_equal(f->kind, "abc");
    assert_string_equal(fit_model_file_get(f, "source"), "abc-pseudo");
    assert_string_equal(fit_model_file_get(f, "samples_pseudo"), "912"); /* DS1's count */
    fit_model_file_free(f);
    double e = model_log_error(model);
    print_message("abc-pseudo log error on the ds2 samples: %.4f\n", e);
    assert_true(e < 0.1);
    free(out);
    free(errtext);
}

static void test_spectral_csv(void **state)
{
    (void)state;
    char csv[400], model[400];
    snprintf(csv, sizeof csv, "%s/spectral.csv", dir);
    snprintf(model, sizeof model, "%s/spectral.model", dir);
    FILE *fp = fopen(csv, "w");
    fprintf(fp, "theta_i,theta_r,wavelength_nm,value\n");
    for (int ti = 0; ti <= 60; ti += 15)
        for (int tr = -60; tr <= 60; tr += 15)
            for (int nm = 400; nm <= 700; nm += 100)
                fprintf(fp, "%d,%d,%d,%.17g\n", ti, tr, nm, 0.1 + 0.001 * (nm - 400));
    fclose(fp);
    char *argv[] = {"fit", csv, "--model", "mlp-spectral", "--epochs", "30", "-o", model, NULL};
    char *out, *errtext;
    int rc = run(argv, 8, &out, &errtext);
    if (rc)
        print_error("%s", errtext);
    assert_int_equal(rc, 0);
    assert_non_null(strstr(out, "samples    180"));
    /* 30 epochs end at the epoch limit: never "converged" beside it */
    assert_non_null(strstr(out, "s, not-converged\n"));
    assert_null(strstr(out, "s, converged"));
    assert_non_null(strstr(out, "(epoch limit)"));
    free(out);
    free(errtext);
    /* A malformed line: exit 2, the message names file and line. */
    fp = fopen(csv, "a");
    fprintf(fp, "1,2,oops,4\n");
    fclose(fp);
    assert_int_equal(run(argv, 8, &out, &errtext), 2);
    char where[420];
    snprintf(where, sizeof where, "%s:182:", csv);
    assert_non_null(strstr(errtext, where));
    assert_string_equal(out, "");
    free(out);
    free(errtext);
}

/* gonio export merl --material model:FILE: the table read back as merl:
 * holds the ABC model's values at the in-plane MERL nodes, to float32
 * storage and the table lookup's rounding of a node's angles (1e-4
 * relative; a wrong model or scale is off by far more). */
static void test_export_model(void **state)
{
    (void)state;
    struct brdf_abc p = {{0.12, 0.08, 0.05}, {1.5, 1.2, 1.0}, 80.0, 0.9, 1.5};
    struct fit_model_file *f = fit_abc_model_file(&p);
    char model[400], table[400], spec[420];
    snprintf(model, sizeof model, "%s/export.model", dir);
    snprintf(table, sizeof table, "%s/export.binary", dir);
    assert_int_equal(fit_model_file_write(f, model, NULL), 0);
    fit_model_file_free(f);
    snprintf(spec, sizeof spec, "model:%s", model);
    char *argv[] = {"export", "merl", "--material", spec, "-o", table, NULL};
    int rc;
    fflush(stdout);
    int save = dup(1);
    int null = open("/dev/null", O_WRONLY);
    dup2(null, 1);
    rc = cmd_export(6, argv);
    fflush(stdout);
    dup2(save, 1);
    close(save);
    close(null);
    assert_int_equal(rc, 0);
    snprintf(spec, sizeof spec, "merl:%s", table);
    struct gonio_err err = {0};
    brdf_material *m = brdf_material_open(spec, &err);
    if (!m)
        print_error("%s\n", err.msg);
    assert_non_null(m);
    struct brdf_domain d;
    assert_int_equal(brdf_domain_inplane(&d, NULL), 0);
    for (size_t i = 0; i < d.n; i += 97) {
        double a[3], e[3];
        brdf_material_eval(m, &d.pairs[i], 1, a);
        brdf_abc_eval(&p, &d.pairs[i], e);
        for (int k = 0; k < 3; k++)
            assert_rel_close(a[k], e[k], 1e-4);
    }
    brdf_domain_free(&d);
    brdf_material_free(m);
}

static void test_bad_input(void **state)
{
    (void)state;
    char missing[400];
    snprintf(missing, sizeof missing, "%s/no-such-capture", dir);
    struct {
        char *argv[6];
        int argc;
    } cases[] = {
        {{"fit", cap, "--model", "no-such-model", NULL}, 4},
        {{"fit", cap, NULL}, 2},
        {{"fit", missing, "--model", "abc", NULL}, 4},
        {{"fit", cap, "--model", "abc", "--seed", "x"}, 6},
        {{"fit", cap, "--model", "mlp", "--epochs", "0"}, 6},
        {{"fit", cap, "--model", "abc", "--saturated", "dropped"}, 6},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        char *out, *errtext;
        assert_int_equal(run(cases[k].argv, cases[k].argc, &out, &errtext), 2);
        assert_string_equal(out, "");
        assert_true(strlen(errtext) > 0);
        free(out);
        free(errtext);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mlp_on_capture),
        cmocka_unit_test(test_abc_default_output),
        cmocka_unit_test(test_abc_pseudo),
        cmocka_unit_test(test_spectral_csv),
        cmocka_unit_test(test_export_model),
        cmocka_unit_test(test_bad_input),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
