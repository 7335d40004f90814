/* Analytic materials outside MERL (`analytic:NAME`): what a lab measures
 * and the latent decoder, trained on MERL, has never seen. Each is one
 * instance of a layered form (docs/models.md "Analytic materials"):
 *
 *   f = T(n.l) T(n.v) rho/pi ON_sigma(l, v)
 *     + sum_k w_k F(v.h) D_alpha_k(n.h) V_alpha_k(n.l, n.v)
 *
 *   ON_sigma   Oren & Nayar's qualitative model (1994), Fujii's form:
 *              A + B max(0, l.v - (n.l)(n.v)) / max(n.l, n.v); 1 at sigma = 0
 *   D_alpha    GGX (Walter, Marschner, Li, Torrance, EGSR 2007):
 *              alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2)
 *   V_alpha    separable Smith G1(l) G1(v) / (4 (n.l)(n.v)) written as
 *              1 / ((n.l + L(n.l)) (n.v + L(n.v))), L(c) = sqrt(alpha^2 +
 *              (1 - alpha^2) c^2): finite at grazing, no 0/0
 *   F          unpolarised Fresnel: of a dielectric of index eta (the ABC
 *              formula, brdf_abc_fresnel), or of a conductor of complex
 *              index n + ik per channel
 *   T          1 - F(n.) of the dielectric coat for a layered material
 *              (the diffuse base seen through the coat twice), else 1
 *
 * Values are RGB in 1/sr, 0 below the horizon, finite and non-negative for
 * every pair (grazing, v.h -> 0 included), and reciprocal. */
#ifndef GONIO_BRDF_ANALYTIC_H
#define GONIO_BRDF_ANALYTIC_H

#include <stddef.h>

#include "brdf/angles.h"
#include "brdf/material.h"
#include "common/err.h"

#define BRDF_ANALYTIC_MAX_LOBES 2

struct brdf_analytic {
    const char *name;
    const char *summary;  /* one line for docs and messages */
    double rho[3];        /* diffuse albedo, RGB */
    double sigma;         /* Oren-Nayar roughness, radians (0: Lambert) */
    int coat;             /* 1: the diffuse base lies under the dielectric coat */
    double eta;           /* dielectric index of the lobes (conductor 0) */
    int conductor;        /* 1: the lobes reflect with the conductor's n + ik */
    double n[3], k[3];    /* conductor complex index, RGB */
    int lobes;            /* specular lobes, <= BRDF_ANALYTIC_MAX_LOBES */
    double alpha[BRDF_ANALYTIC_MAX_LOBES], weight[BRDF_ANALYTIC_MAX_LOBES];
};

/* The named materials: i = 0.. until NULL. */
const struct brdf_analytic *brdf_analytic_at(size_t i);
const struct brdf_analytic *brdf_analytic_find(const char *name);

/* The names, space-separated (for messages), into buf. */
void brdf_analytic_names(char *buf, size_t size);

/* Unpolarised Fresnel reflectance of a conductor of index n + ik at
 * c = cos of the angle of incidence (clamped to [0, 1]); 1 at c = 0. */
double brdf_analytic_fresnel_conductor(double n, double k, double c);

void brdf_analytic_eval(const struct brdf_analytic *a, const struct brdf_pair *g, double rgb[3]);

/* `analytic:NAME`; an unknown name is a GONIO_ENOTFOUND error that lists
 * the names. */
brdf_material *brdf_analytic_open(const char *spec, const char *name, struct gonio_err *err);

#endif
