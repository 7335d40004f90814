/* The fit status (fit/fit_status.h): the rules that turn figures into
 * findings, the geometry count, and the status every registry model
 * reports, in its report and in its model file: limits are not-converged,
 * too few geometries or held-out rows underdetermined, data no material
 * explains poor-fit. */
#include "tests/gonio_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "brdf/abc.h"
#include "brdf/angles.h"
#include "brdf/domain.h"
#include "fit/fit.h"
#include "fit/fit_status.h"
#include "fit/model_file.h"
#include "fit/model_run.h"
#include "fit/models.h"

/* Each rule alone, and the order the shown status takes. */
static void test_rules(void **state)
{
    (void)state;
    struct fit_status st = fit_status_init();
    st.geometries = 40;
    st.params = 9;
    st.rank = 9;
    st.cond = 1e3;
    st.insample = st.heldout = 0.02;
    fit_status_decide(&st);
    assert_int_equal(st.findings, 0);
    assert_string_equal(fit_status_name(fit_status_code(&st)), "converged");

    struct fit_status t = st;
    t.geometries = 8; /* fewer geometries than parameters */
    fit_status_decide(&t);
    assert_int_equal(fit_status_code(&t), FIT_STATUS_UNDERDETERMINED);
    t = st;
    t.rank = 8; /* a rank below them */
    fit_status_decide(&t);
    assert_int_equal(t.findings, 1u << FIT_STATUS_UNDERDETERMINED);
    t = st;
    t.cond = 2 * FIT_STATUS_COND_MAX;
    fit_status_decide(&t);
    assert_int_equal(t.findings, 1u << FIT_STATUS_ILL_CONDITIONED);
    t = st;
    t.cond = 0.5 * FIT_STATUS_COND_MAX;
    fit_status_decide(&t);
    assert_int_equal(t.findings, 0);
    t = st;
    snprintf(t.at_bound, sizeof t.at_bound, "eta");
    fit_status_decide(&t);
    assert_int_equal(t.findings, 1u << FIT_STATUS_AT_BOUND);
    /* poor-fit: held-out (or in-sample) residual beyond 3 noise levels */
    t = st;
    t.heldout = 1.01 * FIT_STATUS_POOR_FACTOR * FIT_STATUS_NOISE_LOG;
    fit_status_decide(&t);
    assert_int_equal(t.findings, 1u << FIT_STATUS_POOR_FIT);
    t = st;
    t.heldout = 0.99 * FIT_STATUS_POOR_FACTOR * FIT_STATUS_NOISE_LOG;
    fit_status_decide(&t);
    assert_int_equal(t.findings, 0);
    t = st;
    t.heldout = NAN;
    t.insample = 1.0;
    fit_status_decide(&t);
    assert_int_equal(t.findings, 1u << FIT_STATUS_POOR_FIT);
    /* the networks: no parameter count, no geometry rule */
    t = st;
    t.params = -1;
    t.geometries = 2;
    fit_status_decide(&t);
    assert_int_equal(t.findings, 0);

    /* several findings: all listed, the first in severity order shown */
    t = st;
    t.findings = 1u << FIT_STATUS_NOT_CONVERGED;
    t.geometries = 3;
    snprintf(t.at_bound, sizeof t.at_bound, "B,eta");
    fit_status_decide(&t);
    assert_int_equal(fit_status_code(&t), FIT_STATUS_NOT_CONVERGED);
    char buf[400];
    fit_status_findings(&t, buf, sizeof buf);
    assert_string_equal(buf, "not-converged,underdetermined,at-bound");
    fit_status_line(&t, buf, sizeof buf);
    print_message("%s\n", buf);
    assert_non_null(strstr(buf, "not-converged,underdetermined,at-bound (B,eta); 3 geometries, "
                                "rank 9 of 9 free parameters, condition 1e+03, held-out 0.02 "
                                "vs in-sample 0.02 RMS log"));
}

/* Geometries are counted on a 1e-9 grid: rounding noise does not make two,
 * a NaN angle none. */
static void test_distinct_pairs(void **state)
{
    (void)state;
    double p[6][2] = {{0.1, 0.2}, {0.1 + 1e-15, 0.2}, {0.2, 0.1}, {0.1, 0.3}, {NAN, 0.1},
                      {0.2, 0.1 - 1e-14}};
    assert_int_equal(fit_status_distinct_pairs(p, 6), 3);
    double q[1][2] = {{0, 0}};
    assert_int_equal(fit_status_distinct_pairs(q, 0), 0);
}

#define NS 200

/* An in-plane grid of a material (ABC truth), theta_i 0..60 step 10,
 * theta_r -70..70 step 5 (the blind zone left out): 172 samples; with
 * coarse at the small size step 10 (the latent fits dominate under
 * valgrind). */
static size_t grid_samples(const struct brdf_abc *p, struct fit_sample *s, int coarse)
{
    size_t n = 0;
    int step = coarse && gonio_test_small() ? 10 : 5;
    for (int ti = 0; ti <= 60; ti += 10)
        for (int tr = -70; tr <= 70; tr += step) {
            if (abs(ti + tr) < 5 || n >= NS)
                continue;
            brdf_pair_inplane(ti, tr, &s[n].g);
            brdf_abc_eval(p, &s[n].g, s[n].rgb);
            n++;
        }
    return n;
}

/* kind->fit on data; the report's status, which the model file repeats. */
static struct fit_status fit_kind(const char *name, const struct fit_data *data,
                                  int max_epochs, struct fit_model_report *rep)
{
    const struct fit_model_kind *kind = fit_model_find(name);
    assert_non_null(kind);
    struct fit_model_options mo = fit_model_default_options();
    mo.max_epochs = max_epochs;
    struct fit_model_file *mf = NULL;
    struct gonio_err err = {0};
    int rc = kind->fit(data, &mo, &mf, rep, &err);
    if (rc)
        print_error("%s: %s\n", name, err.msg);
    assert_int_equal(rc, 0);
    char line[400];
    fit_status_line(&rep->status, line, sizeof line);
    print_message("%s: %s\n", name, line);
    const char *status = fit_model_file_get(mf, "status");
    assert_non_null(status);
    assert_string_equal(status, fit_status_name(fit_status_code(&rep->status)));
    assert_non_null(fit_model_file_get(mf, "rms_log_heldout"));
    fit_model_file_free(mf);
    assert_int_equal(rep->converged,
                     !(rep->status.findings & (1u << FIT_STATUS_NOT_CONVERGED)));
    return rep->status;
}

static const struct brdf_abc plastic = {{0.2, 0.15, 0.1}, {20, 15, 10}, 3000, 0.9, 1.5};

/* A well-sampled material: abc converged with every figure; abc at one
 * iteration and the networks and the latent fit at a few steps stop at
 * their limits: not-converged, and their reports say so. */
static void test_models_converged_and_limits(void **state)
{
    (void)state;
    static struct fit_sample s[NS];
    struct fit_data data = {.rgb = s, .n_rgb = grid_samples(&plastic, s, 1)};
    struct fit_model_report rep;
    struct fit_status st = fit_kind("abc", &data, 0, &rep);
    assert_int_equal(fit_status_code(&st), FIT_STATUS_CONVERGED);
    assert_true(st.geometries >= 40);
    assert_int_equal(st.rank, st.params);
    assert_true(st.cond >= 1 && st.cond < FIT_STATUS_COND_MAX);
    assert_true(st.heldout >= 0 && st.heldout < 1e-6); /* exact model data */

    struct fit_info info;
    struct fit_options o = fit_default_options();
    o.max_iter = 1;
    struct brdf_abc p;
    assert_int_equal(fit_abc(s, data.n_rgb, &o, &p, &info, NULL), 0);
    assert_int_equal(info.converged, 0);
    assert_true(info.status.findings & (1u << FIT_STATUS_NOT_CONVERGED));

    st = fit_kind("mlp", &data, 3, &rep);
    assert_int_equal(fit_status_code(&st), FIT_STATUS_NOT_CONVERGED);
    assert_int_equal(rep.converged, 0);
    st = fit_kind("latent", &data, 5, &rep);
    assert_true(st.findings & (1u << FIT_STATUS_NOT_CONVERGED));
    assert_int_equal(st.params, 12);
    st = fit_kind("latent", &data, 0, &rep);
    assert_false(st.findings & (1u << FIT_STATUS_NOT_CONVERGED));
    assert_true(st.heldout > 0 && st.heldout < 0.1);
}

/* A Gaussian lobe exp(-3000 x): ABC's (1 + B x)^-C with B C = 3000 as C ->
 * infinity (C 1e4 here, beyond the fitter's bound e^3.5): the fit ends
 * with C on its bound and names it. */
static void test_at_bound(void **state)
{
    (void)state;
    static struct fit_sample s[NS];
    const struct brdf_abc sharp = {{0.2, 0.15, 0.1}, {20, 15, 10}, 0.3, 1e4, 1.5};
    size_t n = grid_samples(&sharp, s, 0);
    struct brdf_abc p;
    struct fit_info info;
    assert_int_equal(fit_abc(s, n, NULL, &p, &info, NULL), 0);
    char line[400];
    fit_status_line(&info.status, line, sizeof line);
    print_message("C 1e4: fitted C %g; %s\n", p.C, line);
    assert_true(info.status.findings & (1u << FIT_STATUS_AT_BOUND));
    assert_non_null(strstr(info.status.at_bound, "C"));
    assert_true(info.status.params < 9); /* C is not free */
}

/* The latent fit divides out the data's scale like fit_abc: data x1e12 and
 * x1e-12 give the same z to 1e-6 relative, and the file keeps the scale.
 * 60 Adam steps at the small size. */
static void test_latent_scale(void **state)
{
    (void)state;
    static struct fit_sample s[NS], t[NS];
    size_t n = grid_samples(&plastic, s, 1);
    struct fit_data data = {.rgb = s, .n_rgb = n};
    struct fit_model_options mo = fit_model_default_options();
    mo.max_epochs = gonio_test_small() ? 60 : 0;
    const struct fit_model_kind *kind = fit_model_find("latent");
    struct fit_model_file *f1 = NULL, *fk = NULL;
    struct fit_model_report rep;
    assert_int_equal(kind->fit(&data, &mo, &f1, &rep, NULL), 0);
    const double ks[] = {1e12, 1e-12};
    for (int i = 0; i < 2; i++) {
        for (size_t k = 0; k < n; k++) {
            t[k] = s[k];
            for (int c = 0; c < 3; c++)
                t[k].rgb[c] *= ks[i];
        }
        data.rgb = t;
        assert_int_equal(kind->fit(&data, &mo, &fk, &rep, NULL), 0);
        assert_int_equal(fk->n_data, f1->n_data);
        for (size_t j = 0; j < f1->n_data; j++)
            assert_close(fk->data[j], f1->data[j], 1e-6 * fmax(1.0, fabs(f1->data[j])));
        double sc;
        assert_int_equal(fit_model_file_get_double(fk, "scale", NULL, &sc, NULL), 0);
        assert_rel_close(sc, ks[i], 1e-15);
        fit_model_file_free(fk);
    }
    fit_model_file_free(f1);
}

/* The spectral network at its epoch limit (it once reported converged). */
static void test_spectral_limit(void **state)
{
    (void)state;
    static struct fit_spectral_sample sp[400];
    size_t n = 0;
    for (int ti = 0; ti <= 60; ti += 15)
        for (int tr = -60; tr <= 60; tr += 15)
            for (int nm = 400; nm <= 700; nm += 100)
                sp[n++] = (struct fit_spectral_sample){ti, tr, nm, 0.1 + 0.001 * (nm - 400), 0};
    struct fit_data data = {.spectral = sp, .n_spectral = n};
    struct fit_model_report rep;
    struct fit_status st = fit_kind("mlp-spectral", &data, 20, &rep);
    assert_int_equal(fit_status_code(&st), FIT_STATUS_NOT_CONVERGED);
    assert_int_equal(st.geometries, 45); /* 5 x 9 pairs, 4 wavelengths each */
}

/* Six samples (DS4's pairs) for nine parameters, twelve latents, a network:
 * every model says underdetermined. */
static void test_models_underdetermined(void **state)
{
    (void)state;
    struct fit_sample s[6] = {0};
    const double tr[6] = {-60, -20, 20, 28, 36, 60};
    for (int k = 0; k < 6; k++) {
        brdf_pair_inplane(30, tr[k], &s[k].g);
        brdf_abc_eval(&plastic, &s[k].g, s[k].rgb);
    }
    struct fit_data data = {.rgb = s, .n_rgb = 6};
    const char *models[] = {"abc", "abc-prior", "latent", "mlp", "abc-pseudo"};
    for (size_t i = 0; i < sizeof models / sizeof models[0]; i++) {
        struct fit_model_report rep;
        struct fit_status st = fit_kind(models[i], &data, gonio_test_small() ? 40 : 0, &rep);
        assert_true(st.findings & (1u << FIT_STATUS_UNDERDETERMINED));
        assert_int_equal(st.geometries, 6);
    }
}

/* Values no material has (log-uniform noise over four decades at each
 * geometry): the decoder meets data unlike its training set, the ABC a
 * "material" it cannot hold; both residuals are far above the noise. */
static void test_models_poor_fit(void **state)
{
    (void)state;
    static struct fit_sample s[NS];
    size_t n = grid_samples(&plastic, s, 1);
    uint64_t seed = 99;
    for (size_t k = 0; k < n; k++)
        for (int c = 0; c < 3; c++)
            s[k].rgb[c] = pow(10.0, -2.0 + 4.0 * (double)(brdf_splitmix64(&seed) >> 11) /
                                           9007199254740992.0);
    struct fit_data data = {.rgb = s, .n_rgb = n};
    const char *models[] = {"abc", "latent"};
    for (size_t i = 0; i < 2; i++) {
        struct fit_model_report rep;
        struct fit_status st = fit_kind(models[i], &data, 0, &rep);
        assert_true(st.findings & (1u << FIT_STATUS_POOR_FIT));
        assert_true(st.heldout > FIT_STATUS_POOR_FACTOR * FIT_STATUS_NOISE_LOG);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rules),
        cmocka_unit_test(test_distinct_pairs),
        cmocka_unit_test(test_models_converged_and_limits),
        cmocka_unit_test(test_at_bound),
        cmocka_unit_test(test_latent_scale),
        cmocka_unit_test(test_spectral_limit),
        cmocka_unit_test(test_models_underdetermined),
        cmocka_unit_test(test_models_poor_fit),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
