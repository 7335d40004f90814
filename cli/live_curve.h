/* The fit curves of `gonio live`: a material (a fitted model) evaluated
 * along the in-plane slice at each incidence the capture measured. */
#ifndef GONIO_CLI_LIVE_CURVE_H
#define GONIO_CLI_LIVE_CURVE_H
#include <stddef.h>

#include <jansson.h>

#include "brdf/material.h"

#define LIVE_CURVE_INCIDENCES 12 /* curves drawn at most: one per theta_i */

/* {"source":source,"samples":n,"curves":[{"theta_i":..,"theta_r":[..],
 * "log10_f":[..]}, ...]}: log10 of the mean over RGB of m at theta_r from
 * -88 to 88 degrees (points where the model is not positive are null), for
 * each of the n_ti incidences. NULL when out of memory. */
json_t *live_curve_json(const brdf_material *m, const double *theta_i, size_t n_ti,
                        const char *source, size_t n);

#endif
