#include "brdf/colour.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

/* CIE 1931 standard colorimetric observer (2 degree), x-bar, y-bar, z-bar,
 * 360-830 nm every 5 nm. Source: CIE 018:2019 "Colour-matching functions of
 * CIE 1931 standard colorimetric observer" (CIE_xyz_1931_2deg.csv, DOI
 * 10.25039/CIE.DS.xvudnb9b), the 1 nm table of CIE 15:2004 / ISO 11664-1,
 * taken at every fifth nanometre. Between 380 and 780 nm these agree with the
 * abridged 5 nm table T.4 of CIE 15:2004 to its six decimals. */
static const double cie_cmf[BRDF_CIE_COUNT][3] = {
    {0.0001299, 0.000003917, 0.0006061},      /* 360 */
    {0.0002321, 0.000006965, 0.001086},       /* 365 */
    {0.0004149, 0.00001239, 0.001946},        /* 370 */
    {0.0007416, 0.00002202, 0.003486},        /* 375 */
    {0.001368, 0.000039, 0.006450001},        /* 380 */
    {0.002236, 0.000064, 0.01054999},         /* 385 */
    {0.004243, 0.00012, 0.02005001},          /* 390 */
    {0.00765, 0.000217, 0.03621},             /* 395 */
    {0.01431, 0.000396, 0.06785001},          /* 400 */
    {0.02319, 0.00064, 0.1102},               /* 405 */
    {0.04351, 0.00121, 0.2074},               /* 410 */
    {0.07763, 0.00218, 0.3713},               /* 415 */
    {0.13438, 0.004, 0.6456},                 /* 420 */
    {0.21477, 0.0073, 1.0390501},             /* 425 */
    {0.2839, 0.0116, 1.3856},                 /* 430 */
    {0.3285, 0.01684, 1.62296},               /* 435 */
    {0.34828, 0.023, 1.74706},                /* 440 */
    {0.34806, 0.0298, 1.7826},                /* 445 */
    {0.3362, 0.038, 1.77211},                 /* 450 */
    {0.3187, 0.048, 1.7441},                  /* 455 */
    {0.2908, 0.06, 1.6692},                   /* 460 */
    {0.2511, 0.0739, 1.5281},                 /* 465 */
    {0.19536, 0.09098, 1.28764},              /* 470 */
    {0.1421, 0.1126, 1.0419},                 /* 475 */
    {0.09564, 0.13902, 0.8129501},            /* 480 */
    {0.05795001, 0.1693, 0.6162},             /* 485 */
    {0.03201, 0.20802, 0.46518},              /* 490 */
    {0.0147, 0.2586, 0.3533},                 /* 495 */
    {0.0049, 0.323, 0.272},                   /* 500 */
    {0.0024, 0.4073, 0.2123},                 /* 505 */
    {0.0093, 0.503, 0.1582},                  /* 510 */
    {0.0291, 0.6082, 0.1117},                 /* 515 */
    {0.06327, 0.71, 0.07824999},              /* 520 */
    {0.1096, 0.7932, 0.05725001},             /* 525 */
    {0.1655, 0.862, 0.04216},                 /* 530 */
    {0.2257499, 0.9148501, 0.02984},          /* 535 */
    {0.2904, 0.954, 0.0203},                  /* 540 */
    {0.3597, 0.9803, 0.0134},                 /* 545 */
    {0.4334499, 0.9949501, 0.008749999},      /* 550 */
    {0.5120501, 1.0, 0.005749999},            /* 555 */
    {0.5945, 0.995, 0.0039},                  /* 560 */
    {0.6784, 0.9786, 0.002749999},            /* 565 */
    {0.7621, 0.952, 0.0021},                  /* 570 */
    {0.8425, 0.9154, 0.0018},                 /* 575 */
    {0.9163, 0.87, 0.001650001},              /* 580 */
    {0.9786, 0.8163, 0.0014},                 /* 585 */
    {1.0263, 0.757, 0.0011},                  /* 590 */
    {1.0567, 0.6949, 0.001},                  /* 595 */
    {1.0622, 0.631, 0.0008},                  /* 600 */
    {1.0456, 0.5668, 0.0006},                 /* 605 */
    {1.0026, 0.503, 0.00034},                 /* 610 */
    {0.9384, 0.4412, 0.00024},                /* 615 */
    {0.8544499, 0.381, 0.00019},              /* 620 */
    {0.7514, 0.321, 0.0001},                  /* 625 */
    {0.6424, 0.265, 0.00004999999},           /* 630 */
    {0.5419, 0.217, 0.00003},                 /* 635 */
    {0.4479, 0.175, 0.00002},                 /* 640 */
    {0.3608, 0.1382, 0.00001},                /* 645 */
    {0.2835, 0.107, 0.0},                     /* 650 */
    {0.2187, 0.0816, 0.0},                    /* 655 */
    {0.1649, 0.061, 0.0},                     /* 660 */
    {0.1212, 0.04458, 0.0},                   /* 665 */
    {0.0874, 0.032, 0.0},                     /* 670 */
    {0.0636, 0.0232, 0.0},                    /* 675 */
    {0.04677, 0.017, 0.0},                    /* 680 */
    {0.0329, 0.01192, 0.0},                   /* 685 */
    {0.0227, 0.00821, 0.0},                   /* 690 */
    {0.01584, 0.005723, 0.0},                 /* 695 */
    {0.01135916, 0.004102, 0.0},              /* 700 */
    {0.008110916, 0.002929, 0.0},             /* 705 */
    {0.005790346, 0.002091, 0.0},             /* 710 */
    {0.004109457, 0.001484, 0.0},             /* 715 */
    {0.002899327, 0.001047, 0.0},             /* 720 */
    {0.00204919, 0.00074, 0.0},               /* 725 */
    {0.001439971, 0.00052, 0.0},              /* 730 */
    {0.0009999493, 0.0003611, 0.0},           /* 735 */
    {0.0006900786, 0.0002492, 0.0},           /* 740 */
    {0.0004760213, 0.0001719, 0.0},           /* 745 */
    {0.0003323011, 0.00012, 0.0},             /* 750 */
    {0.0002348261, 0.0000848, 0.0},           /* 755 */
    {0.0001661505, 0.00006, 0.0},             /* 760 */
    {0.000117413, 0.0000424, 0.0},            /* 765 */
    {0.00008307527, 0.00003, 0.0},            /* 770 */
    {0.00005870652, 0.0000212, 0.0},          /* 775 */
    {0.00004150994, 0.00001499, 0.0},         /* 780 */
    {0.00002935326, 0.0000106, 0.0},          /* 785 */
    {0.00002067383, 0.0000074657, 0.0},       /* 790 */
    {0.00001455977, 0.0000052578, 0.0},       /* 795 */
    {0.00001025398, 0.0000037029, 0.0},       /* 800 */
    {0.000007221456, 0.0000026078, 0.0},      /* 805 */
    {0.000005085868, 0.0000018366, 0.0},      /* 810 */
    {0.000003581652, 0.0000012934, 0.0},      /* 815 */
    {0.000002522525, 0.00000091093, 0.0},     /* 820 */
    {0.000001776509, 0.00000064153, 0.0},     /* 825 */
    {0.000001251141, 0.00000045181, 0.0},     /* 830 */
};

/* CIE standard illuminant D65, relative spectral power, 360-830 nm every
 * 5 nm. Source: CIE 15:2004 Table T.1 / ISO 11664-2 (CIE S 014-2), the
 * CIE's "Relative spectral power distributions of CIE standard illuminants
 * A, D65" table. */
static const double cie_d65[BRDF_CIE_COUNT] = {
    46.6383, 49.3637, 52.0891, 51.0323, 49.9755, /* 360-380 */
    52.3118, 54.6482, 68.7015, 82.7549, 87.1204, /* 385-405 */
    91.4860, 92.4589, 93.4318, 90.0570, 86.6823, /* 410-430 */
    95.7736, 104.865, 110.936, 117.008, 117.410, /* 435-455 */
    117.812, 116.336, 114.861, 115.392, 115.923, /* 460-480 */
    112.367, 108.811, 109.082, 109.354, 108.578, /* 485-505 */
    107.802, 106.296, 104.790, 106.239, 107.689, /* 510-530 */
    106.047, 104.405, 104.225, 104.046, 102.023, /* 535-555 */
    100.000, 98.1671, 96.3342, 96.0611, 95.7880, /* 560-580 */
    92.2368, 88.6856, 89.3459, 90.0062, 89.8026, /* 585-605 */
    89.5991, 88.6489, 87.6987, 85.4936, 83.2886, /* 610-630 */
    83.4939, 83.6992, 81.8630, 80.0268, 80.1207, /* 635-655 */
    80.2146, 81.2462, 82.2778, 80.2810, 78.2842, /* 660-680 */
    74.0027, 69.7213, 70.6652, 71.6091, 72.9790, /* 685-705 */
    74.3490, 67.9765, 61.6040, 65.7448, 69.8856, /* 710-730 */
    72.4863, 75.0870, 69.3398, 63.5927, 55.0054, /* 735-755 */
    46.4182, 56.6118, 66.8054, 65.0941, 63.3828, /* 760-780 */
    63.8434, 64.3040, 61.8779, 59.4519, 55.7054, /* 785-805 */
    51.9590, 54.6998, 57.4406, 58.8765, 60.3125, /* 810-830 */
};

/* Table position of lambda: index j and fraction t in [0, 1), or -1 outside. */
static int table_pos(double lambda_nm, double *t)
{
    double u = (lambda_nm - BRDF_CIE_FIRST_NM) / BRDF_CIE_STEP_NM;
    if (!(u >= 0) || u > BRDF_CIE_COUNT - 1)
        return -1;
    int j = (int)u;
    if (j >= BRDF_CIE_COUNT - 1) {
        *t = 0;
        return BRDF_CIE_COUNT - 1;
    }
    *t = u - j;
    return j;
}

void brdf_cie_cmf(double lambda_nm, double xyz_bar[3])
{
    double t;
    int j = table_pos(lambda_nm, &t);
    for (int c = 0; c < 3; c++) {
        if (j < 0)
            xyz_bar[c] = 0;
        else if (t == 0)
            xyz_bar[c] = cie_cmf[j][c];
        else
            xyz_bar[c] = (1 - t) * cie_cmf[j][c] + t * cie_cmf[j + 1][c];
    }
}

double brdf_cie_d65(double lambda_nm)
{
    double t;
    int j = table_pos(lambda_nm, &t);
    if (j < 0)
        return 0;
    return t == 0 ? cie_d65[j] : (1 - t) * cie_d65[j] + t * cie_d65[j + 1];
}

int brdf_colour_weights(const double *lambda_nm, size_t n, double *w, struct gonio_err *err)
{
    if (n == 0)
        return gonio_err_set(err, GONIO_EBADDATA, "spectrum: no bands");
    for (size_t k = 0; k < n; k++) {
        if (!isfinite(lambda_nm[k]))
            return gonio_err_set(err, GONIO_EBADDATA,
                                 "spectrum: band %zu: wavelength %g is not finite", k,
                                 lambda_nm[k]);
        if (k > 0 && !(lambda_nm[k] > lambda_nm[k - 1]))
            return gonio_err_set(err, GONIO_EBADDATA,
                                 "spectrum: band %zu: wavelength %g nm not above %g nm",
                                 k, lambda_nm[k], lambda_nm[k - 1]);
    }
    for (size_t i = 0; i < 3 * n; i++)
        w[i] = 0;

    /* Rectangle rule on the 5 nm nodes; the step cancels in the ratio. */
    double norm = 0;
    size_t k = 0; /* band interval [k, k+1] holding the current node */
    for (int j = 0; j < BRDF_CIE_COUNT; j++) {
        double lam = BRDF_CIE_FIRST_NM + BRDF_CIE_STEP_NM * (double)j;
        double s = cie_d65[j];
        norm += s * cie_cmf[j][1];
        size_t k0, k1;
        double a1; /* weight of band k1; band k0 gets 1 - a1 */
        if (lam <= lambda_nm[0]) {
            k0 = k1 = 0;
            a1 = 0;
        } else if (lam >= lambda_nm[n - 1]) {
            k0 = k1 = n - 1;
            a1 = 0;
        } else {
            while (lambda_nm[k + 1] < lam)
                k++;
            k0 = k;
            k1 = k + 1;
            a1 = (lam - lambda_nm[k0]) / (lambda_nm[k1] - lambda_nm[k0]);
        }
        for (int c = 0; c < 3; c++) {
            w[3 * k0 + c] += (1 - a1) * s * cie_cmf[j][c];
            w[3 * k1 + c] += a1 * s * cie_cmf[j][c];
        }
    }
    for (size_t i = 0; i < 3 * n; i++)
        w[i] /= norm;
    return 0;
}

int brdf_colour_spectrum_to_xyz(const double *lambda_nm, const double *refl, size_t n,
                                double xyz[3], struct gonio_err *err)
{
    double stackw[3 * 64];
    double *w = n <= 64 ? stackw : malloc(3 * n * sizeof *w);
    if (!w)
        return gonio_err_set(err, ENOMEM, "spectrum: out of memory for %zu bands", n);
    int rc = brdf_colour_weights(lambda_nm, n, w, err);
    if (rc == 0) {
        xyz[0] = xyz[1] = xyz[2] = 0;
        for (size_t k = 0; k < n; k++)
            for (int c = 0; c < 3; c++)
                xyz[c] += w[3 * k + c] * refl[k];
    }
    if (w != stackw)
        free(w);
    return rc;
}

/* Design brief section 6 (IEC 61966-2-1 primaries, D65 white). */
static const double xyz_to_srgb[3][3] = {
    {3.2404542, -1.5371385, -0.4985314},
    {-0.9692660, 1.8760108, 0.0415560},
    {0.0556434, -0.2040259, 1.0572252},
};

void brdf_colour_xyz_to_srgb_linear(const double xyz[3], double rgb[3])
{
    double out[3];
    for (int r = 0; r < 3; r++)
        out[r] = xyz_to_srgb[r][0] * xyz[0] + xyz_to_srgb[r][1] * xyz[1] +
                 xyz_to_srgb[r][2] * xyz[2];
    for (int r = 0; r < 3; r++)
        rgb[r] = out[r];
}

int brdf_colour_xyz_to_xy(const double xyz[3], double xy[2])
{
    double s = xyz[0] + xyz[1] + xyz[2];
    if (!isfinite(s) || s == 0) {
        xy[0] = xy[1] = NAN;
        return -1;
    }
    xy[0] = xyz[0] / s;
    xy[1] = xyz[1] / s;
    return 0;
}

double brdf_colour_srgb_encode(double linear)
{
    if (!(linear > 0))
        return 0; /* also NAN */
    if (linear >= 1)
        return 1;
    if (linear <= 0.0031308)
        return 12.92 * linear;
    return 1.055 * pow(linear, 1 / 2.4) - 0.055;
}

uint8_t brdf_colour_srgb8(double linear)
{
    return (uint8_t)lround(255.0 * brdf_colour_srgb_encode(linear));
}
