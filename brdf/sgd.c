#include "brdf/sgd.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/material_private.h"

#define SGD_PI 3.14159265358979323846

double brdf_sgd_ndf(const struct brdf_sgd *p, int ch, double cos_theta_h)
{
    double c2 = cos_theta_h * cos_theta_h;
    if (!(c2 > 0))
        return 0.0; /* half vector on the horizon: no facets face it */
    double t2 = (1.0 - c2) / c2;
    double a = p->alpha[ch] + t2 / p->alpha[ch];
    double e = exp(-a);
    if (e == 0.0)
        return 0.0; /* avoids 0/0 when a^p overflows as well */
    return p->kap[ch] * e / (SGD_PI * pow(a, p->p[ch]) * c2 * c2);
}

double brdf_sgd_fresnel(const struct brdf_sgd *p, int ch, double cos_theta_d)
{
    double c = cos_theta_d < 0 ? 0 : cos_theta_d > 1 ? 1 : cos_theta_d;
    double m = 1.0 - c, m2 = m * m;
    return p->f0[ch] - c * p->f1[ch] + m2 * m2 * m * (1.0 - p->f0[ch]);
}

double brdf_sgd_g1(const struct brdf_sgd *p, int ch, double theta_k)
{
    double t = theta_k - p->theta0[ch];
    if (!(t > 0))
        return 1.0; /* below the onset angle there is no shadowing */
    /* c * t^k overflows to inf for the fits with large k or c; the clamp
     * below then gives 0 (or 1 when lambda is 0), never NaN. */
    double x = p->c[ch] * pow(t, p->k[ch]);
    double one_minus_e = 1.0 - exp(x);
    double g = p->lambda[ch] == 0.0 ? 1.0 : 1.0 + p->lambda[ch] * one_minus_e;
    if (isnan(g))
        g = 0.0;
    return g < 0 ? 0 : g > 1 ? 1 : g;
}

void brdf_sgd_eval(const struct brdf_sgd *p, const struct brdf_pair *g, double rgb[3])
{
    const double *wi = g->wi, *wo = g->wo;
    if (!(wi[2] > 0 && wo[2] > 0)) {
        rgb[0] = rgb[1] = rgb[2] = 0.0;
        return;
    }
    double h[3] = {wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]};
    double hn = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
    double cos_h = h[2] / hn;
    double cos_d = (wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2]) / hn;
    /* Polar angles via atan2: exact near the normal, where acos loses digits. */
    double th_i = atan2(hypot(wi[0], wi[1]), wi[2]);
    double th_o = atan2(hypot(wo[0], wo[1]), wo[2]);
    double cos_io = wi[2] * wo[2];
    for (int ch = 0; ch < 3; ch++) {
        double spec = brdf_sgd_fresnel(p, ch, cos_d) * brdf_sgd_ndf(p, ch, cos_h) *
                      brdf_sgd_g1(p, ch, th_i) * brdf_sgd_g1(p, ch, th_o) / cos_io;
        rgb[ch] = (p->rho_d[ch] + p->rho_s[ch] * spec) / SGD_PI;
    }
}

static void sgd_material_eval(const void *priv, const struct brdf_pair *pairs, size_t n,
                              double *rgb)
{
    for (size_t i = 0; i < n; i++)
        brdf_sgd_eval(priv, &pairs[i], rgb + 3 * i);
}

static const struct brdf_material_ops sgd_ops = {
    .kind = "sgd",
    .eval = sgd_material_eval,
    .free_priv = free,
};

brdf_material *brdf_sgd_material(const struct brdf_sgd *p, const char *name)
{
    struct brdf_sgd *copy = malloc(sizeof *copy);
    if (!copy)
        return NULL;
    memcpy(copy, p, sizeof *copy);
    return brdf_material_new(&sgd_ops, copy, name);
}
