/* A reflectance standard (a diffuse reference plaque) as its certificate
 * describes it: the reflectance factor per RGB channel or per wavelength
 * with its standard uncertainty, and, where known, its angular shape, the
 * departure of its BRDF from a Lambertian one of the same reflectance.
 *
 *   f_ref(theta_i, theta_r) = R / pi * shape(theta_i, theta_r)
 *
 * The file format (configs/standards/NAME.yaml, docs/radiometry.md) lives
 * here, below the radiometry library that reduces against it, because the
 * simulator's reference material (`standard:NAME`, brdf/material.h) must
 * follow the same file: what the chain is tested against is what it
 * calibrates with. A standard given without a shape (or as a bare rho) is
 * Lambertian, and says so in warning: that costs up to ~10 % at large
 * angles on Spectralon. */
#ifndef GONIO_BRDF_STANDARD_H
#define GONIO_BRDF_STANDARD_H

#include <stddef.h>

#include "brdf/material.h"
#include "common/err.h"

#define BRDF_STANDARD_MAX_GRID 32
#define BRDF_STANDARD_MAX_NM 128

struct brdf_standard {
    char name[64];
    char certificate[256]; /* what the values rest on (a certificate, a datasheet) */
    double rho[3];         /* reflectance factor per linear-sRGB channel */
    double u_rho[3];       /* its standard uncertainty (k = 1), absolute */
    /* Angular shape on a grid of incidence angles (>= 0) and signed
     * in-plane view angles (brdf/angles.h: + toward the mirror side);
     * n_inc = 0: Lambertian. Bilinear inside the grid, held at its edges. */
    size_t n_inc, n_view;
    double inc_deg[BRDF_STANDARD_MAX_GRID], view_deg[BRDF_STANDARD_MAX_GRID];
    double shape[BRDF_STANDARD_MAX_GRID][BRDF_STANDARD_MAX_GRID]; /* [inc][view] */
    double u_shape;        /* relative standard uncertainty of the shape */
    /* A certificate per wavelength as it was given (n_nm 0: per RGB
     * channel or a bare rho): what a spectral detector's bands are
     * reduced against (brdf_standard_rho_at). */
    size_t n_nm;
    double nm[BRDF_STANDARD_MAX_NM], rho_nm[BRDF_STANDARD_MAX_NM], u_nm[BRDF_STANDARD_MAX_NM];
    char warning[256];     /* "" or why the standard is weaker than it could be */
};

/* Load a standard from a file, or by name from <config>/standards/NAME.yaml.
 * Errors name the file, line, field and value (GONIO_EBADCONFIG), or the
 * missing file (GONIO_ENOTFOUND). */
int brdf_standard_load(const char *path_or_name, struct brdf_standard *out,
                       struct gonio_err *err);

/* The shape factor at a geometry (1 for a Lambertian standard). */
double brdf_standard_shape(const struct brdf_standard *s, double theta_i_deg,
                           double theta_r_deg);

/* The standard's BRDF, 1/sr, per channel at an in-plane geometry. */
void brdf_standard_brdf(const struct brdf_standard *s, double theta_i_deg, double theta_r_deg,
                        double rgb[3]);

/* The reflectance factor and its standard uncertainty at a wavelength: a
 * certificate per wavelength linearly between its rows (held beyond its
 * ends); one per RGB channel lifted to a spectrum as the simulator lifts
 * RGB materials (brdf/spectral.h; a bare or grey rho is flat). */
void brdf_standard_rho_at(const struct brdf_standard *s, double nm, double *rho, double *u);

/* The standard as a spectral detector sees it (`standard:NAME` on a
 * spectral detector): brdf_standard_rho_at times the shape / pi, at the
 * pairs brdf_standard_material takes. */
struct brdf_spectral;
struct brdf_spectral *brdf_standard_spectral(const struct brdf_standard *s, const char *spec,
                                             struct gonio_err *err);

/* The same standard with its shape dropped: what taking it as rho/pi means. */
void brdf_standard_as_lambertian(struct brdf_standard *s);

/* A material that is the standard (`standard:NAME` in brdf_material_open):
 * in-plane pairs follow the shape; out-of-plane pairs use the shape at the
 * pair's polar angles (forward half when the azimuths differ by > 90 deg). */
brdf_material *brdf_standard_material(const struct brdf_standard *s, const char *spec,
                                      struct gonio_err *err);

#endif
