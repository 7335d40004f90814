/* Colorimetry: CIE tables against the standard's printed values, the D65
 * white point, the sRGB matrix and transfer function, band layouts. */
#include "brdf/colour.h"
#include "tests/gonio_test.h"

#include <string.h>

/* CIE 15:2004 Table T.4 (CIE 1931 2-degree observer) rows, as printed. */
static void test_cmf_table_values(void **state)
{
    (void)state;
    static const double rows[][4] = {
        {380, 0.001368, 0.000039, 0.006450}, {445, 0.348060, 0.029800, 1.782600},
        {500, 0.004900, 0.323000, 0.272000}, {555, 0.512050, 1.000000, 0.005750},
        {600, 1.062200, 0.631000, 0.000800}, {700, 0.011359, 0.004102, 0.000000},
        {780, 0.000042, 0.000015, 0.000000},
    };
    for (size_t r = 0; r < sizeof rows / sizeof rows[0]; r++) {
        double b[3];
        brdf_cie_cmf(rows[r][0], b);
        for (int c = 0; c < 3; c++)
            assert_close(b[c], rows[r][1 + c], 5.1e-7);
    }
    /* Between nodes: linear; outside the table: no response. */
    double a[3], b[3], m[3];
    brdf_cie_cmf(550, a);
    brdf_cie_cmf(555, b);
    brdf_cie_cmf(552.5, m);
    for (int c = 0; c < 3; c++)
        assert_close(m[c], 0.5 * (a[c] + b[c]), 1e-15);
    brdf_cie_cmf(300, m);
    assert_true(m[0] == 0 && m[1] == 0 && m[2] == 0);
}

/* CIE 15:2004 Table T.1 (D65), and its defining formula S0 + M1 S1 + M2 S2
 * with M1 = -0.295, M2 = -0.689 at 10 nm (S values from Table T.2). */
static void test_d65_table_values(void **state)
{
    (void)state;
    assert_close(brdf_cie_d65(560), 100.0, 0);
    assert_close(brdf_cie_d65(380), 49.9755, 1e-12);
    assert_close(brdf_cie_d65(830), 60.3125, 1e-12);
    assert_close(brdf_cie_d65(460), 125.50 - 0.295 * 32.60 - 0.689 * -2.80, 1e-3);
    assert_close(brdf_cie_d65(600), 90.50 - 0.295 * -5.80 - 0.689 * 3.20, 1e-3);
    assert_close(brdf_cie_d65(700), 74.30 - 0.295 * -13.30 - 0.689 * 9.60, 1e-3);
}

static size_t layout(double first, double step, size_t n, double *lam)
{
    for (size_t k = 0; k < n; k++)
        lam[k] = first + step * (double)k;
    return n;
}

/* A perfect white reflector under D65 is the D65 white point, Y = 1. */
static void test_white_is_d65(void **state)
{
    (void)state;
    double lam[95], one[95], xyz[3], xy[2], rgb[3];
    for (int k = 0; k < 95; k++)
        one[k] = 1;
    size_t layouts[][3] = {{400, 10, 31}, {390, 10, 35}, {360, 5, 95}};
    for (size_t l = 0; l < 3; l++) {
        size_t n = layout((double)layouts[l][0], (double)layouts[l][1], layouts[l][2], lam);
        assert_int_equal(brdf_colour_spectrum_to_xyz(lam, one, n, xyz, NULL), 0);
        assert_close(xyz[1], 1.0, 1e-12);
        assert_int_equal(brdf_colour_xyz_to_xy(xyz, xy), 0);
        assert_close(xy[0], 0.3127, 1e-4);
        assert_close(xy[1], 0.3290, 1e-4);
        brdf_colour_xyz_to_srgb_linear(xyz, rgb);
        for (int c = 0; c < 3; c++)
            assert_close(rgb[c], 1.0, 1e-2);
    }
}

/* The brief's matrix, applied by hand to two colours. */
static void test_srgb_matrix(void **state)
{
    (void)state;
    const double xyz[3] = {0.25, 0.5, 0.75};
    double rgb[3];
    brdf_colour_xyz_to_srgb_linear(xyz, rgb);
    assert_close(rgb[0], 3.2404542 * 0.25 - 1.5371385 * 0.5 - 0.4985314 * 0.75, 1e-14);
    assert_close(rgb[1], -0.9692660 * 0.25 + 1.8760108 * 0.5 + 0.0415560 * 0.75, 1e-14);
    assert_close(rgb[2], 0.0556434 * 0.25 - 0.2040259 * 0.5 + 1.0572252 * 0.75, 1e-14);
    /* sRGB red primary (x, y) = (0.64, 0.33) at Y = 0.2126 is pure red. */
    const double red[3] = {0.64 / 0.33 * 0.2126, 0.2126, (1 - 0.64 - 0.33) / 0.33 * 0.2126};
    brdf_colour_xyz_to_srgb_linear(red, rgb);
    assert_close(rgb[0], 1.0, 1e-3);
    assert_close(rgb[1], 0.0, 1e-3);
    assert_close(rgb[2], 0.0, 1e-3);
}

/* A smooth spectrum gives nearly the same colour from 31 bands 400-700 nm and
 * 35 bands 390-730 nm; a linear reflectance scales XYZ linearly. */
static void test_band_layouts_agree(void **state)
{
    (void)state;
    double l31[31], l35[35], r31[31], r35[35], a[3], b[3];
    layout(400, 10, 31, l31);
    layout(390, 10, 35, l35);
    for (int k = 0; k < 35; k++) {
        double x = (l35[k] - 550) / 100;
        r35[k] = 0.4 + 0.3 * exp(-x * x);
        if (k < 31) {
            x = (l31[k] - 550) / 100;
            r31[k] = 0.4 + 0.3 * exp(-x * x);
        }
    }
    assert_int_equal(brdf_colour_spectrum_to_xyz(l31, r31, 31, a, NULL), 0);
    assert_int_equal(brdf_colour_spectrum_to_xyz(l35, r35, 35, b, NULL), 0);
    for (int c = 0; c < 3; c++)
        assert_rel_close(a[c], b[c], 5e-3);
    /* Half reflectance everywhere: half the white. */
    for (int k = 0; k < 31; k++)
        r31[k] = 0.5;
    assert_int_equal(brdf_colour_spectrum_to_xyz(l31, r31, 31, a, NULL), 0);
    assert_close(a[1], 0.5, 1e-12);
}

/* A reflectance that is 1 only in 540-560 nm: Y by the plain sum over the
 * table nodes, computed here from brdf_cie_* with the test's own loop. */
static void test_narrow_band_against_direct_sum(void **state)
{
    (void)state;
    double lam[5] = {400, 530, 540, 560, 570}, r[5] = {0, 0, 1, 1, 0}, xyz[3];
    assert_int_equal(brdf_colour_spectrum_to_xyz(lam, r, 5, xyz, NULL), 0);
    double num[3] = {0, 0, 0}, den = 0;
    for (int l = 360; l <= 830; l += 5) {
        double b[3], s = brdf_cie_d65(l), refl;
        brdf_cie_cmf(l, b);
        if (l <= 530 || l >= 570)
            refl = 0;
        else if (l < 540)
            refl = (l - 530) / 10.0;
        else if (l <= 560)
            refl = 1;
        else
            refl = (570 - l) / 10.0;
        for (int c = 0; c < 3; c++)
            num[c] += s * b[c] * refl;
        den += s * b[1];
    }
    for (int c = 0; c < 3; c++)
        assert_close(xyz[c], num[c] / den, 1e-14);
}

static void test_bad_layouts(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    double lam[3] = {400, 400, 410}, r[3] = {1, 1, 1}, xyz[3];
    assert_int_equal(brdf_colour_spectrum_to_xyz(lam, r, 3, xyz, &err), -GONIO_EBADDATA);
    assert_non_null(strstr(err.msg, "band 1"));
    assert_int_equal(brdf_colour_spectrum_to_xyz(lam, r, 0, xyz, &err), -GONIO_EBADDATA);
    lam[1] = NAN;
    assert_int_equal(brdf_colour_spectrum_to_xyz(lam, r, 3, xyz, NULL), -GONIO_EBADDATA);
    double zero[3] = {0, 0, 0}, xy[2];
    assert_int_equal(brdf_colour_xyz_to_xy(zero, xy), -1);
    assert_true(isnan(xy[0]) && isnan(xy[1]));
}

/* IEC 61966-2-1: linear segment below 0.0031308, power law above. */
static void test_srgb_encoding(void **state)
{
    (void)state;
    assert_int_equal(brdf_colour_srgb8(0.0), 0);
    assert_int_equal(brdf_colour_srgb8(1.0), 255);
    assert_int_equal(brdf_colour_srgb8(2.0), 255);
    assert_int_equal(brdf_colour_srgb8(-1.0), 0);
    assert_int_equal(brdf_colour_srgb8(NAN), 0);
    assert_int_equal(brdf_colour_srgb8(0.18), 118); /* the classic mid grey */
    assert_int_equal(brdf_colour_srgb8(0.5), 188);  /* 1.055*0.5^(1/2.4)-0.055 = 0.7354 */
    assert_close(brdf_colour_srgb_encode(0.002), 12.92 * 0.002, 1e-15);
    /* The two segments meet at the joint. */
    assert_close(brdf_colour_srgb_encode(0.0031308), 1.055 * pow(0.0031308, 1 / 2.4) - 0.055, 1e-6);
    assert_close(brdf_colour_srgb_encode(0.5), 1.055 * pow(0.5, 1 / 2.4) - 0.055, 1e-15);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cmf_table_values),
        cmocka_unit_test(test_d65_table_values),
        cmocka_unit_test(test_white_is_d65),
        cmocka_unit_test(test_srgb_matrix),
        cmocka_unit_test(test_band_layouts_agree),
        cmocka_unit_test(test_narrow_band_against_direct_sum),
        cmocka_unit_test(test_bad_layouts),
        cmocka_unit_test(test_srgb_encoding),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
