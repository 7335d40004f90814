/* The ABC microfacet model, written so that every factor stays finite at the
 * hard cases a fitter walks into: grazing directions, v.h -> 0, eta -> 1,
 * very large B and C. */
#include "brdf/abc.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/material_private.h"

#define ABC_PI 3.14159265358979323846

/* Below this v.h the Fresnel formula is 0/0 at eta = 1; the limit of F for
 * eta -> 1 is 0 and for c -> 0 at eta > 1 it is 1, both reached smoothly
 * from c = 1e-12. */
#define ABC_C_MIN 1e-12

int brdf_abc_geometry(const struct brdf_pair *g, struct brdf_abc_geom *out)
{
    const double *l = g->wi, *v = g->wo;
    double nl = l[2], nv = v[2];
    /* s = l + v is the unnormalised half vector; |s| = 2 (v.h). */
    double s[3] = {l[0] + v[0], l[1] + v[1], l[2] + v[2]};
    double t2 = s[0] * s[0] + s[1] * s[1];
    double len = sqrt(t2 + s[2] * s[2]);
    if (!(nl > 0) || !(nv > 0) || !(len > 0)) {
        out->x = 1.0;
        out->vh = 0.0;
        out->gterm = 0.0;
        return -1;
    }
    double nh = s[2] / len;
    /* 1 - nh = (|s| - s_z) / |s| = t2 / (|s| (|s| + s_z)): no cancellation
     * near the mirror direction, where a large B makes D sensitive to it. */
    out->x = t2 / (len * (len + s[2]));
    out->vh = 0.5 * len;
    /* G / (nl nv) with the min taken term by term, so that a grazing nl or
     * nv cancels analytically instead of as a 0/0. */
    double vh = out->vh;
    double g1 = 1.0 / (nl * nv);
    double g2 = 2.0 * nh / (vh * nl);
    double g3 = 2.0 * nh / (vh * nv);
    double gt = g1;
    if (g2 < gt)
        gt = g2;
    if (g3 < gt)
        gt = g3;
    out->gterm = gt;
    return 0;
}

double brdf_abc_fresnel(double eta, double c, double *d_deta)
{
    if (c < ABC_C_MIN)
        c = ABC_C_MIN;
    if (c > 1.0)
        c = 1.0;
    /* eta^2 - 1 as a product keeps its precision near eta = 1; a g^2 that
     * rounding pushes to <= 0 (eta < 1, total reflection) is clamped. */
    double g2 = (eta - 1.0) * (eta + 1.0) + c * c;
    if (g2 < 0)
        g2 = 0;
    double g = sqrt(g2);
    double gp = g + c, gm = g - c;
    double q = gm / gp;
    double p = q * q;
    double den = c * gm + 1.0; /* >= 1 for g >= c */
    double r = (c * gp - 1.0) / den;
    double qq = 1.0 + r * r;
    double f = 0.5 * p * qq;
    if (d_deta) {
        if (g > 0) {
            double dp_dg = 4.0 * c * gm / (gp * gp * gp);
            double dr_dg = 2.0 * c * (1.0 - c * c) / (den * den);
            double df_dg = 0.5 * (dp_dg * qq + p * 2.0 * r * dr_dg);
            *d_deta = df_dg * eta / g;
        } else {
            *d_deta = 0.0;
        }
    }
    return f;
}

double brdf_abc_distribution(double B, double C, double x, double *d_dB, double *d_dC)
{
    /* (1 + Bx)^-C as exp(-C log1p(Bx)): the exponent is <= 0, so no overflow
     * for any B, C >= 0, and log1p keeps small Bx exact. */
    double bx = B * x;
    double lg = log1p(bx);
    double d = exp(-C * lg);
    if (d_dB)
        *d_dB = -C * x / (1.0 + bx) * d;
    if (d_dC)
        *d_dC = -lg * d;
    return d;
}

void brdf_abc_eval(const struct brdf_abc *p, const struct brdf_pair *g, double rgb[3])
{
    struct brdf_abc_geom geo;
    if (brdf_abc_geometry(g, &geo) < 0) {
        rgb[0] = rgb[1] = rgb[2] = 0.0;
        return;
    }
    double spec = brdf_abc_fresnel(p->eta, geo.vh, NULL) * geo.gterm *
                  brdf_abc_distribution(p->B, p->C, geo.x, NULL, NULL);
    for (int c = 0; c < 3; c++)
        rgb[c] = p->kd[c] / ABC_PI + p->A[c] * spec;
}

static void abc_material_eval(const void *priv, const struct brdf_pair *pairs, size_t n,
                              double *rgb)
{
    const struct brdf_abc *p = priv;
    for (size_t i = 0; i < n; i++)
        brdf_abc_eval(p, &pairs[i], rgb + 3 * i);
}

static const struct brdf_material_ops abc_ops = {
    .kind = "abc",
    .eval = abc_material_eval,
    .free_priv = free,
};

brdf_material *brdf_abc_material(const struct brdf_abc *p, const char *name)
{
    struct brdf_abc *copy = malloc(sizeof *copy);
    if (!copy)
        return NULL;
    memcpy(copy, p, sizeof *copy);
    return brdf_material_new(&abc_ops, copy, name ? name : "abc");
}
