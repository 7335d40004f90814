/* Saturated readings as lower bounds in the networks and the latent fit
 * (docs/fitting.md "Saturated readings"), and the MLP's in-plane tolerance:
 *  - an MLP trained on a smooth curve whose every other row is a lower bound
 *    at half the truth: censored, it follows the curve through those rows;
 *    taken as values, it is pulled down between them;
 *  - the latent fit of decoder samples whose brightest readings are clipped:
 *    censored, it recovers the material; clipped, its peak stays low;
 *  - a commanded in-plane pair a few hundredths of a degree out of its
 *    plane (a rig's settling) is in-plane for training, with theta_i and
 *    theta_o kept; farther out, or with no tolerance, it is not. */
#include <string.h>
#include <unistd.h>

#include "brdf/angles.h"
#include "fit/latent.h"
#include "fit/mlp.h"
#include "fit/models.h"
#include "tests/gonio_test.h"

#define CURVE_N 64

/* mean |log(1 + fhat c) - log(1 + f c)| over the flagged rows of a network
 * trained on t(x) = 2 + sin(3x), x in [0, 2], c = 1, rows with odd index a
 * lower bound at t / 2 (flagged only when censored). */
static double curve_error(int censored)
{
    double u[CURVE_N], f[CURVE_N], c[CURVE_N], truth[CURVE_N];
    unsigned char lower[CURVE_N];
    for (int i = 0; i < CURVE_N; i++) {
        u[i] = 2.0 * i / (CURVE_N - 1);
        truth[i] = 2 + sin(3 * u[i]);
        f[i] = i % 2 ? 0.5 * truth[i] : truth[i];
        c[i] = 1;
        lower[i] = i % 2 == 1;
    }
    static const int widths[] = {1, 16, 16, 1};
    struct fit_mlp net;
    struct gonio_err err = {0};
    assert_int_equal(fit_mlp_init(&net, 3, widths, &err), 0);
    struct fit_mlp_train_options o = fit_mlp_default_train_options();
    o.quiet = 1;
    o.holdout = 0; /* every row trains: the test is about the loss, not early stopping */
    o.max_epochs = gonio_test_small() ? 800 : 2000;
    o.lower = censored ? lower : NULL;
    struct fit_mlp_train_report r;
    if (fit_mlp_train(&net, u, f, c, CURVE_N, &o, &r, &err) < 0)
        fail_msg("%s", err.msg);
    double e = 0;
    for (int i = 1; i < CURVE_N; i += 2) {
        double z;
        fit_mlp_forward(&net, &u[i], 1, &z);
        e += fabs(log1p(fit_mlp_value(z)) - log1p(truth[i]));
    }
    fit_mlp_free(&net);
    return e / (CURVE_N / 2);
}

static void test_mlp_censored(void **state)
{
    (void)state;
    double cens = curve_error(1), vals = curve_error(0);
    print_message("bounds at half the truth on every other row: log error there %.4f "
                  "censored, %.4f taken as values\n",
                  cens, vals);
    /* log 2 = 0.69 between the curve and its bounds: values pull the net
     * about half-way down, bounds not at all */
    assert_true(cens < 0.05);
    assert_true(vals > 0.1);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* A decoder material's DS2-like in-plane samples, readings above the 85th
 * percentile of the red channel clipped there (all channels of the
 * sample, as a detector's full well does to the brightest), flagged. */
static void test_latent_censored(void **state)
{
    (void)state;
    char path[4096];
    assert_true(latent_decoder_default_path(path, sizeof path) >= 0);
    struct gonio_err err = {0};
    latent_decoder *d = latent_decoder_load(path, &err);
    if (!d)
        fail_msg("%s", err.msg);
    long m = latent_decoder_find(d, "chrome");
    assert_true(m >= 0);
    const double *zt = latent_decoder_latent(d, (size_t)m);
    struct brdf_pair g[600];
    size_t n = 0;
    for (int ti = 0; ti <= 75; ti += 15)
        for (int tr = -75; tr <= 75; tr += 3)
            if (abs(ti + tr) >= 5)
                brdf_pair_inplane(ti, tr, &g[n++]);
    double *truth = malloc(3 * n * sizeof *truth), *fit = malloc(3 * n * sizeof *fit);
    latent_decoder_eval(d, zt, g, n, truth);
    double *red = calloc(n, sizeof *red);
    for (size_t k = 0; k < n; k++)
        red[k] = truth[3 * k];
    qsort(red, n, sizeof *red, cmp_double);
    double clip = red[n * 85 / 100];
    struct fit_sample *s = calloc(n, sizeof *s);
    unsigned char *lower = calloc(n, 1);
    size_t flagged = 0;
    for (size_t k = 0; k < n; k++) {
        s[k].g = g[k];
        for (int ch = 0; ch < 3; ch++) {
            s[k].rgb[ch] = truth[3 * k + ch] > clip ? clip : truth[3 * k + ch];
            lower[k] |= truth[3 * k + ch] > clip;
        }
        flagged += lower[k];
    }
    double err_of[2];
    for (int censored = 0; censored < 2; censored++) {
        struct latent_fit_options o = latent_fit_default_options();
        o.lower = censored ? lower : NULL;
        if (gonio_test_small())
            o.max_iter = 150;
        double z[LATENT_MAX_NZ];
        struct latent_fit_info info;
        if (fit_latent(d, s, n, &o, z, &info, &err) < 0)
            fail_msg("%s", err.msg);
        latent_decoder_eval(d, z, g, n, fit);
        double e = 0;
        for (size_t k = 0; k < n; k++)
            for (int ch = 0; ch < 3; ch++)
                e += fabs(log1p(fit[3 * k + ch] * g[k].wi[2]) -
                          log1p(truth[3 * k + ch] * g[k].wi[2]));
        err_of[censored] = e / (3.0 * (double)n);
    }
    print_message("chrome, %zu of %zu samples clipped at %.3g: log error against the truth "
                  "%.4f censored, %.4f clipped\n",
                  flagged, n, clip, err_of[1], err_of[0]);
    assert_true(flagged >= n / 10);
    assert_true(err_of[1] < 0.5 * err_of[0]);
    free(truth);
    free(fit);
    free(red);
    free(s);
    free(lower);
    latent_decoder_free(d);
}

/* A pair from its directions' polar and azimuth angles (degrees). */
static struct brdf_pair pair_of(double ti, double pi, double to, double po)
{
    double a = ti * BRDF_DEG, b = pi * BRDF_DEG, c = to * BRDF_DEG, e = po * BRDF_DEG;
    double wi[3] = {sin(a) * cos(b), sin(a) * sin(b), cos(a)};
    double wo[3] = {sin(c) * cos(e), sin(c) * sin(e), cos(c)};
    struct brdf_pair p;
    brdf_pair_from_dirs(wi, wo, &p);
    return p;
}

static void test_mlp_near_plane(void **state)
{
    (void)state;
    double ti, tr;
    /* theta_o 40 at 0.03 deg of azimuth off the plane: 0.015 deg out of it */
    struct brdf_pair p = pair_of(30, 10, 40, 190.03);
    assert_int_equal(fit_mlp_inplane_angles(&p, FIT_MLP_PLANE_TOL, &ti, &tr), 0);
    assert_true(fabs(ti - 30) < 1e-9 && fabs(tr - 40) < 1e-9);
    assert_int_equal(fit_mlp_inplane_angles(&p, 0, &ti, &tr), -1);
    /* near the normal an azimuth says little: 3 deg of it at theta_i 0.5 is
     * 0.026 deg out of the plane of theta_o 60 */
    p = pair_of(0.5, 3, 60, 180);
    assert_int_equal(fit_mlp_inplane_angles(&p, FIT_MLP_PLANE_TOL, &ti, &tr), 0);
    assert_true(fabs(ti - 0.5) < 1e-9 && fabs(tr - 60) < 1e-9);
    /* same side of the normal: theta_r negative */
    p = pair_of(30, 0, 20, 0.05);
    assert_int_equal(fit_mlp_inplane_angles(&p, FIT_MLP_PLANE_TOL, &ti, &tr), 0);
    assert_true(fabs(ti - 30) < 1e-9 && fabs(tr + 20) < 1e-9);
    /* 0.16 deg out of the plane is another geometry */
    p = pair_of(30, 0, 40, 180.31);
    assert_int_equal(fit_mlp_inplane_angles(&p, FIT_MLP_PLANE_TOL, &ti, &tr), -1);
}

/* spectra.csv's saturated column reaches the spectral samples; a flag
 * other than 0 or 1 is an error naming the line. */
static void test_spectral_saturated_column(void **state)
{
    (void)state;
    char path[] = "/tmp/gonio-test-spectra-XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    FILE *fp = fdopen(fd, "w");
    fputs("theta_i,theta_r,wavelength_nm,value,acquisition,integration_s,saturated\n"
          "30,30,550,12.5,0,0.001,1\n"
          "30,40,550,0.25,0,0.05,0\n",
          fp);
    fclose(fp);
    struct fit_spectral_sample *s = NULL;
    size_t n = 0;
    struct gonio_err err = {0};
    assert_int_equal(fit_spectral_samples_read(path, &s, &n, &err), 2);
    assert_int_equal(s[0].saturated, 1);
    assert_int_equal(s[1].saturated, 0);
    free(s);
    fp = fopen(path, "a");
    fputs("30,50,550,0.1,0,0.05,2\n", fp);
    fclose(fp);
    assert_true(fit_spectral_samples_read(path, &s, &n, &err) < 0);
    assert_non_null(strstr(err.msg, ":4: column saturated"));
    unlink(path);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mlp_censored),
        cmocka_unit_test(test_latent_censored),
        cmocka_unit_test(test_mlp_near_plane),
        cmocka_unit_test(test_spectral_saturated_column),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
