/* Latent fits with the committed decoder (configs/models/latent-decoder.gld):
 *  - samples of the decoder at a training material's own latent: the fit
 *    reproduces that material's decoder output (out of plane too);
 *  - in-plane samples of a training material's NBRDF: the fitted model is
 *    about as good out of plane as the latent training gave it;
 *  - DS1 samples of a held-out material: the fit beats the mean latent and
 *    a random training latent over the full domain;
 *  (at the small size, gonio_test_small: the blend fitted on the fit's own
 *  300-sample subset, the NBRDF fits on DS2 samples, nylon only held out,
 *  a 2000-node evaluation domain, DS4's errors on every 143rd node);
 *  - outputs are finite and non-negative at grazing angles and theta_h = 0,
 *    even for latents far outside the training set;
 *  - too few usable samples is a GONIO_EFIT error;
 *  - DS4 (six pairs) of the held-out materials that need the population
 *    prior stays within the acceptance's 0.12 over the full domain;
 *  - the prior's gradient matches finite differences, and its bandwidth
 *    maximises the latents' leave-one-out likelihood;
 *  - weighted by domain share, a fit of spread samples plus a crowd from
 *    another material follows the spread samples.
 * Errors are computed here, with the metrics' formula written out. */
#include <string.h>

#include "brdf/angles.h"
#include "brdf/domain.h"
#include "brdf/material.h"
#include "fit/latent.h"
#include "fit/latent_private.h"
#include "tests/gonio_test.h"

static latent_decoder *dec;

static int setup(void **state)
{
    (void)state;
    char path[4096];
    if (latent_decoder_default_path(path, sizeof path) < 0)
        return -1;
    struct gonio_err err = {0};
    dec = latent_decoder_load(path, &err);
    if (!dec)
        fprintf(stderr, "%s\n", err.msg);
    return dec ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    latent_decoder_free(dec);
    return 0;
}

/* The DS1 grid of the design brief, written out (not from the planner);
 * small: DS2 (theta_i step 15, diffuse step 10, glossy step 2), for the
 * fits of NBRDF samples at the small size (valgrind: a fit's cost goes
 * with its samples). */
static size_t ds_grid(struct brdf_pair *out, int small)
{
    int si = small ? 15 : 5, sd = small ? 10 : 5, sg = small ? 2 : 1;
    size_t n = 0;
    for (int ti = 0; ti <= 80; ti += si) {
        for (int tr = -80; tr <= 80; tr += sd)
            if (abs(tr - ti) > 15 && abs(ti + tr) >= 5)
                brdf_pair_inplane(ti, tr, &out[n++]);
        for (int k = -15; k <= 15; k += sg) {
            int tr = ti + k;
            if (abs(tr) <= 80 && abs(ti + tr) >= 5)
                brdf_pair_inplane(ti, tr, &out[n++]);
        }
    }
    return n;
}

/* mean over pairs and channels of |log(1 + a cos) - log(1 + b cos)| */
static double log_err(const double *a, const double *b, const struct brdf_pair *p, size_t n)
{
    double s = 0;
    for (size_t k = 0; k < n; k++) {
        double c = p[k].wi[2];
        for (int ch = 0; ch < 3; ch++)
            s += fabs(log(1 + a[3 * k + ch] * c) - log(1 + b[3 * k + ch] * c));
    }
    return s / (3.0 * (double)n);
}

static struct fit_sample *samples_of(const double *rgb, const struct brdf_pair *p, size_t n)
{
    struct fit_sample *s = calloc(n, sizeof *s);
    for (size_t k = 0; k < n; k++) {
        s[k].g = p[k];
        memcpy(s[k].rgb, rgb + 3 * k, sizeof s[k].rgb);
    }
    return s;
}

static struct brdf_domain eval_domain(void)
{
    struct brdf_domain d;
    struct gonio_err err = {0};
    if (brdf_domain_oop_random(&d, gonio_test_small() ? 2000 : 8000, 99, &err) < 0)
        fail_msg("%s", err.msg);
    return d;
}

/* Spread samples of one material and a crowd in a grazing corner from
 * another (what an adaptive capture's crowd looks like to a model that
 * cannot follow it): weighted by domain share, the crowd counts as the bit
 * of the domain it covers and the fit follows the spread samples. */
static void test_weighted_fit_ignores_crowd(void **state)
{
    (void)state;
    long m = latent_decoder_find(dec, "white-paint"), m2 = latent_decoder_find(dec, "chrome");
    assert_true(m >= 0 && m2 >= 0);
    const double *za = latent_decoder_latent(dec, (size_t)m);
    struct brdf_pair p[400];
    size_t n = 0;
    for (int ti = 0; ti <= 75; ti += 15)
        for (int tr = -75; tr <= 75; tr += 6)
            if (abs(ti + tr) >= 5)
                brdf_pair_inplane(ti, tr, &p[n++]);
    size_t spread = n;
    for (int c = 0; c < 120; c++)
        brdf_pair_inplane(70 + 0.1 * (c % 10), -(60 + 0.1 * (c / 10)), &p[n++]);
    double *rgb = malloc(3 * n * sizeof *rgb);
    latent_decoder_eval(dec, za, p, spread, rgb);
    latent_decoder_eval(dec, latent_decoder_latent(dec, (size_t)m2), p + spread, n - spread,
                        rgb + 3 * spread);
    struct fit_sample *s = samples_of(rgb, p, n);
    struct brdf_domain d = eval_domain();
    double *a = malloc(3 * d.n * sizeof *a), *b = malloc(3 * d.n * sizeof *b);
    latent_decoder_eval(dec, za, d.pairs, d.n, a);
    double e[2];
    for (int weighted = 0; weighted < 2; weighted++) {
        struct latent_fit_options o = latent_fit_default_options();
        o.domain_weights = weighted;
        if (gonio_test_small()) { /* valgrind: the weighting, not its convergence */
            o.weighted_iter = o.max_iter;
            o.weighted_starts = o.n_starts;
        }
        double z[LATENT_MAX_NZ];
        struct latent_fit_info info;
        struct gonio_err err = {0};
        if (fit_latent(dec, s, n, &o, z, &info, &err) < 0)
            fail_msg("%s", err.msg);
        assert_int_equal(info.domain_weights, weighted);
        latent_decoder_eval(dec, z, d.pairs, d.n, b);
        e[weighted] = log_err(b, a, d.pairs, d.n);
    }
    printf("error against the spread samples' material: unweighted %.4f, weighted %.4f\n", e[0],
           e[1]);
    assert_true(e[1] < 0.5 * e[0]);
    free(a);
    free(b);
    free(s);
    free(rgb);
    brdf_domain_free(&d);
}

/* Samples of the decoder itself at a latent between two training materials
 * (so that no start of the fit is the answer). */
static void test_recovers_latent(void **state)
{
    (void)state;
    long m = latent_decoder_find(dec, "white-paint"), m2 = latent_decoder_find(dec, "chrome");
    assert_true(m >= 0 && m2 >= 0);
    double zt[LATENT_MAX_NZ];
    for (int k = 0; k < latent_decoder_nz(dec); k++)
        zt[k] = 0.7 * latent_decoder_latent(dec, (size_t)m)[k] +
                0.3 * latent_decoder_latent(dec, (size_t)m2)[k];
    struct brdf_pair ds1[2000];
    size_t n = ds_grid(ds1, 0);
    double *rgb = malloc(3 * n * sizeof *rgb);
    latent_decoder_eval(dec, zt, ds1, n, rgb);
    struct fit_sample *s = samples_of(rgb, ds1, n);
    double z[LATENT_MAX_NZ];
    struct latent_fit_info info;
    struct gonio_err err = {0};
    struct latent_fit_options o = latent_fit_default_options();
    o.lambda_z = 0; /* exact data: no prior pull */
    o.prior_scale = 0;
    /* small (valgrind): the fit's own seeded subset of 300 of the samples */
    if (gonio_test_small())
        o.max_samples = 300;
    if (fit_latent(dec, s, n, &o, z, &info, &err) < 0)
        fail_msg("%s", err.msg);
    assert_int_equal(info.used, n < o.max_samples ? n : o.max_samples);
    assert_true(info.loss < 0.01);
    assert_true(info.start_loss > 2 * info.loss); /* the starts were not the answer */

    struct brdf_domain d = eval_domain();
    double *a = malloc(3 * d.n * sizeof *a), *b = malloc(3 * d.n * sizeof *b);
    latent_decoder_eval(dec, zt, d.pairs, d.n, a);
    latent_decoder_eval(dec, z, d.pairs, d.n, b);
    double e = log_err(a, b, d.pairs, d.n);
    /* the decoder's spread between materials, for scale */
    latent_decoder_eval(dec, latent_decoder_latent(dec, (size_t)m2), d.pairs, d.n, b);
    double spread = log_err(a, b, d.pairs, d.n);
    print_message("blended latent: in-plane loss %.5f (start %.5f), full-domain log error "
                  "%.5f (chrome vs blend %.4f)\n",
                  info.loss, info.start_loss, e, spread);
    assert_true(e < 0.01);
    assert_true(e < 0.05 * spread);
    free(a);
    free(b);
    free(s);
    free(rgb);
    brdf_domain_free(&d);
}

static void fit_nbrdf_ds1(const char *name, double *z, struct latent_fit_info *info)
{
    char spec[96];
    snprintf(spec, sizeof spec, "nbrdf:%s", name);
    struct gonio_err err = {0};
    brdf_material *m = brdf_material_open(spec, &err);
    if (!m)
        fail_msg("%s", err.msg);
    struct brdf_pair ds1[2000];
    size_t n = ds_grid(ds1, gonio_test_small());
    double *rgb = malloc(3 * n * sizeof *rgb);
    brdf_material_eval(m, ds1, n, rgb);
    struct fit_sample *s = samples_of(rgb, ds1, n);
    if (fit_latent(dec, s, n, NULL, z, info, &err) < 0)
        fail_msg("%s", err.msg);
    free(s);
    free(rgb);
    brdf_material_free(m);
}

/* Full-domain (8k-node subset) log error of latent z against nbrdf:name. */
static double full_err(const char *name, const double *z, const struct brdf_domain *d)
{
    char spec[96];
    snprintf(spec, sizeof spec, "nbrdf:%s", name);
    brdf_material *m = brdf_material_open(spec, NULL);
    assert_non_null(m);
    double *a = malloc(3 * d->n * sizeof *a), *b = malloc(3 * d->n * sizeof *b);
    brdf_material_eval(m, d->pairs, d->n, a);
    brdf_material *lm = latent_material(dec, z, NULL);
    assert_non_null(lm);
    brdf_material_eval(lm, d->pairs, d->n, b);
    double e = log_err(a, b, d->pairs, d->n);
    brdf_material_free(lm);
    brdf_material_free(m);
    free(a);
    free(b);
    return e;
}

static void test_training_material_from_inplane(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    const char *name = "green-metallic-paint";
    long m = latent_decoder_find(dec, name);
    assert_true(m >= 0);
    double z[LATENT_MAX_NZ];
    struct latent_fit_info info;
    fit_nbrdf_ds1(name, z, &info);
    struct brdf_domain d = eval_domain();
    double e_fit = full_err(name, z, &d);
    double e_train = full_err(name, latent_decoder_latent(dec, (size_t)m), &d);
    /* the fitted latent against the material's own latent, decoder vs decoder */
    double *a = malloc(3 * d.n * sizeof *a), *b = malloc(3 * d.n * sizeof *b);
    latent_decoder_eval(dec, latent_decoder_latent(dec, (size_t)m), d.pairs, d.n, a);
    latent_decoder_eval(dec, z, d.pairs, d.n, b);
    double e_own = log_err(a, b, d.pairs, d.n);
    free(a);
    free(b);
    print_message("%s: DS1 fit %.4f, training latent %.4f, fit vs own latent %.4f\n", name,
                  e_fit, e_train, e_own);
    assert_true(e_fit < 1.5 * e_train + 0.005);
    assert_true(e_own < 0.01);
    brdf_domain_free(&d);
}

static void test_heldout_beats_mean(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    struct brdf_domain d = eval_domain();
    const char *names[] = {"nylon", "brass"};
    for (int i = 0; i < (gonio_test_small() ? 1 : 2); i++) { /* small: nylon only */
        assert_true(latent_decoder_find(dec, names[i]) < 0); /* really held out */
        double z[LATENT_MAX_NZ];
        struct latent_fit_info info;
        fit_nbrdf_ds1(names[i], z, &info);
        double e_fit = full_err(names[i], z, &d);
        double e_mean = full_err(names[i], latent_decoder_mean_latent(dec), &d);
        double e_first = full_err(names[i], latent_decoder_latent(dec, 0), &d);
        print_message("%s: DS1 fit %.4f, mean latent %.4f, %s's latent %.4f\n", names[i],
                      e_fit, e_mean, latent_decoder_material(dec, 0), e_first);
        assert_true(e_fit < 0.5 * e_mean);
        assert_true(e_fit < e_first);
    }
    brdf_domain_free(&d);
}

static void check_finite(const double *z)
{
    struct brdf_pair p[8];
    brdf_pair_inplane(89.9, 89.9, &p[0]);
    brdf_pair_inplane(89.9, -89.9, &p[1]);
    brdf_pair_inplane(0, 89.9, &p[2]);
    brdf_pair_spherical(89.9, 0, 89.9, 90, &p[3]);
    brdf_pair_from_hd(0, 0, 0, &p[4]);
    brdf_pair_from_hd(0, 1.5, 2.0, &p[5]);
    brdf_pair_from_hd(0, 89.9 * BRDF_DEG, -3.0, &p[6]);
    brdf_pair_inplane(30, 30, &p[7]); /* mirror: theta_h = 0 */
    brdf_material *m = latent_material(dec, z, "t");
    assert_non_null(m);
    double rgb[24];
    assert_int_equal(brdf_material_eval(m, p, 8, rgb), 0);
    for (int k = 0; k < 24; k++) {
        if (!isfinite(rgb[k]) || rgb[k] < 0)
            fail_msg("value %d = %g", k, rgb[k]);
    }
    brdf_material_free(m);
}

static void test_finite_at_extremes(void **state)
{
    (void)state;
    int nz = latent_decoder_nz(dec);
    for (size_t m = 0; m < latent_decoder_n_materials(dec); m++)
        check_finite(latent_decoder_latent(dec, m));
    double z[LATENT_MAX_NZ];
    for (int s = -1; s <= 1; s += 2) {
        for (int k = 0; k < nz; k++)
            z[k] = s * 1e3 * (k % 2 ? 1 : -1);
        check_finite(z); /* far outside training: clipped, never inf */
    }
}

static void test_too_few_samples(void **state)
{
    (void)state;
    struct fit_sample s[4] = {0};
    memset(s, 0, sizeof s);
    brdf_pair_inplane(30, 30, &s[0].g);
    brdf_pair_inplane(30, 40, &s[1].g);
    brdf_pair_inplane(95, 40, &s[2].g); /* below the horizon */
    brdf_pair_inplane(30, 50, &s[3].g);
    s[3].rgb[1] = NAN;
    double z[LATENT_MAX_NZ];
    struct latent_fit_info info;
    struct gonio_err err = {0};
    assert_int_equal(fit_latent(dec, s, 4, NULL, z, &info, &err), -GONIO_EFIT);
    assert_non_null(strstr(err.msg, "2 usable"));
}

/* The acceptance line of the regularised fit: DS4 (six in-plane pairs at
 * theta_i 30, configs/plans/ds4.yaml) of held-out materials, full-domain log
 * error <= 0.12. These three are the ones the population prior was added
 * for (gold-metallic-paint was 0.173 and blue-acrylic 0.108 without it) and
 * the one it moved most the other way (alum-bronze 0.050 -> 0.106). Error:
 * the design's log error on every 13th node of the full reference domain
 * (71k of 923,870; 13 and the 180 phi_d steps are coprime, so every phi_d
 * is visited; within 0.001 of the whole domain's figure for these three). The fit without the prior is printed, not asserted: it shows
 * what the prior is worth, and may change with the decoder. */
static void test_ds4_heldout(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    const char *names[] = {"gold-metallic-paint", "blue-acrylic", "alum-bronze"};
    const double tr[6] = {-60, -20, 20, 28, 36, 60};
    struct brdf_pair g[6];
    for (int k = 0; k < 6; k++)
        brdf_pair_inplane(30, tr[k], &g[k]);
    struct brdf_domain full;
    struct gonio_err err = {0};
    assert_true(brdf_domain_full(&full, &err) >= 0);
    /* small (valgrind): every 143rd node (6.5k; 143 = 11 x 13 is coprime
     * with 180 too) */
    size_t stride = gonio_test_small() ? 143 : 13;
    struct brdf_domain d = {0};
    d.pairs = malloc((full.n / stride + 1) * sizeof *d.pairs);
    for (size_t k = 0; k < full.n; k += stride)
        d.pairs[d.n++] = full.pairs[k];
    brdf_domain_free(&full);
    for (int i = 0; i < 3; i++) {
        assert_true(latent_decoder_find(dec, names[i]) < 0); /* really held out */
        char spec[96];
        snprintf(spec, sizeof spec, "nbrdf:%s", names[i]);
        brdf_material *m = brdf_material_open(spec, &err);
        if (!m)
            fail_msg("%s", err.msg);
        double v[18];
        brdf_material_eval(m, g, 6, v);
        brdf_material_free(m);
        struct fit_sample *s = samples_of(v, g, 6);
        double z[LATENT_MAX_NZ], z0[LATENT_MAX_NZ];
        struct latent_fit_info info;
        if (fit_latent(dec, s, 6, NULL, z, &info, &err) < 0)
            fail_msg("%s", err.msg);
        struct latent_fit_options o = latent_fit_default_options();
        o.prior_scale = 0;
        if (fit_latent(dec, s, 6, &o, z0, NULL, &err) < 0)
            fail_msg("%s", err.msg);
        free(s);
        double e = full_err(names[i], z, &d), e0 = full_err(names[i], z0, &d);
        print_message("%s DS4: full-domain log error %.4f (without the population prior "
                      "%.4f), prior weight %.2e, bandwidth %.3f\n",
                      names[i], e, e0, info.prior_weight, info.bandwidth);
        assert_true(e <= 0.12);
        assert_close(info.prior_weight, LATENT_PRIOR_SCALE / 18.0, 1e-12);
    }
    free(d.pairs);
}

static void test_prior_gradient_and_bandwidth(void **state)
{
    (void)state;
    int nz = latent_decoder_nz(dec);
    double h = latent_decoder_prior_bandwidth(dec);
    assert_true(h > 0 && isfinite(h));
    /* between two training latents, where several kernels contribute */
    double z[LATENT_MAX_NZ], g[LATENT_MAX_NZ] = {0};
    for (int k = 0; k < nz; k++)
        z[k] = 0.6 * latent_decoder_latent(dec, 3)[k] + 0.4 * latent_decoder_latent(dec, 7)[k];
    double f = latent_prior_nll(dec, h, z, 2.0, g);
    assert_true(isfinite(f));
    for (int k = 0; k < nz; k++) {
        double zp[LATENT_MAX_NZ], zm[LATENT_MAX_NZ], eps = 1e-6;
        memcpy(zp, z, sizeof zp);
        memcpy(zm, z, sizeof zm);
        zp[k] += eps;
        zm[k] -= eps;
        double fd = (latent_prior_nll(dec, h, zp, 0, NULL) - latent_prior_nll(dec, h, zm, 0, NULL)) /
                    (2 * eps);
        assert_close(g[k], 2.0 * fd, 1e-5 * (1 + fabs(fd)));
    }
    /* at a training latent the density is higher than half-way to another */
    assert_true(latent_prior_nll(dec, h, latent_decoder_latent(dec, 3), 0, NULL) < f);
    /* the bandwidth maximises the leave-one-out log likelihood, computed here */
    size_t m = latent_decoder_n_materials(dec);
    double ll[3];
    const double fac[3] = {0.9, 1.0, 1.0 / 0.9};
    for (int t = 0; t < 3; t++) {
        double hh = h * fac[t], s = 0;
        for (size_t a = 0; a < m; a++) {
            double acc = 0;
            for (size_t b = 0; b < m; b++) {
                if (b == a)
                    continue;
                double d2 = 0;
                for (int k = 0; k < nz; k++) {
                    double u = latent_decoder_latent(dec, a)[k] - latent_decoder_latent(dec, b)[k];
                    d2 += u * u;
                }
                acc += exp(-d2 / (2 * hh * hh)) / pow(hh, nz);
            }
            s += log(acc);
        }
        ll[t] = s;
    }
    print_message("bandwidth %.4f: leave-one-out log likelihood %.3f, x0.9 %.3f, /0.9 %.3f\n", h,
                  ll[1], ll[0], ll[2]);
    assert_true(ll[1] > ll[0] && ll[1] > ll[2]);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_recovers_latent),
        cmocka_unit_test(test_training_material_from_inplane),
        cmocka_unit_test(test_heldout_beats_mean),
        cmocka_unit_test(test_finite_at_extremes),
        cmocka_unit_test(test_too_few_samples),
        cmocka_unit_test(test_ds4_heldout),
        cmocka_unit_test(test_prior_gradient_and_bandwidth),
        cmocka_unit_test(test_weighted_fit_ignores_crowd),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
