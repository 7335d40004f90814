/* Spectral materials: the BRDF per wavelength (1/sr, cosine not included)
 * for the simulated spectral detector, and their colour through the
 * radiometry -> photometry pipeline of brdf/colour.h.
 *
 * Kinds (specification "spectral:NAME"):
 *   gold     polished gold: GGX microfacet lobe (alpha 0.12) with the exact
 *            unpolarised Fresnel reflectance of the complex index n + ik
 *            tabulated in <shared>/data/spectral/gold_nk.csv (read at open;
 *            390-730 nm, linear between rows)
 *   cyan, magenta
 *            a printed ink on paper: Lambertian body with a smooth model
 *            reflectance spectrum (logistic edges / Gaussian absorption band,
 *            not measured data) under a clear varnish lobe (GGX alpha 0.25,
 *            dielectric Fresnel, eta 1.5)
 *   gonio    goniochromatic: a 380 nm film of index 1.8 on a dark substrate
 *            (index 1.5 + 0.5i); the lobe's Fresnel factor is the film's
 *            thin-film (Airy) reflectance, whose interference colour shifts
 *            to shorter wavelengths as the angle grows
 * and any RGB material lifted to spectra (brdf_spectral_lift).
 *
 * The lift (RGB -> spectrum) is linear and smooth: s(lambda) = sum_j c_j
 * b_j(lambda) over three logistic bases that sum to one (blue: 1 -
 * L((lambda - 490)/15), red: L((lambda - 590)/15), green: the rest), with c
 * solving M c = rgb where M is the linear sRGB of each basis under D65 on
 * the 5 nm CIE grid. It is exact on that grid (lift then convert gives the
 * RGB back), turns grey into a flat spectrum, and may go negative for
 * colours outside its three bases' gamut (not clamped: clamping would
 * change the colour). */
#ifndef GONIO_BRDF_SPECTRAL_H
#define GONIO_BRDF_SPECTRAL_H

#include <stddef.h>

#include "brdf/angles.h"
#include "brdf/material.h"
#include "common/err.h"

typedef struct brdf_spectral brdf_spectral;

/* Open "spectral:NAME" (or NAME) from the list above. gold needs the shared
 * data; errors name the spec and, for the table, file:line. */
brdf_spectral *brdf_spectral_open(const char *spec, struct gonio_err *err);

/* An RGB material seen spectrally through the lift; rgb is borrowed and
 * must outlive the result. */
brdf_spectral *brdf_spectral_lift(const brdf_material *rgb, struct gonio_err *err);

/* BRDF at the pair for n wavelengths (nm) into out[n]. */
void brdf_spectral_eval(const brdf_spectral *m, const struct brdf_pair *p,
                        const double *lambda_nm, size_t n, double *out);

/* Wavelength range the material is defined on, nm. */
void brdf_spectral_range(const brdf_spectral *m, double *lo_nm, double *hi_nm);

const char *brdf_spectral_name(const brdf_spectral *m);
void brdf_spectral_free(brdf_spectral *m);

/* The three lift bases at lambda (blue, green, red); they sum to 1. */
void brdf_spectral_basis(double lambda_nm, double b[3]);

/* The lift of one linear sRGB triple, sampled at n wavelengths. */
void brdf_spectral_from_rgb(const double rgb[3], const double *lambda_nm, size_t n, double *out);

/* Weights w[3n] with linear sRGB[c] = sum_k w[3k + c] * s[k] for a spectrum
 * s at the n wavelengths (D65, CIE 1931 2 degree, DESIGN.md's matrix). */
int brdf_spectral_rgb_weights(const double *lambda_nm, size_t n, double *w,
                              struct gonio_err *err);

/* Exact unpolarised Fresnel reflectance of a conductor/dielectric of
 * complex index n + ik (from air) at incidence cosine cos_theta. */
double brdf_fresnel_complex(double n, double k, double cos_theta);

/* Unpolarised reflectance of a film (index n_film, thickness d_nm) on a
 * substrate n_sub + i k_sub, from air, at incidence cosine cos_theta. */
double brdf_thin_film_reflectance(double n_film, double d_nm, double n_sub, double k_sub,
                                  double lambda_nm, double cos_theta);

/* "spectral:NAME" as an RGB material (brdf/material.h): each pair's
 * spectrum on 31 bands 400-700 nm turned into linear sRGB. */
brdf_material *brdf_spectral_material_open(const char *spec, struct gonio_err *err);

#endif
