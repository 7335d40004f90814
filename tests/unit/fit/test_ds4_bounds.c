/* DS4 (six pairs at theta_i 30) on every one of the ten held-out study
 * materials, for each RGB model of docs/results-fit.md: the in-plane log
 * error against the truth may be at most the documented per-material
 * figure plus 10 %. The figures are the in-plane log column of
 * docs/results-fit.md (scripts/fit_table.sh; the latent rows are those of
 * docs/results-latent.md too), measured the same way: an offline ideal-scene
 * capture of nbrdf:NAME, then the model's registry fit with default
 * options (seed 1), the captured material left out of abc-prior's prior.
 * The small size (valgrind, GONIO_TEST_SMALL) runs two materials. Needs
 * the shared data: skipped without it. */
#include "tests/gonio_test.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "brdf/domain.h"
#include "brdf/metrics.h"
#include "capture/capture.h"
#include "sim_source/sim_source.h"
#include "fit/journal_samples.h"
#include "journal/journal.h"
#include "fit/model_file.h"
#include "fit/model_run.h"
#include "fit/models.h"

static const char *const models[4] = {"abc", "abc-prior", "mlp", "latent"};

/* In-plane log error of each model on DS4, docs/results-fit.md. */
static const struct {
    const char *name;
    double inplane[4];
} docs[] = {
    {"nylon", {0.0329, 0.0435, 0.1457, 0.0785}},
    {"tungsten-carbide", {0.5453, 0.0910, 0.7961, 0.0499}},
    {"specular-black-phenolic", {0.4184, 0.0640, 0.4495, 0.0294}},
    {"blue-acrylic", {0.3011, 0.2682, 0.4255, 0.0444}},
    {"brass", {0.3282, 0.1301, 0.7132, 0.1151}},
    {"gold-metallic-paint", {0.0723, 0.0711, 0.0796, 0.0818}},
    {"white-diffuse-bball", {0.0393, 0.0207, 0.0776, 0.0185}},
    {"red-plastic", {0.0091, 0.0062, 0.0412, 0.0083}},
    {"alum-bronze", {0.1850, 0.1845, 0.3796, 0.1286}},
    {"pearl-paint", {0.0140, 0.0139, 0.0716, 0.0175}},
};

static char dir[] = "/tmp/gonio-ds4XXXXXX";

static int teardown(void **state)
{
    (void)state;
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    return system(cmd) == 0 ? 0 : -1;
}

/* The DS4 samples of a material, as an ideal-scene capture journals them. */
static size_t capture_ds4(const char *spec, const char *out, struct fit_sample **s)
{
    struct capture_config cfg = {.plan = "ds4", .material = spec,
                                 .model = "abc", .out_dir = out, .quiet = 1,
                                 .measure_only = 1};
    struct capture_summary sum;
    struct gonio_err err = {0};
    if (sim_source_capture("ideal", &cfg, NULL, &sum, &err))
        print_error("%s: %s\n", spec, err.msg);
    assert_int_equal(sum.samples, 6);
    char path[400];
    snprintf(path, sizeof path, "%s/samples.csv", out);
    struct journal_sample *js = NULL;
    size_t n = 0;
    assert_int_equal(journal_read(path, &js, &n, &err), 0);
    *s = malloc(n * sizeof **s);
    assert_non_null(*s);
    fit_journal_samples(js, n, *s);
    free(js);
    return n;
}

static void test_ds4_every_material(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    assert_non_null(mkdtemp(dir));
    struct brdf_domain inplane;
    struct gonio_err err = {0};
    assert_int_equal(brdf_domain_inplane(&inplane, &err), 0);
    size_t n_mats = gonio_test_small() ? 2 : sizeof docs / sizeof docs[0];
    for (size_t i = 0; i < n_mats; i++) {
        char spec[128], cap[300];
        snprintf(spec, sizeof spec, "nbrdf:%s", docs[i].name);
        snprintf(cap, sizeof cap, "%s/%s", dir, docs[i].name);
        struct fit_sample *s;
        size_t n = capture_ds4(spec, cap, &s);
        brdf_material *truth = brdf_material_open(spec, &err);
        assert_non_null(truth);
        for (int m = 0; m < 4; m++) {
            const struct fit_model_kind *kind = fit_model_find(models[m]);
            struct fit_data data = {.rgb = s, .n_rgb = n, .material = spec};
            struct fit_model_options mo = fit_model_default_options();
            struct fit_model_report rep;
            char path[400];
            snprintf(path, sizeof path, "%s/%s.model", cap, models[m]);
            brdf_material *fitted = NULL;
            int rc = fit_model_run(kind, &data, &mo, path, &rep, &fitted, &err);
            if (rc)
                print_error("%s %s: %s\n", docs[i].name, models[m], err.msg);
            assert_int_equal(rc, 0);
            struct brdf_errors e;
            assert_int_equal(brdf_errors_material(truth, fitted, &inplane, &e, &err), 0);
            double bound = 1.1 * docs[i].inplane[m];
            print_message("%-24s %-9s in-plane log %.4f (docs %.4f, bound %.4f), %s\n",
                          docs[i].name, models[m], e.log, docs[i].inplane[m], bound,
                          fit_status_name(fit_status_code(&rep.status)));
            assert_true(e.log <= bound);
            /* six samples: no model may call its answer known (underdetermined,
             * or parameters pinned on bounds and a poor fit) */
            assert_int_not_equal(fit_status_code(&rep.status), FIT_STATUS_CONVERGED);
            brdf_material_free(fitted);
        }
        brdf_material_free(truth);
        free(s);
    }
    brdf_domain_free(&inplane);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_ds4_every_material, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
