/* Radiometry to colour (design brief section 6): a reflectance spectrum is
 * lit by CIE D65, seen by the CIE 1931 2-degree observer, and the XYZ result
 * is turned into linear sRGB with DESIGN.md's matrix. Spectra may come in
 * any band layout (31 bands 400-700 nm, 35 bands 390-730 nm, ...): they are
 * resampled onto the 5 nm CIE tables, so every layout is weighed by the
 * same observer and illuminant. */
#ifndef GONIO_BRDF_COLOUR_H
#define GONIO_BRDF_COLOUR_H

#include <stddef.h>
#include <stdint.h>

#include "common/err.h"

/* The embedded CIE tables: 360, 365, ..., 830 nm. */
#define BRDF_CIE_FIRST_NM 360
#define BRDF_CIE_STEP_NM 5
#define BRDF_CIE_COUNT 95

/* CIE 1931 2-degree colour matching functions at lambda_nm: the table value
 * on a 5 nm node, linear between nodes, 0 outside 360-830 nm. */
void brdf_cie_cmf(double lambda_nm, double xyz_bar[3]);

/* CIE D65 relative spectral power (100 at 560 nm), same sampling rules. */
double brdf_cie_d65(double lambda_nm);

/* Weights w[3n] such that XYZ[c] = sum_k w[3k + c] * r[k] for a reflectance
 * r sampled at the n strictly increasing wavelengths lambda_nm[k]. The
 * reflectance is interpolated linearly onto the 5 nm table and held at its
 * end values beyond the first and last band (ASTM E308 practice), and the
 * result is normalised so that r = 1 everywhere gives Y = 1 exactly.
 * Computing the weights once makes converting many spectra a dot product.
 * Returns 0, or -GONIO_EBADDATA for an empty, non-finite or unsorted layout. */
int brdf_colour_weights(const double *lambda_nm, size_t n, double *w, struct gonio_err *err);

/* XYZ under D65 of one reflectance spectrum (see brdf_colour_weights). */
int brdf_colour_spectrum_to_xyz(const double *lambda_nm, const double *refl, size_t n,
                                double xyz[3], struct gonio_err *err);

/* XYZ (D65 white at Y = 1) to linear sRGB with the matrix of DESIGN.md. */
void brdf_colour_xyz_to_srgb_linear(const double xyz[3], double rgb[3]);

/* Chromaticity x = X/(X+Y+Z), y = Y/(X+Y+Z). Returns 0, or -1 (xy set to
 * NAN) when X+Y+Z is zero or not finite. */
int brdf_colour_xyz_to_xy(const double xyz[3], double xy[2]);

/* sRGB transfer function (IEC 61966-2-1) of a linear value clamped to
 * [0, 1]; NAN maps to 0. */
double brdf_colour_srgb_encode(double linear);

/* The same, quantised to 8 bits (rounded to nearest) for PNG output. */
uint8_t brdf_colour_srgb8(double linear);

#endif
