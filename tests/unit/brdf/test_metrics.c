/* Error metrics against DESIGN.md's formulas written out in the test. */
#include "brdf/domain.h"
#include "brdf/material_private.h"
#include "brdf/metrics.h"
#include "tests/gonio_test.h"

/* Plain formulas: theta_i in degrees per pair, independent of the pairs'
 * direction vectors. */
static void reference(const double *ti_deg, const double *f, const double *g, size_t n,
                      double *log_err, double *rel)
{
    double sl = 0, num = 0, den = 0;
    size_t used = 0;
    for (size_t i = 0; i < n; i++) {
        int bad = 0;
        for (int c = 0; c < 3; c++)
            bad |= isnan(f[3 * i + c]) || isnan(g[3 * i + c]);
        if (bad)
            continue;
        double w = cos(ti_deg[i] * 3.14159265358979323846 / 180);
        for (int c = 0; c < 3; c++) {
            double a = f[3 * i + c], b = g[3 * i + c];
            sl += fabs(log(1 + b * w) - log(1 + a * w));
            num += w * (b - a) * (b - a);
            den += w * a * a;
        }
        used++;
    }
    *log_err = sl / (3.0 * used);
    *rel = sqrt(num / den);
}

static void test_small_case(void **state)
{
    (void)state;
    const double ti[4] = {60, 0, 30, 45}, tr[4] = {60, 0, -10, 20};
    struct brdf_pair p[4];
    for (int i = 0; i < 4; i++)
        brdf_pair_inplane(ti[i], tr[i], &p[i]);
    const double f[12] = {1, 2, 3, 0.5, 0.5, 0.5, 0.1, 0.2, 0.3, 10, 20, 30};
    const double g[12] = {2, 2, 1, 0.5, 1.5, 0, 0.1, 0.25, 0.2, 12, 18, 33};
    double el, er;
    reference(ti, f, g, 4, &el, &er);
    struct brdf_errors e;
    brdf_errors_compute(p, f, g, 4, &e);
    assert_int_equal(e.n_used, 4);
    assert_int_equal(e.n_skipped, 0);
    assert_close(e.log, el, 1e-14);
    assert_close(e.rel_rmse, er, 1e-14);

    /* By hand for the first pair alone (cos 60 = 1/2):
     * log: (|ln 2 - ln 1.5| + 0 + |ln 1.5 - ln 2.5|) / 3
     * rel: sqrt(0.5 (1 + 0 + 4) / (0.5 (1 + 4 + 9))) = sqrt(5/14) */
    brdf_errors_compute(p, f, g, 1, &e);
    assert_close(e.log, (log(2 / 1.5) + log(2.5 / 1.5)) / 3, 1e-14);
    assert_close(e.rel_rmse, sqrt(5.0 / 14.0), 1e-14);
}

static void test_nan_pairs_skipped(void **state)
{
    (void)state;
    const double ti[4] = {10, 20, 30, 40};
    struct brdf_pair p[4];
    for (int i = 0; i < 4; i++)
        brdf_pair_inplane(ti[i], 5, &p[i]);
    const double f[12] = {1, 2, 3, 0.4, NAN, 0.4, 0.1, 0.2, 0.3, 5, 6, 7};
    const double g[12] = {1.5, 2, 2, 0.1, 0.2, 0.3, 0.2, 0.2, 0.2, 5, NAN, 7};
    struct brdf_errors e;
    brdf_errors_compute(p, f, g, 4, &e);
    assert_int_equal(e.n_used, 2);
    assert_int_equal(e.n_skipped, 2);
    /* Same as the two clean pairs on their own. */
    const double ti2[2] = {10, 30};
    const double f2[6] = {1, 2, 3, 0.1, 0.2, 0.3}, g2[6] = {1.5, 2, 2, 0.2, 0.2, 0.2};
    double el, er;
    reference(ti2, f2, g2, 2, &el, &er);
    assert_close(e.log, el, 1e-15);
    assert_close(e.rel_rmse, er, 1e-15);

    /* Nothing usable: NAN errors, no crash. */
    brdf_errors_compute(p + 1, f + 3, g + 3, 1, &e);
    assert_int_equal(e.n_used, 0);
    assert_true(isnan(e.log) && isnan(e.rel_rmse));
    brdf_errors_compute(p, f, g, 0, &e);
    assert_int_equal(e.n_used, 0);
    assert_true(isnan(e.log) && isnan(e.rel_rmse));
}

static void test_identical_is_zero(void **state)
{
    (void)state;
    struct brdf_pair p[50];
    double f[150];
    for (int i = 0; i < 50; i++) {
        brdf_pair_inplane(i * 1.5, 40 - i, &p[i]);
        for (int c = 0; c < 3; c++)
            f[3 * i + c] = exp(0.1 * i - 2) * (c + 1);
    }
    struct brdf_errors e;
    brdf_errors_compute(p, f, f, 50, &e);
    assert_true(e.log == 0.0);
    assert_true(e.rel_rmse == 0.0);
    /* Truth and prediction both zero: relative error 0, not NAN. */
    double z[6] = {0};
    brdf_errors_compute(p, z, z, 2, &e);
    assert_true(e.log == 0.0 && e.rel_rmse == 0.0);
}

/* rel RMSE is invariant to a common scale, and a uniform relative error a
 * gives exactly |a|; the log error is not scale invariant. */
static void test_rel_rmse_scaling(void **state)
{
    (void)state;
    struct brdf_pair p[20];
    double f[60], g[60], fs[60], gs[60], g2[60];
    for (int i = 0; i < 20; i++) {
        brdf_pair_inplane(i * 4.0, 10, &p[i]);
        for (int c = 0; c < 3; c++) {
            f[3 * i + c] = 0.2 + 0.1 * c + 0.05 * i;
            g[3 * i + c] = f[3 * i + c] * (1 + 0.03 * ((i + c) % 5) - 0.06);
            fs[3 * i + c] = 7 * f[3 * i + c];
            gs[3 * i + c] = 7 * g[3 * i + c];
            g2[3 * i + c] = 1.25 * f[3 * i + c];
        }
    }
    struct brdf_errors a, b, c;
    brdf_errors_compute(p, f, g, 20, &a);
    brdf_errors_compute(p, fs, gs, 20, &b);
    assert_rel_close(b.rel_rmse, a.rel_rmse, 1e-12);
    assert_true(fabs(b.log - a.log) > 1e-3);
    brdf_errors_compute(p, f, g2, 20, &c);
    assert_close(c.rel_rmse, 0.25, 1e-14);
}

/* A tiny material: Lambertian kd/pi, with a scale, NAN above a theta_h
 * limit to mimic unmeasured cells. */
struct lambert {
    double kd[3], scale, nan_above_th;
};

static void lambert_eval(const void *priv, const struct brdf_pair *pairs, size_t n, double *rgb)
{
    const struct lambert *l = priv;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            rgb[3 * i + c] = pairs[i].theta_h > l->nan_above_th
                                 ? NAN
                                 : l->scale * l->kd[c] / 3.14159265358979323846 *
                                       (1 + 0.5 * pairs[i].theta_d);
}

static const struct brdf_material_ops lambert_ops = {"test-lambert", lambert_eval, free};

static brdf_material *lambert_new(double scale, double nan_above)
{
    struct lambert *l = malloc(sizeof *l);
    assert_non_null(l);
    *l = (struct lambert){{0.2, 0.5, 0.8}, scale, nan_above};
    brdf_material *m = brdf_material_new(&lambert_ops, l, NULL);
    assert_non_null(m);
    return m;
}

static void test_material_blocks(void **state)
{
    (void)state;
    struct brdf_domain d;
    assert_int_equal(brdf_domain_inplane(&d, NULL), 0);
    assert_true(d.n > 2 * 4096); /* several blocks and a partial one */
    brdf_material *truth = lambert_new(1.0, 1.0), *model = lambert_new(1.1, 10);
    struct brdf_errors e;
    assert_int_equal(brdf_errors_material(truth, model, &d, &e, NULL), 0);

    /* Reference: the same values computed here, pair by pair. */
    double *ti = malloc(d.n * sizeof *ti), *f = malloc(3 * d.n * sizeof *f),
           *g = malloc(3 * d.n * sizeof *g);
    assert_true(ti && f && g);
    size_t nan_pairs = 0;
    for (size_t i = 0; i < d.n; i++) {
        ti[i] = brdf_pair_theta_i_deg(&d.pairs[i]);
        double th = d.pairs[i].theta_h, td = d.pairs[i].theta_d;
        const double kd[3] = {0.2, 0.5, 0.8};
        for (int c = 0; c < 3; c++) {
            f[3 * i + c] = th > 1.0 ? NAN : kd[c] / 3.14159265358979323846 * (1 + 0.5 * td);
            g[3 * i + c] = 1.1 * kd[c] / 3.14159265358979323846 * (1 + 0.5 * td);
        }
        nan_pairs += th > 1.0;
    }
    double el, er;
    reference(ti, f, g, d.n, &el, &er);
    assert_true(nan_pairs > 0);
    assert_int_equal(e.n_skipped, nan_pairs);
    assert_int_equal(e.n_used, d.n - nan_pairs);
    assert_rel_close(e.log, el, 1e-12);
    assert_close(e.rel_rmse, 0.1, 1e-12);
    assert_rel_close(e.rel_rmse, er, 1e-12);

    /* A material against itself. */
    assert_int_equal(brdf_errors_material(model, model, &d, &e, NULL), 0);
    assert_true(e.log == 0.0 && e.rel_rmse == 0.0 && e.n_used == d.n);

    free(ti);
    free(f);
    free(g);
    brdf_material_free(truth);
    brdf_material_free(model);
    brdf_domain_free(&d);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_small_case),
        cmocka_unit_test(test_nan_pairs_skipped),
        cmocka_unit_test(test_identical_is_zero),
        cmocka_unit_test(test_rel_rmse_scaling),
        cmocka_unit_test(test_material_blocks),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
