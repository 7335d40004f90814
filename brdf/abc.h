/* The ABC microfacet model (Low, Kronander, Ynnerman, Unger, TOG 2012):
 *
 *   f = kd/pi + F(eta, v.h) G / ((n.l)(n.v)) * A / (1 + B (1 - n.h))^C
 *
 * with the Cook-Torrance V-groove G and the unpolarised dielectric Fresnel
 * F. Convention: A here is without the extra 1/pi of the published MERL fits
 * (A_here = A_published / pi); brdf_published_abc_convert() in brdf/published.h
 * converts. */
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

/* RGB value in 1/sr, cosine not included. Below the horizon (n.l <= 0 or
 * n.v <= 0) the model is undefined and the value is 0. Finite for every
 * finite parameter set with eta >= 1, B >= 0, C >= 0, up to grazing. */
void brdf_abc_eval(const struct brdf_abc *p, const struct brdf_pair *g, double rgb[3]);

/* The parameter-free part of the model for one pair, computed once so that
 * a fitter evaluates only the parameter-dependent factors. */
struct brdf_abc_geom {
    double x;     /* 1 - n.h, computed without cancellation near the mirror */
    double vh;    /* v.h = l.h = cos(theta_d) */
    double gterm; /* G / ((n.l)(n.v)) */
};

/* Returns 0, or -1 (and gterm = 0) below the horizon. */
int brdf_abc_geometry(const struct brdf_pair *g, struct brdf_abc_geom *out);

/* Unpolarised dielectric Fresnel reflectance at relative index eta and
 * c = v.h; 0 at eta = 1. d_deta (if not NULL) receives dF/deta. */
double brdf_abc_fresnel(double eta, double c, double *d_deta);

/* The distribution term 1 / (1 + B x)^C, and its derivatives in B and C
 * (either pointer may be NULL). */
double brdf_abc_distribution(double B, double C, double x, double *d_dB, double *d_dC);

/* A material that evaluates the model with these parameters. */
brdf_material *brdf_abc_material(const struct brdf_abc *p, const char *name);

#endif
