/* Angle conventions: in-plane <-> directions <-> half/difference <-> axes. */
#include "brdf/angles.h"
#include "tests/gonio_test.h"

#define PI 3.14159265358979323846

static void test_normal_incidence(void **state)
{
    (void)state;
    struct brdf_pair p;
    brdf_pair_inplane(0, 0, &p);
    assert_close(p.wi[2], 1.0, 1e-15);
    assert_close(p.theta_h, 0.0, 1e-15);
    assert_close(p.theta_d, 0.0, 1e-15);
    assert_close(p.phi_d, 0.0, 1e-15);
}

static void test_mirror_is_exact(void **state)
{
    (void)state;
    /* theta_r = theta_i: half vector on the normal, phi_h = 0, so phi_d = 0
     * exactly (not pi, not pi/2 from atan2 of rounding noise). */
    for (double ti = 1; ti <= 89.9; ti += 0.7) {
        struct brdf_pair p;
        brdf_pair_inplane(ti, ti, &p);
        assert_true(p.theta_h < 1e-12);
        assert_close(p.theta_d, ti * BRDF_DEG, 1e-12);
        assert_close(p.phi_d, 0.0, 1e-12);
    }
}

static void test_retro_reflection(void **state)
{
    (void)state;
    /* theta_r = -theta_i: detector on the source, wo = wi, theta_d = 0. */
    struct brdf_pair p;
    brdf_pair_inplane(40, -40, &p);
    assert_close(p.wo[0], p.wi[0], 1e-15);
    assert_close(p.theta_h, 40 * BRDF_DEG, 1e-12);
    assert_close(p.theta_d, 0.0, 1e-12);
}

static void test_grazing(void **state)
{
    (void)state;
    struct brdf_pair p;
    brdf_pair_inplane(89.9, 89.9, &p);
    assert_true(isfinite(p.theta_d) && isfinite(p.phi_d));
    assert_close(p.theta_d, 89.9 * BRDF_DEG, 1e-12);
    brdf_pair_inplane(89.9, -89.9, &p);
    assert_close(p.theta_h, 89.9 * BRDF_DEG, 1e-10);
    brdf_pair_inplane(89.9, 0, &p);
    assert_close(brdf_pair_theta_i_deg(&p), 89.9, 1e-10);
    assert_close(brdf_pair_theta_o_deg(&p), 0.0, 1e-10);
}

/* In-plane pairs are the phi_d in {0, pi} nodes: theta_h = |ti - tr|/2
 * and theta_d = (ti + tr)/2 up to the side. */
static void test_inplane_hd(void **state)
{
    (void)state;
    struct brdf_pair p;
    brdf_pair_inplane(50, 20, &p);
    assert_close(p.theta_h, 15 * BRDF_DEG, 1e-12);
    assert_close(p.theta_d, 35 * BRDF_DEG, 1e-12);
    assert_close(fabs(p.phi_d), 0.0, 1e-12);
    brdf_pair_inplane(20, 50, &p);
    assert_close(p.theta_h, 15 * BRDF_DEG, 1e-12);
    assert_close(fabs(p.phi_d), PI, 1e-12);
}

/* Rows of nbrdf_reference_values.csv (shared data), which gives the
 * half/difference angles of spherical geometries computed independently. */
static void test_reference_geometries(void **state)
{
    (void)state;
    static const double rows[][7] = {
        {30, 0, 40, 180, 0.0872664625997, 0.610865238198, -PI},
        {45, 0, 45, 90, 0.61547970867, 0.523598775598, -1.57079632679},
        {60, 0, 10, 180, 0.436332312999, 0.610865238198, 0},
        {20, 30, 70, 250, 0.507334064833, 0.747766712911, 2.70106421946},
        {10, 0, 50, 0, 0.523598775598, 0.349065850399, PI},
        {50, 90, 20, 300, 0.306033666151, 0.5920548095, 0.488704196664},
        {65, 0, 0, 0, 0.567232006898, 0.567232006898, 0},
    };
    for (size_t i = 0; i < sizeof rows / sizeof rows[0]; i++) {
        struct brdf_pair p;
        brdf_pair_spherical(rows[i][0], rows[i][1], rows[i][2], rows[i][3], &p);
        assert_close(p.theta_h, rows[i][4], 1e-9);
        assert_close(p.theta_d, rows[i][5], 1e-9);
        /* phi_d = pi and -pi are the same direction */
        double dp = fmod(fabs(p.phi_d - rows[i][6]), 2 * PI);
        assert_true(dp < 1e-9 || fabs(dp - 2 * PI) < 1e-9);
    }
}

static void test_hd_round_trip(void **state)
{
    (void)state;
    srand(12345);
    for (int n = 0; n < 10000; n++) {
        double th = (rand() / (double)RAND_MAX) * 1.5;
        double td = (rand() / (double)RAND_MAX) * 1.5;
        double pd = (rand() / (double)RAND_MAX) * 2 * PI - PI;
        struct brdf_pair a, b;
        brdf_pair_from_hd(th, td, pd, &a);
        brdf_pair_from_dirs(a.wi, a.wo, &b);
        assert_close(b.theta_h, th, 1e-9);
        assert_close(b.theta_d, td, 1e-9);
        if (th > 1e-6 && td > 1e-6) {
            double dp = fmod(fabs(b.phi_d - pd), 2 * PI);
            assert_true(dp < 1e-8 || fabs(dp - 2 * PI) < 1e-8);
        }
        for (int k = 0; k < 3; k++) {
            assert_close(a.wi[k], b.wi[k], 1e-12);
            assert_close(a.wo[k], b.wo[k], 1e-12);
        }
    }
}

static void test_inplane_round_trip_and_axes(void **state)
{
    (void)state;
    for (double ti = 0; ti <= 89.9; ti += 2.3) {
        for (double tr = -89.9; tr <= 89.9; tr += 3.1) {
            struct brdf_pair p;
            double ti2, tr2, s, a, ti3, tr3;
            brdf_pair_inplane(ti, tr, &p);
            assert_int_equal(brdf_pair_to_inplane(&p, &ti2, &tr2), 0);
            if (ti > 0) {
                assert_close(ti2, ti, 1e-9);
                assert_close(tr2, tr, 1e-9);
            }
            brdf_inplane_to_axes(ti, tr, &s, &a);
            assert_close(s, ti, 1e-15);
            assert_close(a, ti + tr, 1e-15);
            brdf_axes_to_inplane(s, a, &ti3, &tr3);
            assert_close(ti3, ti, 1e-12);
            assert_close(tr3, tr, 1e-12);
        }
    }
    struct brdf_pair q;
    brdf_pair_spherical(30, 0, 30, 90, &q);
    double x, y;
    assert_int_equal(brdf_pair_to_inplane(&q, &x, &y), -1);
}

static void test_blind_zone(void **state)
{
    (void)state;
    double s, a;
    brdf_inplane_to_axes(30, -28, &s, &a);
    assert_true(brdf_axes_in_blind_zone(a, 5));
    brdf_inplane_to_axes(30, -25, &s, &a);
    assert_false(brdf_axes_in_blind_zone(a, 5));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_normal_incidence),
        cmocka_unit_test(test_mirror_is_exact),
        cmocka_unit_test(test_retro_reflection),
        cmocka_unit_test(test_grazing),
        cmocka_unit_test(test_inplane_hd),
        cmocka_unit_test(test_reference_geometries),
        cmocka_unit_test(test_hd_round_trip),
        cmocka_unit_test(test_inplane_round_trip_and_axes),
        cmocka_unit_test(test_blind_zone),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
