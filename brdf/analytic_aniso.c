/* The anisotropic GGX material (brdf/analytic_aniso.h), written on the
 * unnormalised half vector so that the exact mirror and grazing pairs need
 * no special case beyond l = -v. */
#include "brdf/analytic_aniso.h"

#include <math.h>
#include <stdlib.h>

#include "brdf/material_private.h"

#define AA_PI 3.14159265358979323846

/* w's components along the tangent and the bitangent. */
static void tangent_frame(const double w[3], double c, double s, double *t, double *b)
{
    *t = w[0] * c + w[1] * s;
    *b = -w[0] * s + w[1] * c;
}

static double smith_l(const struct brdf_aniso_ggx *a, const double w[3], double c, double s)
{
    double t, b;
    tangent_frame(w, c, s, &t, &b);
    return sqrt(a->ax * a->ax * t * t + a->ay * a->ay * b * b + w[2] * w[2]);
}

void brdf_aniso_ggx_eval(const struct brdf_aniso_ggx *a, const struct brdf_pair *g,
                         double rgb[3])
{
    const double *l = g->wi, *v = g->wo;
    rgb[0] = rgb[1] = rgb[2] = 0.0;
    if (!(l[2] > 0) || !(v[2] > 0))
        return;
    double c = cos(a->phi_deg * BRDF_DEG), s = sin(a->phi_deg * BRDF_DEG);
    double h[3] = {l[0] + v[0], l[1] + v[1], l[2] + v[2]};
    double len2 = h[0] * h[0] + h[1] * h[1] + h[2] * h[2];
    double D;
    if (len2 > 1e-24) {
        /* D of the normalised half vector: |h|^4 / (pi ax ay q^2) with q
         * the quadratic form of the unnormalised one. */
        double t, b;
        tangent_frame(h, c, s, &t, &b);
        double q = t * t / (a->ax * a->ax) + b * b / (a->ay * a->ay) + h[2] * h[2];
        D = len2 * len2 / (AA_PI * a->ax * a->ay * q * q);
    } else {
        D = 1.0 / (AA_PI * a->ax * a->ay); /* l = -v at the horizon: h = n */
    }
    double vh = 0.5 * sqrt(len2);
    double spec = D / ((l[2] + smith_l(a, l, c, s)) * (v[2] + smith_l(a, v, c, s)));
    double m = 1.0 - (vh > 1 ? 1 : vh), m5 = m * m * m * m * m;
    for (int k = 0; k < 3; k++)
        rgb[k] = a->rho[k] / AA_PI + (a->f0[k] + (1.0 - a->f0[k]) * m5) * spec;
}

static void aniso_material_eval(const void *priv, const struct brdf_pair *pairs, size_t n,
                                double *rgb)
{
    for (size_t i = 0; i < n; i++)
        brdf_aniso_ggx_eval(priv, &pairs[i], rgb + 3 * i);
}

static const struct brdf_material_ops aniso_ops = {
    .kind = "analytic",
    .eval = aniso_material_eval,
    .free_priv = free,
};

brdf_material *brdf_aniso_ggx_material(const struct brdf_aniso_ggx *a, const char *name)
{
    struct brdf_aniso_ggx *copy = malloc(sizeof *copy);
    if (!copy)
        return NULL;
    *copy = *a;
    brdf_material *m = brdf_material_new(&aniso_ops, copy, name);
    if (m)
        brdf_material_set_anisotropic(m);
    return m;
}
