/* ABC model: values against a straightforward evaluation of the formula
 * written here from explicit vectors, the hard cases, reciprocity, eta -> 1. */
#include <string.h>

#include "brdf/abc.h"
#include "brdf/angles.h"
#include "brdf/material.h"
#include "tests/gonio_test.h"

#define PI 3.14159265358979323846

static double dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* The textbook form: h = (l + v)/|l + v|, G = min(1, 2 nh nv/vh, 2 nh nl/vh),
 * F with g = sqrt(eta^2 + c^2 - 1), D = A / (1 + B (1 - nh))^C. */
static void reference_abc(const struct brdf_abc *p, const double l_in[3], const double v_in[3],
                          double rgb[3])
{
    double l[3], v[3], h[3];
    double nl_ = sqrt(dot(l_in, l_in)), nv_ = sqrt(dot(v_in, v_in));
    for (int k = 0; k < 3; k++) {
        l[k] = l_in[k] / nl_;
        v[k] = v_in[k] / nv_;
        h[k] = l[k] + v[k];
    }
    double hn = sqrt(dot(h, h));
    for (int k = 0; k < 3; k++)
        h[k] /= hn;
    double nl = l[2], nv = v[2], nh = h[2], vh = dot(v, h);
    double G = fmin(1.0, fmin(2 * nh * nv / vh, 2 * nh * nl / vh));
    double c = vh, g = sqrt(p->eta * p->eta + c * c - 1);
    double F = (g - c) * (g - c) / (2 * (g + c) * (g + c)) *
               (1 + pow(c * (g + c) - 1, 2) / pow(c * (g - c) + 1, 2));
    for (int k = 0; k < 3; k++)
        rgb[k] = p->kd[k] / PI + F * G / (nl * nv) * p->A[k] / pow(1 + p->B * (1 - nh), p->C);
}

static const struct brdf_abc nylon_like = {
    .kd = {0.23, 0.23, 0.21}, .A = {6.1, 5.8, 5.4}, .B = 3334, .C = 0.887, .eta = 1.38};
static const struct brdf_abc metal_like = {
    .kd = {0.003, 0.0033, 0.0036}, .A = {257, 197, 193}, .B = 90806, .C = 1.7, .eta = 9.0};

static void test_matches_reference(void **state)
{
    (void)state;
    const struct brdf_abc *ps[] = {&nylon_like, &metal_like};
    /* out-of-plane directions, not unit length on purpose */
    const double dirs[][2][3] = {
        {{0.3, 0.1, 1.0}, {-0.2, 0.05, 0.9}},
        {{0.5, -0.4, 0.6}, {-0.45, 0.35, 0.7}},
        {{0.0, 0.0, 1.0}, {0.7, 0.2, 0.4}},
        {{0.9, 0.1, 0.2}, {-0.8, 0.3, 0.3}},
        {{0.2, 0.6, 0.5}, {0.1, -0.5, 0.8}},
    };
    for (size_t m = 0; m < 2; m++)
        for (size_t i = 0; i < sizeof dirs / sizeof dirs[0]; i++) {
            struct brdf_pair g;
            brdf_pair_from_dirs(dirs[i][0], dirs[i][1], &g);
            double got[3], want[3];
            brdf_abc_eval(ps[m], &g, got);
            reference_abc(ps[m], dirs[i][0], dirs[i][1], want);
            for (int c = 0; c < 3; c++)
                assert_rel_close(got[c], want[c], 1e-10);
        }
}

static void test_inplane_peak_value(void **state)
{
    (void)state;
    /* At the mirror direction with ti = 30: nh = 1 (D = A), vh = cos 30,
     * G = 1 (2 nh nv / vh = 2), F from the formula at c = cos 30. */
    struct brdf_pair g;
    brdf_pair_inplane(30, 30, &g);
    double c = cos(30 * BRDF_DEG), eta = nylon_like.eta;
    double gg = sqrt(eta * eta + c * c - 1);
    double F = 0.5 * pow((gg - c) / (gg + c), 2) *
               (1 + pow((c * (gg + c) - 1) / (c * (gg - c) + 1), 2));
    double got[3];
    brdf_abc_eval(&nylon_like, &g, got);
    for (int k = 0; k < 3; k++)
        assert_rel_close(got[k], nylon_like.kd[k] / PI + F / (c * c) * nylon_like.A[k], 1e-12);
}

static void test_hard_cases_finite(void **state)
{
    (void)state;
    const double etas[] = {1.0, 1.0 + 1e-15, 1.0 + 1e-8, 1.5, 100.0};
    const double Bs[] = {0.0, 1.0, 1e4, 1e7, 1e12};
    const double Cs[] = {0.0, 0.01, 1.0, 50.0, 1000.0};
    const double ang[][4] = {
        {89.9, 0, 89.9, 180},  /* grazing mirror: v.h -> 0 */
        {89.9, 0, 89.9, 0},    /* grazing retro */
        {89.9, 0, 0, 0},       {0, 0, 89.9, 0}, {89.9, 0, 89.9, 90},
        {0, 0, 0, 0},          {45, 0, 45, 180}, {89.99, 0, 89.99, 179.99},
    };
    for (size_t a = 0; a < sizeof ang / sizeof ang[0]; a++) {
        struct brdf_pair g;
        brdf_pair_spherical(ang[a][0], ang[a][1], ang[a][2], ang[a][3], &g);
        for (size_t e = 0; e < 5; e++)
            for (size_t b = 0; b < 5; b++)
                for (size_t c = 0; c < 5; c++) {
                    struct brdf_abc p = {.kd = {0.1, 0.2, 0.3}, .A = {1e3, 1, 0},
                                         .B = Bs[b], .C = Cs[c], .eta = etas[e]};
                    double rgb[3];
                    brdf_abc_eval(&p, &g, rgb);
                    for (int k = 0; k < 3; k++) {
                        assert_true(isfinite(rgb[k]));
                        assert_true(rgb[k] >= p.kd[k] / PI * (1 - 1e-12));
                    }
                }
    }
    /* The Fresnel factor and its derivative stay finite and in [0, 1]. */
    const double cs[] = {0.0, 1e-300, 1e-12, 1e-6, 0.5, 1.0};
    for (size_t e = 0; e < 5; e++)
        for (size_t k = 0; k < 6; k++) {
            double d;
            double F = brdf_abc_fresnel(etas[e], cs[k], &d);
            assert_true(isfinite(F) && isfinite(d));
            assert_true(F >= 0 && F <= 1);
        }
}

static void test_below_horizon_is_zero(void **state)
{
    (void)state;
    struct brdf_pair g;
    brdf_pair_spherical(95, 0, 30, 180, &g);
    double rgb[3];
    brdf_abc_eval(&nylon_like, &g, rgb);
    for (int k = 0; k < 3; k++)
        assert_close(rgb[k], 0.0, 0.0);
}

static void test_reciprocity(void **state)
{
    (void)state;
    unsigned seed = 12345;
    printf("seed %u\n", seed);
    srand(seed);
    for (int t = 0; t < 500; t++) {
        double ti = 89.9 * rand() / RAND_MAX, to = 89.9 * rand() / RAND_MAX;
        double pi_ = 360.0 * rand() / RAND_MAX, po = 360.0 * rand() / RAND_MAX;
        struct brdf_pair a, b;
        brdf_pair_spherical(ti, pi_, to, po, &a);
        brdf_pair_spherical(to, po, ti, pi_, &b);
        double fa[3], fb[3];
        brdf_abc_eval(&metal_like, &a, fa);
        brdf_abc_eval(&metal_like, &b, fb);
        for (int k = 0; k < 3; k++)
            assert_rel_close(fa[k], fb[k], 1e-11);
    }
}

static void test_eta_one_is_diffuse_only(void **state)
{
    (void)state;
    struct brdf_abc p = metal_like;
    struct brdf_pair g;
    brdf_pair_inplane(40, 38, &g);
    double prev = INFINITY;
    /* F -> 0 smoothly and monotonically as eta -> 1 */
    for (double de = 1e-1; de >= 1e-12; de /= 10) {
        double F = brdf_abc_fresnel(1 + de, cos(g.theta_d), NULL);
        assert_true(F >= 0 && F < prev);
        prev = F;
    }
    assert_true(prev < 1e-20);
    p.eta = 1.0;
    double rgb[3];
    brdf_abc_eval(&p, &g, rgb);
    for (int k = 0; k < 3; k++)
        assert_rel_close(rgb[k], p.kd[k] / PI, 1e-12);
}

static void test_fresnel_derivative(void **state)
{
    (void)state;
    const double etas[] = {1.01, 1.3, 1.5, 3.0, 20.0};
    const double cs[] = {0.05, 0.3, 0.7, 0.99};
    for (size_t e = 0; e < 5; e++)
        for (size_t k = 0; k < 4; k++) {
            double d, h = 1e-6 * etas[e];
            brdf_abc_fresnel(etas[e], cs[k], &d);
            double fd = (brdf_abc_fresnel(etas[e] + h, cs[k], NULL) -
                         brdf_abc_fresnel(etas[e] - h, cs[k], NULL)) /
                        (2 * h);
            assert_close(d, fd, 1e-6 * fabs(fd) + 1e-9);
        }
}

static void test_distribution_large_b(void **state)
{
    (void)state;
    double dB, dC;
    /* exact value where the power form is still representable */
    double x = 1e-3;
    double D = brdf_abc_distribution(1e7, 2.5, x, &dB, &dC);
    assert_rel_close(D, pow(1 + 1e7 * x, -2.5), 1e-12);
    assert_rel_close(dC, -log(1 + 1e7 * x) * D, 1e-12);
    assert_rel_close(dB, -2.5 * x / (1 + 1e7 * x) * D, 1e-12);
    D = brdf_abc_distribution(1e7, 1e4, 0.5, &dB, &dC);
    assert_true(isfinite(D) && isfinite(dB) && isfinite(dC));
}

static void test_material_wrapper(void **state)
{
    (void)state;
    brdf_material *m = brdf_abc_material(&nylon_like, "abc-test");
    assert_non_null(m);
    assert_string_equal(brdf_material_name(m), "abc-test");
    struct brdf_pair g[3];
    brdf_pair_inplane(10, 10, &g[0]);
    brdf_pair_inplane(30, -50, &g[1]);
    brdf_pair_spherical(60, 0, 40, 120, &g[2]);
    double rgb[9];
    assert_int_equal(brdf_material_eval(m, g, 3, rgb), 0);
    for (int i = 0; i < 3; i++) {
        double want[3];
        reference_abc(&nylon_like, g[i].wi, g[i].wo, want);
        for (int k = 0; k < 3; k++)
            assert_rel_close(rgb[3 * i + k], want[k], 1e-10);
    }
    brdf_material_free(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_matches_reference),   cmocka_unit_test(test_inplane_peak_value),
        cmocka_unit_test(test_hard_cases_finite),   cmocka_unit_test(test_below_horizon_is_zero),
        cmocka_unit_test(test_reciprocity),         cmocka_unit_test(test_eta_one_is_diffuse_only),
        cmocka_unit_test(test_fresnel_derivative),  cmocka_unit_test(test_distribution_large_b),
        cmocka_unit_test(test_material_wrapper),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
