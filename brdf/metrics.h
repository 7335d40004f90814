/* Error metrics (design brief section 6), always reported with their domain:
 *
 *   log error (headline)  mean over pairs and channels of
 *                         |log(1 + fhat cos ti) - log(1 + f cos ti)|
 *   relative RMSE         sqrt(sum w (fhat - f)^2 / sum w f^2), w = cos ti,
 *                         summed over pairs and channels
 *
 * f is the truth, fhat the prediction, both RGB BRDF values in 1/sr without
 * the cosine. A pair with NAN in any channel of either (no data) is left
 * out and counted. */
#ifndef GONIO_BRDF_METRICS_H
#define GONIO_BRDF_METRICS_H

#include <stddef.h>

#include "brdf/angles.h"
#include "brdf/domain.h"
#include "brdf/material.h"
#include "common/err.h"

struct brdf_errors {
    double log;      /* NAN when no pair was used */
    double rel_rmse; /* NAN when no pair was used; 0 when truth and prediction are both all 0 */
    size_t n_used;   /* pairs that entered the sums */
    size_t n_skipped; /* pairs left out for NAN in truth or prediction */
};

/* Running sums, so that errors over a large domain can be computed block by
 * block (brdf_errors_material) or merged across threads. */
struct brdf_errors_acc {
    double sum_log, sum_wd2, sum_wf2;
    size_t n_used, n_skipped;
};

void brdf_errors_acc_init(struct brdf_errors_acc *acc);
void brdf_errors_acc_add(struct brdf_errors_acc *acc, const struct brdf_pair *pairs,
                         const double *truth_rgb, const double *pred_rgb, size_t n);
void brdf_errors_acc_finish(const struct brdf_errors_acc *acc, struct brdf_errors *out);

/* Errors of pred_rgb[3n] against truth_rgb[3n] at the n pairs. The cosine is
 * wi.z, taken as 0 below the horizon. */
void brdf_errors_compute(const struct brdf_pair *pairs, const double *truth_rgb,
                         const double *pred_rgb, size_t n, struct brdf_errors *out);

/* Errors of model against truth over a domain, evaluated 4096 pairs at a
 * time so that memory stays small whatever the domain. Returns 0, or a
 * negative code (out of memory) with out set to NAN errors. */
int brdf_errors_material(const brdf_material *truth, const brdf_material *model,
                         const struct brdf_domain *d, struct brdf_errors *out,
                         struct gonio_err *err);

#endif
