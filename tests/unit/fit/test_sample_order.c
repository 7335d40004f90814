/* The same samples in another order give the same model, bit for bit
 * (fit/sample_order.h): fit_abc's parameters and fit_latent's z, with and
 * without saturated flags, and the model files of the registry's fits
 * (abc, abc-prior, latent, auto, mlp, abc-pseudo), for seeded permutations
 * and the reversal of a synthetic ABC material's noisy samples: DS4's six
 * pairs (the adaptive policy's 15 s budget measures them in another order
 * than DS4's travel order) and a wider in-plane set with a repeated pair.
 * The same for fit_abc and fit_latent on DS4's six pairs of MERL materials
 * (nbrdf:NAME), the adaptive policy's 15 s case: that test needs the
 * shared data and is skipped without it (the others need none: the latent
 * decoder and the ABC prior are committed). */
#include <string.h>

#include "brdf/abc.h"
#include "brdf/angles.h"
#include "brdf/domain.h"
#include "brdf/material.h"
#include "fit/auto_model.h"
#include "fit/fit.h"
#include "fit/latent.h"
#include "fit/model_file.h"
#include "fit/models.h"
#include "tests/gonio_test.h"

#define MAX_SAMPLES 64
#define N_ORDERS 5 /* reversed, then seeded permutations */

static const struct brdf_abc truth = {
    .kd = {0.12, 0.08, 0.05}, .A = {9.0, 7.0, 5.0}, .B = 900, .C = 0.8, .eta = 1.6};

/* DS4 (configs/plans/ds4.yaml), written out. */
static const double ds4[6][2] = {{30, -60}, {30, -20}, {30, 20}, {30, 28}, {30, 36}, {30, 60}};

/* The synthetic material at n pairs, with 3 % multiplicative noise so no
 * fit lands on the truth exactly. wide: DS4 plus theta_i 10 and 55 sweeps
 * and DS4's mirror pair measured again (another reading, another value). */
static size_t synth(int wide, struct fit_sample *s)
{
    size_t n = 0;
    for (int k = 0; k < 6; k++)
        brdf_pair_inplane(ds4[k][0], ds4[k][1], &s[n++].g);
    if (wide) {
        for (int tr = -70; tr <= 70; tr += 14) {
            brdf_pair_inplane(10, tr + 3, &s[n++].g);
            brdf_pair_inplane(55, tr, &s[n++].g);
        }
        brdf_pair_inplane(30, 28, &s[n++].g);
    }
    uint64_t st = 7;
    for (size_t k = 0; k < n; k++) {
        brdf_abc_eval(&truth, &s[k].g, s[k].rgb);
        for (int c = 0; c < 3; c++)
            s[k].rgb[c] *= 1 + 0.03 * ((double)(brdf_splitmix64(&st) >> 11) * 0x1p-53 - 0.5);
    }
    return n;
}

/* Order o of the samples and their flags (NULL: none) into out: 0 the
 * reversal, else a Fisher-Yates shuffle seeded by o. */
static void permute(const struct fit_sample *s, const unsigned char *f, size_t n, int o,
                    struct fit_sample *out, unsigned char *fout)
{
    size_t p[MAX_SAMPLES];
    for (size_t k = 0; k < n; k++)
        p[k] = n - 1 - k;
    uint64_t st = (uint64_t)o;
    for (size_t k = n; o > 0 && k > 1; k--) {
        size_t j = (size_t)(brdf_splitmix64(&st) % k), t = p[k - 1];
        p[k - 1] = p[j];
        p[j] = t;
    }
    for (size_t k = 0; k < n; k++) {
        out[k] = s[p[k]];
        if (f)
            fout[k] = f[p[k]];
    }
}

/* Flags on DS4's mirror-side pairs (30, 28) and (30, 36), their values
 * clipped to half: readings of a detector that saturated there. */
static void saturate(struct fit_sample *s, size_t n, unsigned char *f)
{
    for (size_t k = 0; k < n; k++) {
        double ti, tr;
        brdf_pair_to_inplane(&s[k].g, &ti, &tr);
        f[k] = fabs(ti - 30) < 1e-9 && (fabs(tr - 28) < 1e-9 || fabs(tr - 36) < 1e-9);
        for (int c = 0; c < 3 && f[k]; c++)
            s[k].rgb[c] *= 0.5;
    }
}

/* fit_abc on s[0..n) (modified: flagged clips) in N_ORDERS orders. */
static void abc_orders(struct fit_sample *s, size_t n, int flagged)
{
    struct fit_sample p[MAX_SAMPLES] = {0};
    unsigned char f[MAX_SAMPLES], pf[MAX_SAMPLES];
    if (flagged)
        saturate(s, n, f);
    struct fit_options opt = fit_default_options();
    opt.lower_bound = flagged ? f : NULL;
    struct brdf_abc ref, got;
    struct gonio_err err = {0};
    assert_int_equal(fit_abc(s, n, &opt, &ref, NULL, &err), 0);
    for (int o = 0; o < N_ORDERS; o++) {
        permute(s, flagged ? f : NULL, n, o, p, pf);
        opt.lower_bound = flagged ? pf : NULL;
        memset(&got, 0xa5, sizeof got);
        assert_int_equal(fit_abc(p, n, &opt, &got, NULL, &err), 0);
        assert_memory_equal(&got, &ref, sizeof ref);
    }
}

static void test_abc(void **state)
{
    (void)state;
    struct fit_sample s[MAX_SAMPLES] = {0};
    for (int wide = 0; wide <= 1; wide++)
        for (int flagged = 0; flagged <= 1; flagged++)
            abc_orders(s, synth(wide, s), flagged);
}

static latent_decoder *load_decoder(void)
{
    char path[4096];
    assert_int_equal(latent_decoder_default_path(path, sizeof path) >= 0, 1);
    struct gonio_err err = {0};
    latent_decoder *d = latent_decoder_load(path, &err);
    if (!d)
        print_error("%s\n", err.msg);
    assert_non_null(d);
    return d;
}

/* fit_latent on s[0..n) (modified: flagged clips) in N_ORDERS orders. */
static void latent_orders(const latent_decoder *d, struct fit_sample *s, size_t n, int flagged)
{
    struct fit_sample p[MAX_SAMPLES] = {0};
    unsigned char f[MAX_SAMPLES], pf[MAX_SAMPLES];
    if (flagged)
        saturate(s, n, f);
    struct latent_fit_options opt = latent_fit_default_options();
    opt.lower = flagged ? f : NULL;
    int nz = latent_decoder_nz(d);
    double ref[LATENT_MAX_NZ], got[LATENT_MAX_NZ];
    struct gonio_err err = {0};
    assert_int_equal(fit_latent(d, s, n, &opt, ref, NULL, &err), 0);
    for (int o = 0; o < N_ORDERS; o++) {
        permute(s, flagged ? f : NULL, n, o, p, pf);
        opt.lower = flagged ? pf : NULL;
        assert_int_equal(fit_latent(d, p, n, &opt, got, NULL, &err), 0);
        assert_memory_equal(got, ref, (size_t)nz * sizeof *ref);
    }
}

static void test_latent(void **state)
{
    (void)state;
    latent_decoder *d = load_decoder();
    struct fit_sample s[MAX_SAMPLES] = {0};
    for (int wide = 0; wide <= 1; wide++)
        for (int flagged = 0; flagged <= 1; flagged++)
            latent_orders(d, s, synth(wide, s), flagged);
    latent_decoder_free(d);
}

/* DS4 of MERL materials with sharp and broad lobes (the small size: one),
 * noiseless as the ideal scene reads them. */
static void test_merl_ds4(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    static const char *const names[] = {"brass", "gold-metallic-paint", "nylon"};
    latent_decoder *d = load_decoder();
    size_t n_mats = gonio_test_small() ? 1 : sizeof names / sizeof *names;
    for (size_t i = 0; i < n_mats; i++) {
        char spec[64];
        snprintf(spec, sizeof spec, "nbrdf:%s", names[i]);
        struct gonio_err err = {0};
        brdf_material *m = brdf_material_open(spec, &err);
        if (!m)
            print_error("%s\n", err.msg);
        assert_non_null(m);
        struct brdf_pair g[6];
        double rgb[18];
        for (int k = 0; k < 6; k++)
            brdf_pair_inplane(ds4[k][0], ds4[k][1], &g[k]);
        assert_int_equal(brdf_material_eval(m, g, 6, rgb), 0);
        brdf_material_free(m);
        struct fit_sample s[6] = {0};
        for (int flagged = 0; flagged <= 1; flagged++) {
            for (int k = 0; k < 6; k++) {
                s[k].g = g[k];
                memcpy(s[k].rgb, rgb + 3 * k, sizeof s[k].rgb);
            }
            abc_orders(s, 6, flagged);
            for (int k = 0; k < 6; k++)
                memcpy(s[k].rgb, rgb + 3 * k, sizeof s[k].rgb);
            latent_orders(d, s, 6, flagged);
        }
    }
    latent_decoder_free(d);
}

/* Two model files are the same model: kind, keys, values and data. */
static void assert_same_file(const struct fit_model_file *a, const struct fit_model_file *b,
                             const char *model)
{
    print_message("%s: %zu keys, %zu data\n", model, a->n_kv, a->n_data);
    assert_string_equal(a->kind, b->kind);
    assert_int_equal(a->n_kv, b->n_kv);
    for (size_t k = 0; k < a->n_kv; k++) {
        const char *v = fit_model_file_get(b, a->kv[k].key);
        assert_non_null(v);
        assert_string_equal(v, a->kv[k].value);
    }
    assert_int_equal(a->n_data, b->n_data);
    if (a->n_data)
        assert_memory_equal(a->data, b->data, a->n_data * sizeof *a->data);
}

static struct fit_model_file *registry_fit(const struct fit_model_kind *kind,
                                           const struct fit_sample *s, const unsigned char *f,
                                           size_t n)
{
    struct fit_data data = {
        .rgb = s, .n_rgb = n, .rgb_lower = fit_model_censors(kind, FIT_SATURATED_DEFAULT) ? f : NULL};
    struct fit_model_options mo = fit_model_default_options();
    struct fit_model_file *mf = NULL;
    struct fit_model_report rep;
    struct gonio_err err = {0};
    if (kind->fit(&data, &mo, &mf, &rep, &err))
        print_error("%s: %s\n", kind->name, err.msg);
    assert_non_null(mf);
    return mf;
}

/* The wide set with flags through every RGB fit of the registry; three
 * orders (the small size: one) keep mlp's training affordable. */
static void test_registry(void **state)
{
    (void)state;
    static const char *const models[] = {"abc", "abc-prior", "latent", "auto", "mlp",
                                         "abc-pseudo"};
    struct fit_sample s[MAX_SAMPLES] = {0}, p[MAX_SAMPLES] = {0};
    unsigned char f[MAX_SAMPLES], pf[MAX_SAMPLES];
    size_t n = synth(1, s);
    saturate(s, n, f);
    int orders = gonio_test_small() ? 1 : 3;
    for (size_t m = 0; m < sizeof models / sizeof *models; m++) {
        const struct fit_model_kind *kind = fit_model_find(models[m]);
        assert_non_null(kind);
        struct fit_model_file *ref = registry_fit(kind, s, f, n);
        for (int o = 0; o < orders; o++) {
            permute(s, f, n, o, p, pf);
            struct fit_model_file *got = registry_fit(kind, p, pf, n);
            assert_same_file(ref, got, models[m]);
            fit_model_file_free(got);
        }
        fit_model_file_free(ref);
    }
}

/* auto's cross-validation figures themselves, unrounded: its folds' sums
 * run over the samples, so they too must see one order. */
static void test_auto_cv(void **state)
{
    (void)state;
    struct fit_sample s[MAX_SAMPLES] = {0}, p[MAX_SAMPLES] = {0};
    unsigned char f[MAX_SAMPLES], pf[MAX_SAMPLES];
    size_t n = synth(1, s);
    saturate(s, n, f);
    struct fit_model_options mo = fit_model_default_options();
    struct fit_data data = {.rgb = s, .n_rgb = n, .rgb_lower = f};
    struct fit_auto_cv ref, got;
    struct gonio_err err = {0};
    assert_int_equal(fit_auto_cross_validate(&data, &mo, &ref, &err), 0);
    for (int o = 0; o < (gonio_test_small() ? 1 : 3); o++) {
        permute(s, f, n, o, p, pf);
        data = (struct fit_data){.rgb = p, .n_rgb = n, .rgb_lower = pf};
        assert_int_equal(fit_auto_cross_validate(&data, &mo, &got, &err), 0);
        assert_int_equal(got.chosen, ref.chosen);
        assert_memory_equal(got.cv, ref.cv, ref.n * sizeof *ref.cv);
        assert_memory_equal(got.cv_rms, ref.cv_rms, ref.n * sizeof *ref.cv_rms);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_abc),
        cmocka_unit_test(test_latent),
        cmocka_unit_test(test_registry),
        cmocka_unit_test(test_auto_cv),
        cmocka_unit_test(test_merl_ds4),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
