/* The embedded materials: published shifted-gamma (SGD) fits of a few MERL
 * materials, so that `default` and `builtin:NAME` work without the shared
 * data folder (`make demo` on a fresh checkout).
 *
 * Parameters: M. M. Bagher, C. Soler, N. Holzschuch, "Accurate fitting of
 * measured reflectances using a Shifted Gamma micro-facet distribution",
 * Computer Graphics Forum 31(4), 2012, fitted to the MERL BRDF database
 * (W. Matusik, H. Pfister, M. Brand, L. McMillan, "A Data-Driven Reflectance
 * Model", ACM TOG 22(3), 2003; CC-BY-SA-4.0). Figures copied from
 * <shared>/data/merl/fits/sgd_bagher2012_merl.csv (itself from the
 * public-domain dj_brdf.h of J. Dupuy, commit 94cb16a4); a test checks they
 * still equal that table.
 *
 * The default is a non-ABC ground truth on purpose: fitting the ABC model
 * to it is then a real test of the fit, not a round trip. */
#include "brdf/embedded.h"

#include <string.h>

static const struct {
    const char *name;
    struct brdf_sgd p;
} embedded[] = {
    {"nylon",
     {.rho_d = {0.204199, 0.211192, 0.19234},
      .rho_s = {0.156797, 0.303324, 0.236394},
      .alpha = {0.0250344, 0.0436802, 0.0421753},
      .p = {0.528875, 0.617086, 0.620808},
      .kap = {26.4669, 14.8484, 15.213},
      .f0 = {0.240279, 0.117115, 0.127421},
      .f1 = {0.219191, 0.0940848, 0.101339},
      .lambda = {2.32486, 2.22618, 2.18663},
      .c = {1.17309e-07, 5.34378e-08, 6.68165e-08},
      .k = {39.9707, 33.9774, 34.3152},
      .theta0 = {0.11793, -0.0190508, -0.00222626}}},
    {"gray-plastic",
     {.rho_d = {0.103233, 0.104428, 0.0983734},
      .rho_s = {0.494656, 0.517207, 0.52772},
      .alpha = {0.00758705, 0.00848095, 0.00887135},
      .p = {0.557908, 0.556548, 0.545887},
      .kap = {75.6274, 68.3098, 66.5689},
      .f0 = {0.0428175, 0.0438899, 0.0569098},
      .f1 = {0.0208304, 0.0221893, 0.0375763},
      .lambda = {1.72111, 1.76597, 1.8406},
      .c = {1.06783e-07, 5.31845e-08, 6.53296e-08},
      .k = {65.6538, 63.2018, 61.5805},
      .theta0 = {0.308907, 0.283768, 0.280211}}},
    {"red-plastic",
     {.rho_d = {0.247569, 0.049382, 0.0175621},
      .rho_s = {0.406976, 0.151478, 0.176348},
      .alpha = {0.28723, 0.0572489, 0.0624682},
      .p = {0.939617, 0.0851973, 0.0701483},
      .kap = {3.80564, 17.8374, 16.5631},
      .f0 = {0.10036, 0.178468, 0.149441},
      .f1 = {0.0512697, 0.13191, 0.102958},
      .lambda = {4.37031, 4.96092, 4.75924},
      .c = {1.03822e-07, 0.0236845, 0.0321546},
      .k = {18.6088, 16.1371, 15.1243},
      .theta0 = {-0.609047, 0.43547, 0.445882}}},
    {"gold-metallic-paint",
     {.rho_d = {0.0178625, 0.00995704, 0.00335044},
      .rho_s = {0.17127, 0.120714, 0.115473},
      .alpha = {0.127954, 0.127825, 0.109623},
      .p = {0.781093, 0.795517, 0.661313},
      .kap = {5.90039, 5.83556, 7.14985},
      .f0 = {1.00776e-12, 1.22243e-15, 6.18432e-13},
      .f1 = {-1, -1, -0.334497},
      .lambda = {2.7548, 2.7057, 2.94348},
      .c = {9.46481e-08, 1.06951e-07, 1.10733e-07},
      .k = {23.8811, 23.9059, 24.2972},
      .theta0 = {-0.303345, -0.293778, -0.267019}}},
};

#define N_EMBEDDED (sizeof embedded / sizeof embedded[0])

const char *brdf_embedded_default_spec(void)
{
    return "builtin:nylon";
}

const char *brdf_embedded_names(void)
{
    return "nylon gray-plastic red-plastic gold-metallic-paint";
}

size_t brdf_embedded_count(void)
{
    return N_EMBEDDED;
}

const char *brdf_embedded_name(size_t i)
{
    return i < N_EMBEDDED ? embedded[i].name : NULL;
}

int brdf_embedded_sgd(const char *name, struct brdf_sgd *out)
{
    for (size_t i = 0; i < N_EMBEDDED; i++)
        if (strcmp(embedded[i].name, name) == 0) {
            *out = embedded[i].p;
            return 0;
        }
    return -1;
}
