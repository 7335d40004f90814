/* Colorimetry: CIE tables against the standard's printed values, the D65
 * white point, the sRGB matrix and transfer function, band layouts. */
#include "brdf/colour.h"
#include "tests/gonio_test.h"

#include <string.h>

/* CIE 15:2004 Table T.4 (CIE 1931 2-degree observer, 380-780 nm every 5 nm,
 * six decimals) as printed, transcribed separately from the 1 nm CIE data
 * set the code embeds; the two agree to the table's rounding. The ends of
 * the embedded range come from the CIE 1 nm data set (CIE 018:2019). */
static void test_cmf_table_values(void **state)
{
    (void)state;
    static const double rows[][4] = {
        {380, 0.001368, 0.000039, 0.006450}, {385, 0.002236, 0.000064, 0.010550},
        {390, 0.004243, 0.000120, 0.020050}, {395, 0.007650, 0.000217, 0.036210},
        {400, 0.014310, 0.000396, 0.067850}, {405, 0.023190, 0.000640, 0.110200},
        {410, 0.043510, 0.001210, 0.207400}, {415, 0.077630, 0.002180, 0.371300},
        {420, 0.134380, 0.004000, 0.645600}, {425, 0.214770, 0.007300, 1.039050},
        {430, 0.283900, 0.011600, 1.385600}, {435, 0.328500, 0.016840, 1.622960},
        {440, 0.348280, 0.023000, 1.747060}, {445, 0.348060, 0.029800, 1.782600},
        {450, 0.336200, 0.038000, 1.772110}, {455, 0.318700, 0.048000, 1.744100},
        {460, 0.290800, 0.060000, 1.669200}, {465, 0.251100, 0.073900, 1.528100},
        {470, 0.195360, 0.090980, 1.287640}, {475, 0.142100, 0.112600, 1.041900},
        {480, 0.095640, 0.139020, 0.812950}, {485, 0.057950, 0.169300, 0.616200},
        {490, 0.032010, 0.208020, 0.465180}, {495, 0.014700, 0.258600, 0.353300},
        {500, 0.004900, 0.323000, 0.272000}, {505, 0.002400, 0.407300, 0.212300},
        {510, 0.009300, 0.503000, 0.158200}, {515, 0.029100, 0.608200, 0.111700},
        {520, 0.063270, 0.710000, 0.078250}, {525, 0.109600, 0.793200, 0.057250},
        {530, 0.165500, 0.862000, 0.042160}, {535, 0.225750, 0.914850, 0.029840},
        {540, 0.290400, 0.954000, 0.020300}, {545, 0.359700, 0.980300, 0.013400},
        {550, 0.433450, 0.994950, 0.008750}, {555, 0.512050, 1.000000, 0.005750},
        {560, 0.594500, 0.995000, 0.003900}, {565, 0.678400, 0.978600, 0.002750},
        {570, 0.762100, 0.952000, 0.002100}, {575, 0.842500, 0.915400, 0.001800},
        {580, 0.916300, 0.870000, 0.001650}, {585, 0.978600, 0.816300, 0.001400},
        {590, 1.026300, 0.757000, 0.001100}, {595, 1.056700, 0.694900, 0.001000},
        {600, 1.062200, 0.631000, 0.000800}, {605, 1.045600, 0.566800, 0.000600},
        {610, 1.002600, 0.503000, 0.000340}, {615, 0.938400, 0.441200, 0.000240},
        {620, 0.854450, 0.381000, 0.000190}, {625, 0.751400, 0.321000, 0.000100},
        {630, 0.642400, 0.265000, 0.000050}, {635, 0.541900, 0.217000, 0.000030},
        {640, 0.447900, 0.175000, 0.000020}, {645, 0.360800, 0.138200, 0.000010},
        {650, 0.283500, 0.107000, 0.000000}, {655, 0.218700, 0.081600, 0.000000},
        {660, 0.164900, 0.061000, 0.000000}, {665, 0.121200, 0.044580, 0.000000},
        {670, 0.087400, 0.032000, 0.000000}, {675, 0.063600, 0.023200, 0.000000},
        {680, 0.046770, 0.017000, 0.000000}, {685, 0.032900, 0.011920, 0.000000},
        {690, 0.022700, 0.008210, 0.000000}, {695, 0.015840, 0.005723, 0.000000},
        {700, 0.011359, 0.004102, 0.000000}, {705, 0.008111, 0.002929, 0.000000},
        {710, 0.005790, 0.002091, 0.000000}, {715, 0.004109, 0.001484, 0.000000},
        {720, 0.002899, 0.001047, 0.000000}, {725, 0.002049, 0.000740, 0.000000},
        {730, 0.001440, 0.000520, 0.000000}, {735, 0.001000, 0.000361, 0.000000},
        {740, 0.000690, 0.000249, 0.000000}, {745, 0.000476, 0.000172, 0.000000},
        {750, 0.000332, 0.000120, 0.000000}, {755, 0.000235, 0.000085, 0.000000},
        {760, 0.000166, 0.000060, 0.000000}, {765, 0.000117, 0.000042, 0.000000},
        {770, 0.000083, 0.000030, 0.000000}, {775, 0.000059, 0.000021, 0.000000},
        {780, 0.000042, 0.000015, 0.000000},
        /* CIE 018:2019 1 nm data set at the ends of the embedded range */
        {360, 1.299e-4, 3.917e-6, 6.061e-4}, {365, 2.321e-4, 6.965e-6, 1.086e-3},
        {370, 4.149e-4, 1.239e-5, 1.946e-3}, {375, 7.416e-4, 2.202e-5, 3.486e-3},
        {785, 2.935326e-5, 1.06e-5, 0}, {790, 2.067383e-5, 7.4657e-6, 0},
        {795, 1.455977e-5, 5.2578e-6, 0}, {800, 1.025398e-5, 3.7029e-6, 0},
        {805, 7.221456e-6, 2.6078e-6, 0}, {810, 5.085868e-6, 1.8366e-6, 0},
        {815, 3.581652e-6, 1.2934e-6, 0}, {820, 2.522525e-6, 9.1093e-7, 0},
        {825, 1.776509e-6, 6.4153e-7, 0}, {830, 1.251141e-6, 4.5181e-7, 0},
    };
    for (size_t r = 0; r < sizeof rows / sizeof rows[0]; r++) {
        double b[3];
        brdf_cie_cmf(rows[r][0], b);
        /* T.4 rows: within its rounding; the 1 nm set's rows: as printed. */
        int t4 = rows[r][0] >= 380 && rows[r][0] <= 780;
        for (int c = 0; c < 3; c++)
            assert_close(b[c], rows[r][1 + c], t4 ? 5.1e-7 : 1e-6 * rows[r][1 + c]);
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

/* CIE 15:2004 Table T.1 (D65) is defined by S0 + M1 S1 + M2 S2 with
 * M1 = -0.295, M2 = -0.689 every 10 nm (S0, S1, S2 from Table T.2, 360-830
 * nm, below) and linear interpolation at the 5 nm points in between. */
static void test_d65_table_values(void **state)
{
    (void)state;
    static const double s012[][3] = {
        {61.50, 38.00, 5.30}, {68.80, 42.40, 6.10}, {63.40, 38.50, 3.00},
        {65.80, 35.00, 1.20}, {94.80, 43.40, -1.10}, {104.80, 46.30, -0.50},
        {105.90, 43.90, -0.70}, {96.80, 37.10, -1.20}, {113.90, 36.70, -2.60},
        {125.60, 35.90, -2.90}, {125.50, 32.60, -2.80}, {121.30, 27.90, -2.60},
        {121.30, 24.30, -2.60}, {113.50, 20.10, -1.80}, {113.10, 16.20, -1.50},
        {110.80, 13.20, -1.30}, {106.50, 8.60, -1.20}, {108.80, 6.10, -1.00},
        {105.30, 4.20, -0.50}, {104.40, 1.90, -0.30}, {100.00, 0.00, 0.00},
        {96.00, -1.60, 0.20}, {95.10, -3.50, 0.50}, {89.10, -3.50, 2.10},
        {90.50, -5.80, 3.20}, {90.30, -7.20, 4.10}, {88.40, -8.60, 4.70},
        {84.00, -9.50, 5.10}, {85.10, -10.90, 6.70}, {81.90, -10.70, 7.30},
        {82.60, -12.00, 8.60}, {84.90, -14.00, 9.80}, {81.30, -13.60, 10.20},
        {71.90, -12.00, 8.30}, {74.30, -13.30, 9.60}, {76.40, -12.90, 8.50},
        {63.30, -10.60, 7.00}, {71.70, -11.60, 7.60}, {77.00, -12.20, 8.00},
        {65.20, -10.20, 6.70}, {47.70, -7.80, 5.20}, {68.60, -11.20, 7.40},
        {65.00, -10.40, 6.80}, {66.00, -10.60, 7.00}, {61.00, -9.70, 6.40},
        {53.30, -8.30, 5.50}, {58.90, -9.30, 6.10}, {61.90, -9.80, 6.50},
    };
    for (int i = 0; i < 48; i++) {
        double l = 360 + 10 * i;
        double d = s012[i][0] - 0.295 * s012[i][1] - 0.689 * s012[i][2];
        assert_close(brdf_cie_d65(l), d, 1e-4 * d);
        if (i > 0)
            assert_close(brdf_cie_d65(l - 5), 0.5 * (brdf_cie_d65(l - 10) + brdf_cie_d65(l)),
                         1e-4 * d);
    }
    assert_close(brdf_cie_d65(560), 100.0, 0);
    assert_close(brdf_cie_d65(380), 49.9755, 1e-12);
    assert_close(brdf_cie_d65(830), 60.3125, 1e-12);
    assert_true(brdf_cie_d65(355) == 0 && brdf_cie_d65(835) == 0);
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

/* DESIGN.md's matrix, applied by hand to two colours. */
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

/* A ramp on 31 bands 400-700 nm is held at its end values outside them. */
static void test_ramp_held_at_ends(void **state)
{
    (void)state;
    double lam[31], r[31], xyz[3];
    for (int k = 0; k < 31; k++) {
        lam[k] = 400 + 10 * k;
        r[k] = k / 30.0;
    }
    assert_int_equal(brdf_colour_spectrum_to_xyz(lam, r, 31, xyz, NULL), 0);
    double num[3] = {0, 0, 0}, den = 0;
    for (int l = 360; l <= 830; l += 5) {
        double b[3], s = brdf_cie_d65(l);
        double refl = l < 400 ? 0 : l > 700 ? 1 : (l - 400) / 300.0;
        brdf_cie_cmf(l, b);
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
        cmocka_unit_test(test_ramp_held_at_ends),
        cmocka_unit_test(test_bad_layouts),
        cmocka_unit_test(test_srgb_encoding),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
