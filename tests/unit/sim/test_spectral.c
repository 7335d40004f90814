/* Spectral materials against closed forms: Fresnel of a complex index at
 * normal incidence and at Brewster's angle, the quarter-wave film, gold from
 * its own table (read here independently), the RGB lift's round trip, and
 * the colours the inks and the goniochromatic film must have. */
#include <string.h>

#include "brdf/colour.h"
#include "brdf/spectral.h"
#include "tests/gonio_test.h"

static double normal_fresnel(double n, double k)
{
    return ((n - 1) * (n - 1) + k * k) / ((n + 1) * (n + 1) + k * k);
}

static void test_fresnel_closed_forms(void **state)
{
    (void)state;
    assert_close(brdf_fresnel_complex(1.5, 0, 1), 0.04, 1e-15);
    assert_close(brdf_fresnel_complex(0.2, 3.4, 1), normal_fresnel(0.2, 3.4), 1e-15);
    assert_close(brdf_fresnel_complex(0.2, 3.4, 0), 1, 1e-12); /* grazing */
    /* Brewster, n = 1.5: p vanishes, F = Rs / 2 with Rs from Snell's law */
    double tb = atan(1.5), ci = cos(tb), st = sin(tb) / 1.5, ct = sqrt(1 - st * st);
    double rs = (ci - 1.5 * ct) / (ci + 1.5 * ct);
    assert_close(brdf_fresnel_complex(1.5, 0, ci), 0.5 * rs * rs, 1e-14);
}

static void test_thin_film_closed_forms(void **state)
{
    (void)state;
    /* quarter wave at normal incidence: ((n2 - n1^2) / (n2 + n1^2))^2 */
    double n1 = 1.8, n2 = 1.5, lambda = 4 * n1 * 100.0; /* d = 100 nm */
    double r = (n2 - n1 * n1) / (n2 + n1 * n1);
    assert_close(brdf_thin_film_reflectance(n1, 100, n2, 0, lambda, 1), r * r, 1e-14);
    /* half wave: the film is absent */
    assert_close(brdf_thin_film_reflectance(n1, 100, n2, 0, 2 * n1 * 100.0, 1),
                 normal_fresnel(n2, 0), 1e-14);
    /* no film on an absorbing substrate */
    assert_close(brdf_thin_film_reflectance(n1, 0, 1.5, 0.5, 550, 1), normal_fresnel(1.5, 0.5),
                 1e-14);
}

/* gold_nk.csv read here, not by the library. */
static int read_gold(double *lambda, double *n, double *k)
{
    const char *shared = gonio_test_shared_or_skip();
    char path[1024];
    snprintf(path, sizeof path, "%s/data/spectral/gold_nk.csv", shared);
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    char line[256];
    int m = 0;
    while (fgets(line, sizeof line, f))
        if (sscanf(line, "%lf,%lf,%lf", &lambda[m], &n[m], &k[m]) == 3)
            m++;
    fclose(f);
    return m;
}

static void test_gold_from_its_table(void **state)
{
    (void)state;
    double lambda[64], n[64], k[64];
    int m = read_gold(lambda, n, k);
    assert_int_equal(m, 35);
    struct gonio_err err = {0};
    brdf_spectral *gold = brdf_spectral_open("spectral:gold", &err);
    assert_non_null(gold);
    double lo, hi;
    brdf_spectral_range(gold, &lo, &hi);
    assert_close(lo, 390, 0);
    assert_close(hi, 730, 0);
    /* at the mirror direction of normal incidence the lobe is common to all
     * wavelengths: ratios of the BRDF are ratios of the normal Fresnel */
    struct brdf_pair p;
    brdf_pair_inplane(0, 0, &p);
    double f[64];
    brdf_spectral_eval(gold, &p, lambda, (size_t)m, f);
    for (int i = 0; i < m; i++)
        assert_rel_close(f[i] / f[0], normal_fresnel(n[i], k[i]) / normal_fresnel(n[0], k[0]),
                         1e-12);
    /* between rows: linear in n and k */
    double mid = 555, fm;
    brdf_spectral_eval(gold, &p, &mid, 1, &fm);
    double nm = 0.5 * (n[16] + n[17]), km = 0.5 * (k[16] + k[17]);
    assert_close(lambda[16], 550, 0);
    assert_rel_close(fm / f[0], normal_fresnel(nm, km) / normal_fresnel(n[0], k[0]), 1e-12);
    brdf_spectral_free(gold);

    /* gold looks gold: red > green > blue at the specular peak */
    brdf_material *rgb = brdf_material_open("spectral:gold", &err);
    assert_non_null(rgb);
    double c[3];
    brdf_pair_inplane(30, 30, &p);
    brdf_material_eval(rgb, &p, 1, c);
    assert_true(c[0] > c[1] && c[1] > c[2] && c[2] > 0);
    brdf_material_free(rgb);
}

static void test_lift_round_trip(void **state)
{
    (void)state;
    double lambda[BRDF_CIE_COUNT], w[3 * BRDF_CIE_COUNT], s[BRDF_CIE_COUNT];
    for (int k = 0; k < BRDF_CIE_COUNT; k++)
        lambda[k] = BRDF_CIE_FIRST_NM + BRDF_CIE_STEP_NM * k;
    assert_int_equal(brdf_spectral_rgb_weights(lambda, BRDF_CIE_COUNT, w, NULL), 0);
    const double colours[][3] = {{0.2, 0.5, 0.8}, {0.9, 0.1, 0.05}, {0.3, 0.3, 0.3}};
    for (int i = 0; i < 3; i++) {
        brdf_spectral_from_rgb(colours[i], lambda, BRDF_CIE_COUNT, s);
        for (int c = 0; c < 3; c++) {
            double sum = 0;
            for (int k = 0; k < BRDF_CIE_COUNT; k++)
                sum += w[3 * k + c] * s[k];
            assert_close(sum, colours[i][c], 1e-12);
        }
    }
    /* grey lifts to a nearly flat spectrum (the matrix's white is D65 to
     * about 1e-4), and the bases are a partition of unity */
    for (int k = 0; k < BRDF_CIE_COUNT; k++) {
        assert_close(s[k], 0.3, 0.3 * 0.01);
        double b[3];
        brdf_spectral_basis(lambda[k], b);
        assert_close(b[0] + b[1] + b[2], 1, 1e-15);
        assert_true(b[0] >= 0 && b[1] >= 0 && b[2] >= 0);
    }
    /* a lifted material in the 31-band layout keeps its colour to 1% */
    brdf_material *m = brdf_material_open("default", NULL);
    brdf_spectral *lift = brdf_spectral_lift(m, NULL);
    double l31[31], w31[93], s31[31], rgb[3];
    for (int k = 0; k < 31; k++)
        l31[k] = 400 + 10 * k;
    assert_int_equal(brdf_spectral_rgb_weights(l31, 31, w31, NULL), 0);
    struct brdf_pair p;
    brdf_pair_inplane(20, 40, &p);
    brdf_material_eval(m, &p, 1, rgb);
    brdf_spectral_eval(lift, &p, l31, 31, s31);
    for (int c = 0; c < 3; c++) {
        double sum = 0;
        for (int k = 0; k < 31; k++)
            sum += w31[3 * k + c] * s31[k];
        assert_rel_close(sum, rgb[c], 0.01);
    }
    brdf_spectral_free(lift);
    brdf_material_free(m);
}

static void test_inks_and_gonio_colours(void **state)
{
    (void)state;
    struct brdf_pair p;
    brdf_pair_inplane(45, 0, &p); /* off specular: the ink body */
    double cy[3], ma[3];
    brdf_material *cyan = brdf_material_open("spectral:cyan", NULL);
    brdf_material *magenta = brdf_material_open("spectral:magenta", NULL);
    assert_non_null(cyan);
    assert_non_null(magenta);
    brdf_material_eval(cyan, &p, 1, cy);
    brdf_material_eval(magenta, &p, 1, ma);
    assert_true(cy[0] < 0.5 * cy[1] && cy[0] < 0.5 * cy[2]);
    assert_true(ma[1] < 0.5 * ma[0] && ma[1] < 0.5 * ma[2]);
    brdf_material_free(cyan);
    brdf_material_free(magenta);

    /* the film's specular colour moves with angle, its interference peak
     * to shorter wavelengths as theta grows (lambda ~ cos theta_t) */
    brdf_spectral *g = brdf_spectral_open("spectral:gonio", NULL);
    assert_non_null(g);
    double lambda[81], s[81];
    for (int k = 0; k < 81; k++)
        lambda[k] = 380 + 5 * k;
    double xy_prev[2] = {0, 0}, peak_prev = 1e9;
    const double angles[] = {5, 35, 60};
    for (int a = 0; a < 3; a++) {
        brdf_pair_inplane(angles[a], angles[a], &p);
        brdf_spectral_eval(g, &p, lambda, 81, s);
        double xyz[3], xy[2];
        assert_int_equal(brdf_colour_spectrum_to_xyz(lambda, s, 81, xyz, NULL), 0);
        assert_int_equal(brdf_colour_xyz_to_xy(xyz, xy), 0);
        /* follow one interference order: the local maximum nearest the
         * previous angle's (at first, the one nearest 550 nm) */
        double peak = 0, ref = a ? peak_prev : 550;
        for (int k = 1; k < 80; k++)
            if (s[k] > s[k - 1] && s[k] >= s[k + 1] && fabs(lambda[k] - ref) < fabs(peak - ref))
                peak = lambda[k];
        assert_true(peak > 0);
        if (a > 0) {
            assert_true(hypot(xy[0] - xy_prev[0], xy[1] - xy_prev[1]) > 0.02);
            assert_true(peak < peak_prev);
        }
        memcpy(xy_prev, xy, sizeof xy);
        peak_prev = peak;
    }
    brdf_spectral_free(g);
}

static void test_unknown_spectral_material(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    assert_null(brdf_spectral_open("spectral:unobtainium", &err));
    assert_int_equal(err.code, GONIO_ENOTFOUND);
    assert_non_null(strstr(err.msg, "unobtainium"));
    assert_null(brdf_material_open("spectral:unobtainium", &err));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fresnel_closed_forms),
        cmocka_unit_test(test_thin_film_closed_forms),
        cmocka_unit_test(test_gold_from_its_table),
        cmocka_unit_test(test_lift_round_trip),
        cmocka_unit_test(test_inks_and_gonio_colours),
        cmocka_unit_test(test_unknown_spectral_material),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
