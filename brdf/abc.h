/* The ABC microfacet model (Low, Kronander, Ynnerman, Unger, TOG 2012):
 *
 *   f = kd/pi + F(eta, v.h) G / ((n.l)(n.v)) * A / (1 + B (1 - n.h))^C
 *
 * with the Cook-Torrance V-groove G and the unpolarised dielectric Fresnel
 * F. Convention: A here is without the extra 1/pi of the published MERL fits
 * (A_here = A_published / pi); brdf_abc_from_published() converts. */
#ifndef GONIO_BRDF_ABC_H
#define GONIO_BRDF_ABC_H

#include "brdf/angles.h"
#include "brdf/material.h"

struct brdf_abc {
    double kd[3]; /* diffuse albedo, RGB */
    double A[3];  /* specular amplitude, RGB */
    double B, C;  /* distribution width and falloff */
    double eta;   /* relative index of refraction, > 1 */
};

void brdf_abc_eval(const struct brdf_abc *p, const struct brdf_pair *g, double rgb[3]);

/* A material that evaluates the model with these parameters. */
brdf_material *brdf_abc_material(const struct brdf_abc *p, const char *name);

#endif
