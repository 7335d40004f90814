/* Analytic materials built from their parameters in the material spec:
 *
 *   analytic:aniso-ggx?ax=A&ay=A[&phi=DEG][&rho_d=R|R:G:B][&f0=F|R:G:B]
 *       Lambert base and one anisotropic GGX lobe (brdf/analytic_aniso.h);
 *       ax, ay in 0.001..1 (required), phi -360..360 degrees (default 0),
 *       rho_d 0..1 (default 0.05), f0 0..1 (default 0.9)
 *   analytic:two-lobe?a1=A&w1=W&a2=A&w2=W[&rho_d=R|R:G:B][&eta=N]
 *       Lambert base and two isotropic GGX lobes of a dielectric
 *       (brdf/analytic.h): a1, a2 in 0.001..1, w1, w2 in 0..10 (all
 *       required), rho_d 0..1 (default 0.1), eta 1.01..4 (default 1.5)
 *
 * A value is a number, or for RGB values one number or three separated by
 * ':'. Errors (GONIO_EBADCONFIG) name the spec, the parameter and the
 * value: an unknown or repeated parameter, a missing required one, a
 * value that is not a number or lies outside its range. */
#ifndef GONIO_BRDF_ANALYTIC_SPEC_H
#define GONIO_BRDF_ANALYTIC_SPEC_H

#include "brdf/analytic.h"
#include "brdf/analytic_aniso.h"
#include "brdf/material.h"
#include "common/err.h"

/* True when name (the part after "analytic:") is a parametric kind. */
int brdf_analytic_spec_is_parametric(const char *name);

/* Parse name into a material's parameters; 0, or -GONIO_EBADCONFIG with
 * err naming spec. */
int brdf_analytic_spec_aniso(const char *spec, const char *name, struct brdf_aniso_ggx *out,
                             struct gonio_err *err);
int brdf_analytic_spec_two_lobe(const char *spec, const char *name, struct brdf_analytic *out,
                                struct gonio_err *err);

/* The material of a parametric name, labelled spec; NULL with err. */
brdf_material *brdf_analytic_spec_open(const char *spec, const char *name,
                                       struct gonio_err *err);

#endif
