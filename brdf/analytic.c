/* Analytic materials outside MERL (brdf/analytic.h): a table of named
 * instances of one layered form, evaluated so that every term stays finite
 * at the hard cases (grazing directions, v.h -> 0, the exact mirror). */
#include "brdf/analytic.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/abc.h"
#include "brdf/analytic_spec.h"
#include "brdf/material_private.h"

#define AN_PI 3.14159265358979323846

/* Gold's complex index at about 650, 550 and 450 nm (the red, green and
 * blue of an sRGB camera), rounded from Johnson & Christy (1972): what
 * makes a gold conductor yellow at normal incidence and white at grazing. */
static const struct brdf_analytic materials[] = {
    {.name = "ggx-gold",
     .summary = "gold conductor, one sharp GGX lobe (alpha 0.06), complex Fresnel",
     .conductor = 1,
     .n = {0.166, 0.402, 1.400},
     .k = {3.15, 2.54, 1.86},
     .lobes = 1,
     .alpha = {0.06},
     .weight = {1.0}},
    {.name = "layered-paint",
     .summary = "red paint under a clear coat (eta 1.5): Lambert base through the coat, "
                "sharp (alpha 0.04) and broad (alpha 0.3) GGX lobes",
     .rho = {0.55, 0.07, 0.05},
     .coat = 1,
     .eta = 1.5,
     .lobes = 2,
     .alpha = {0.04, 0.3},
     .weight = {0.6, 0.4}},
    {.name = "rough-diffuse",
     .summary = "clay-like rough diffuse surface, Oren-Nayar sigma 0.4 rad, no specular lobe",
     .rho = {0.65, 0.52, 0.38},
     .sigma = 0.4},
    {.name = "plastic-ggx",
     .summary = "blue glossy plastic: Lambert + one GGX lobe (alpha 0.2), dielectric eta 1.5",
     .rho = {0.05, 0.18, 0.55},
     .eta = 1.5,
     .lobes = 1,
     .alpha = {0.2},
     .weight = {1.0}},
};

#define N_MATERIALS (sizeof materials / sizeof materials[0])

const struct brdf_analytic *brdf_analytic_at(size_t i)
{
    return i < N_MATERIALS ? &materials[i] : NULL;
}

const struct brdf_analytic *brdf_analytic_find(const char *name)
{
    for (size_t i = 0; i < N_MATERIALS; i++)
        if (!strcmp(materials[i].name, name))
            return &materials[i];
    return NULL;
}

void brdf_analytic_names(char *buf, size_t size)
{
    size_t len = 0;
    buf[0] = '\0';
    for (size_t i = 0; i < N_MATERIALS && len < size; i++)
        len += (size_t)snprintf(buf + len, size - len, "%s%s", i ? " " : "", materials[i].name);
}

double brdf_analytic_fresnel_conductor(double n, double k, double c)
{
    /* The exact unpolarised reflectance of an absorbing medium (as pbrt's
     * FrConductor): at c = 0 both Rs and Rp are 1, with no division by c. */
    c = c < 0 ? 0 : c > 1 ? 1 : c;
    double c2 = c * c, s2 = 1.0 - c2;
    double t0 = n * n - k * k - s2;
    double a2b2 = sqrt(t0 * t0 + 4.0 * n * n * k * k);
    double t1 = a2b2 + c2;
    double a = sqrt(fmax(0.0, 0.5 * (a2b2 + t0)));
    double t2 = 2.0 * c * a;
    double rs = (t1 - t2) / (t1 + t2);
    double t3 = c2 * a2b2 + s2 * s2;
    double t4 = t2 * s2;
    double rp = rs * (t3 - t4) / (t3 + t4);
    return 0.5 * (rs + rp);
}

/* GGX times the Smith visibility, with sin^2 theta_h given (no 1 - nh^2
 * cancellation near the mirror, where a sharp lobe is steepest). */
static double lobe(double alpha, double sin2h, double nl, double nv)
{
    double a2 = alpha * alpha;
    double d = sin2h + (1.0 - sin2h) * a2;
    double D = a2 / (AN_PI * d * d);
    double ll = sqrt(a2 + (1.0 - a2) * nl * nl), lv = sqrt(a2 + (1.0 - a2) * nv * nv);
    return D / ((nl + ll) * (nv + lv));
}

void brdf_analytic_eval(const struct brdf_analytic *a, const struct brdf_pair *g, double rgb[3])
{
    const double *l = g->wi, *v = g->wo;
    double nl = l[2], nv = v[2];
    rgb[0] = rgb[1] = rgb[2] = 0.0;
    if (!(nl > 0) || !(nv > 0))
        return;
    double s[3] = {l[0] + v[0], l[1] + v[1], l[2] + v[2]};
    double t2 = s[0] * s[0] + s[1] * s[1];
    double len2 = t2 + s[2] * s[2];
    /* l = -v (both at the horizon) leaves h undefined: take h = n there;
     * v.h = |l + v| / 2 -> 0 and every factor stays finite. */
    double sin2h = len2 > 1e-24 ? t2 / len2 : 0.0;
    double vh = 0.5 * sqrt(len2);

    double diffuse = 1.0 / AN_PI;
    if (a->sigma > 0) {
        double s2 = a->sigma * a->sigma;
        double A = 1.0 - 0.5 * s2 / (s2 + 0.33), B = 0.45 * s2 / (s2 + 0.09);
        double lv = l[0] * v[0] + l[1] * v[1] + l[2] * v[2] - nl * nv;
        diffuse *= A + B * (lv > 0 ? lv / fmax(nl, nv) : 0.0);
    }
    if (a->coat)
        diffuse *= (1.0 - brdf_abc_fresnel(a->eta, nl, NULL)) *
                   (1.0 - brdf_abc_fresnel(a->eta, nv, NULL));
    double spec = 0.0;
    for (int k = 0; k < a->lobes; k++)
        spec += a->weight[k] * lobe(a->alpha[k], sin2h, nl, nv);
    /* eta is unset (0) without lobes: no Fresnel term then */
    double fd = a->conductor || !a->lobes ? 0.0 : brdf_abc_fresnel(a->eta, vh, NULL);
    for (int c = 0; c < 3; c++) {
        double f = a->conductor ? brdf_analytic_fresnel_conductor(a->n[c], a->k[c], vh) : fd;
        rgb[c] = a->rho[c] * diffuse + f * spec;
    }
}

static void analytic_material_eval(const void *priv, const struct brdf_pair *pairs, size_t n,
                                   double *rgb)
{
    for (size_t i = 0; i < n; i++)
        brdf_analytic_eval(priv, &pairs[i], rgb + 3 * i);
}

/* The table is static: nothing to free. */
static const struct brdf_material_ops analytic_ops = {
    .kind = "analytic",
    .eval = analytic_material_eval,
};

brdf_material *brdf_analytic_open(const char *spec, const char *name, struct gonio_err *err)
{
    if (brdf_analytic_spec_is_parametric(name))
        return brdf_analytic_spec_open(spec, name, err);
    const struct brdf_analytic *a = brdf_analytic_find(name);
    if (!a) {
        char names[256];
        brdf_analytic_names(names, sizeof names);
        gonio_err_set(err, GONIO_ENOTFOUND, "%s: no analytic material '%s' (have: %s, "
                      "or aniso-ggx?... and two-lobe?... with parameters)", spec, name, names);
        return NULL;
    }
    brdf_material *m = brdf_material_new(&analytic_ops, (void *)a, spec);
    if (!m)
        gonio_err_set(err, ENOMEM, "%s: out of memory", spec);
    return m;
}
