/* The anisotropic GGX model (`gonio fit --model aniso-ggx`): the material
 * of brdf/analytic_aniso.h — a Lambert base rho, one anisotropic GGX lobe
 * of roughnesses ax, ay along a tangent turned phi on the sample, Schlick's
 * Fresnel from f0 — fitted by weighted least squares on the log residuals
 * log(1 + f cos theta_i), as abc.
 *
 * Its value depends on where the pair lies on the sample (the azimuths of
 * both directions in the sample's frame), so it needs samples taken at more
 * than one azimuth of the sample: out-of-plane pairs, or in-plane ones with
 * the sample turned (a plan's sample_azimuths, docs/plans.md), whose
 * journal records each pair in the turned sample's frame. In-plane samples
 * at one azimuth see one slice of the lobe and leave ax, ay and phi
 * underdetermined.
 *
 * Parameters (9): rho (RGB, >= 0), f0 (RGB, > 0: the specular scale at
 * normal incidence; above 1 it is a scale, the Fresnel term stays
 * positive), ax, ay in [0.001, 2], phi in [0, 180) degrees with ax <= ay
 * (the lobe is unchanged by phi + 180, and by swapping ax and ay with phi
 * + 90). docs/models.md says how it is fitted. */
#ifndef GONIO_FIT_ANISO_GGX_MODEL_H
#define GONIO_FIT_ANISO_GGX_MODEL_H

#include "brdf/analytic_aniso.h"
#include "fit/models.h"

#define FIT_ANISO_GGX_FILE_VERSION 1

/* The registry's fit and open (fit/models.h). */
int fit_aniso_ggx_model_fit(const struct fit_data *data, const struct fit_model_options *opt,
                            struct fit_model_file **out, struct fit_model_report *rep,
                            struct gonio_err *err);
brdf_material *fit_aniso_ggx_model_open(const struct fit_model_file *f, const char *name,
                                        struct gonio_err *err);

/* The parameters of an aniso-ggx model file; 0, or GONIO_EBADDATA naming
 * path. */
int fit_aniso_ggx_params(const struct fit_model_file *f, const char *path,
                         struct brdf_aniso_ggx *a, struct gonio_err *err);

/* The fit on samples s[0..n) (those with both directions above the
 * sample and finite values; no censored readings) in the fit's own
 * coordinates x: log rho (RGB), log f0 (RGB), log ax, log ay, phi in
 * radians, as canonical as the model file's. cold: from the grid of starts,
 * as fit_aniso_ggx_model_fit; else one local solve from x (a warm start,
 * for the adaptive policy's refits). *rms: the RMS log residual at the end.
 * 0, -ENOMEM, or -GONIO_EFIT with fewer than 3 usable samples. */
int fit_aniso_ggx_solve(const struct fit_sample *s, size_t n, int cold, double x[9],
                        double *rms);

/* 1 if the fit uses s: both directions above the sample, finite values
 * with 1 + f cos theta_i > 0. */
int fit_aniso_ggx_usable(const struct fit_sample *s);

/* The material at x (fit_aniso_ggx_solve's coordinates), clamped as the
 * fit clamps it: rho and f0 within e^-30..e^5, ax and ay within
 * 0.001..2. */
void fit_aniso_ggx_to_params(const double x[9], struct brdf_aniso_ggx *a);

#endif
