/* An anisotropic analytic material: a Lambert base and one anisotropic GGX
 * lobe (Walter et al. 2007; the anisotropic form of Heitz, JCGT 2014)
 * whose roughnesses ax, ay lie along the sample's tangent and bitangent,
 * the tangent turned phi_deg from the sample's x axis about its normal:
 *
 *   f = rho/pi + F(v.h) D(h) / ((n.l + L(l)) (n.v + L(v)))
 *   D(h) = 1 / (pi ax ay ((h.t/ax)^2 + (h.b/ay)^2 + (h.n)^2)^2)
 *   L(w) = sqrt(ax^2 (w.t)^2 + ay^2 (w.b)^2 + (w.n)^2)   (separable Smith)
 *   F    = Schlick's f0 + (1 - f0) (1 - v.h)^5, per channel
 *
 * Directions are in the sample's frame: a rig that turns the sample about
 * its normal rotates the pair first (brdf_pair_rotate). Values are RGB in
 * 1/sr, 0 below the horizon, finite at grazing and at l = -v, reciprocal;
 * with ax = ay it is the isotropic GGX lobe of brdf/analytic.h. */
#ifndef GONIO_BRDF_ANALYTIC_ANISO_H
#define GONIO_BRDF_ANALYTIC_ANISO_H

#include "brdf/angles.h"
#include "brdf/material.h"

struct brdf_aniso_ggx {
    double ax, ay;   /* GGX roughness along the tangent and the bitangent */
    double phi_deg;  /* the tangent's azimuth on the sample */
    double rho[3];   /* diffuse albedo, RGB */
    double f0[3];    /* Fresnel reflectance at normal incidence, RGB */
};

void brdf_aniso_ggx_eval(const struct brdf_aniso_ggx *a, const struct brdf_pair *g,
                         double rgb[3]);

/* The material of these parameters, labelled name (anisotropic:
 * brdf_material_isotropic says 0); NULL when out of memory. */
brdf_material *brdf_aniso_ggx_material(const struct brdf_aniso_ggx *a, const char *name);

#endif
