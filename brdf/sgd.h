/* The shifted-gamma-distribution (SGD) microfacet BRDF of
 *   M. M. Bagher, C. Soler, N. Holzschuch, "Accurate fitting of measured
 *   reflectances using a Shifted Gamma micro-facet distribution",
 *   Computer Graphics Forum 31(4), 2012,
 * with the per-channel parameters the authors fitted to the MERL materials
 * (as distributed in the public-domain dj_brdf.h of J. Dupuy, commit
 * 94cb16a4, and in <shared>/data/merl/fits/sgd_bagher2012_merl.csv).
 *
 * Per channel, with c_d = clamp(wi.h, 0, 1), theta_k the polar angle of a
 * direction k, all angles in radians:
 *
 *   f  = (rhoD + rhoS F D G1(wi) G1(wo) / (cos theta_i cos theta_o)) / pi
 *   D  = kap exp(-a) / (pi a^p cos^4 theta_h),  a = alpha + tan^2 theta_h / alpha
 *   F  = f0 - c_d f1 + (1 - c_d)^5 (1 - f0)
 *   G1 = clamp(1 + lambda (1 - exp(c max(0, theta_k - theta0)^k)), 0, 1)
 *
 * and f = 0 when either direction is at or below the horizon. These are
 * the forms dj_brdf evaluates the published parameters with (the paper's
 * Fresnel and shadowing fits); the data README gives only the outline. */
#ifndef GONIO_BRDF_SGD_H
#define GONIO_BRDF_SGD_H

#include "brdf/angles.h"
#include "brdf/material.h"

struct brdf_sgd {
    double rho_d[3], rho_s[3];
    double alpha[3], p[3], kap[3];      /* distribution */
    double f0[3], f1[3];                /* Fresnel */
    double lambda[3], c[3], k[3], theta0[3]; /* shadowing */
};

/* The SGD terms of one channel, exposed for tests and fitting code. */
double brdf_sgd_ndf(const struct brdf_sgd *p, int ch, double cos_theta_h);
double brdf_sgd_fresnel(const struct brdf_sgd *p, int ch, double cos_theta_d);
double brdf_sgd_g1(const struct brdf_sgd *p, int ch, double theta_k);

void brdf_sgd_eval(const struct brdf_sgd *p, const struct brdf_pair *g, double rgb[3]);

/* A material that evaluates the model with these parameters (copied). */
brdf_material *brdf_sgd_material(const struct brdf_sgd *p, const char *name);

#endif
