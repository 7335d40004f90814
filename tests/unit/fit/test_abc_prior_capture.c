/* abc-prior through the capture engine: `gonio capture --model abc-prior`
 * fits the journalled samples with the prior that leaves the captured
 * material out, reports the too-few-samples warning, and writes the
 * parameter uncertainties into results.json. */
#include "tests/gonio_test.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "daemon/capture.h"
#include "daemon/journal.h"
#include "fit/abc_prior.h"
#include "fit/fit.h"

static char dir[] = "/tmp/gonio-abcpriorXXXXXX";

static void test_ds4_capture_with_prior(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    assert_non_null(mkdtemp(dir));
    char cap[300], path[400];
    snprintf(cap, sizeof cap, "%s/cap", dir);
    struct capture_config cfg = {.plan = "ds4", .scene = "ideal",
                                 .material = "nbrdf:tungsten-carbide", .model = "abc-prior",
                                 .out_dir = cap, .quiet = 1,
                                 .assess_nodes = gonio_test_assess_nodes()};
    struct capture_summary s;
    struct gonio_err err = {0};
    int rc = capture_run_offline(&cfg, &s, &err);
    if (rc)
        printf("capture: %s\n", err.msg);
    assert_int_equal(rc, 0);
    assert_string_equal(s.model, "abc-prior");
    /* the same MAP fit done here, the material left out of the prior */
    snprintf(path, sizeof path, "%s/samples.csv", cap);
    struct journal_sample *js = NULL;
    size_t n = 0;
    assert_true(journal_read(path, &js, &n, &err) >= 0);
    assert_int_equal((int)n, 6);
    struct fit_sample fs[6];
    for (size_t i = 0; i < n; i++) {
        journal_sample_pair(&js[i], &fs[i].g);
        memcpy(fs[i].rgb, js[i].rgb, sizeof fs[i].rgb);
    }
    free(js);
    struct fit_abc_prior prior;
    assert_int_equal(fit_abc_prior_build("tungsten-carbide", &prior, &err), 0);
    assert_int_equal((int)prior.n_materials, 99);
    struct brdf_abc p;
    struct fit_info info;
    assert_int_equal(fit_abc_map(fs, n, NULL, &prior, &p, &info, &err), 0);
    assert_rel_close(s.params.B, p.B, 1e-9);
    assert_rel_close(s.params.eta, p.eta, 1e-9);
    for (int c = 0; c < 3; c++)
        assert_rel_close(s.params.A[c], p.A[c], 1e-9);
    /* the full prior gives another fit: the exclusion took effect */
    struct fit_abc_prior all;
    struct brdf_abc q;
    assert_int_equal(fit_abc_prior_build(NULL, &all, &err), 0);
    assert_int_equal(fit_abc_map(fs, n, NULL, &all, &q, NULL, &err), 0);
    assert_true(fabs(q.B / p.B - 1) > 1e-6 || fabs(q.A[0] / p.A[0] - 1) > 1e-6);
    printf("warning: %s\n", s.warning);
    assert_true(strstr(s.warning, "not enough") != NULL);
    /* results.json: the uncertainty object */
    snprintf(path, sizeof path, "%s/results.json", cap);
    json_t *root = json_load_file(path, 0, NULL);
    assert_non_null(root);
    json_t *u = json_object_get(root, "uncertainty");
    assert_true(json_is_object(u));
    assert_close(json_number_value(json_object_get(u, "sd_pred_log")), info.sd.pred_log,
                 1e-9 * fmax(1, info.sd.pred_log));
    assert_true(json_is_string(json_object_get(u, "warning")));
    assert_int_equal((int)json_array_size(json_object_get(u, "sd_log_A")), 3);
    json_decref(root);
    char cmd[400];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    assert_int_equal(system(cmd), 0);
}

static void test_unknown_model_refused(void **state)
{
    (void)state;
    struct capture_config cfg = {.plan = "ds4", .scene = "ideal", .model = "abc-priors",
                                 .out_dir = "/tmp/gonio-never-written", .quiet = 1};
    struct capture_summary s;
    struct gonio_err err = {0};
    assert_int_equal(capture_run_offline(&cfg, &s, &err), -GONIO_EUSAGE);
    assert_non_null(strstr(err.msg, "abc-priors"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ds4_capture_with_prior),
        cmocka_unit_test(test_unknown_model_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
