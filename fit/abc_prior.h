/* ABC with a population prior (`--model abc-prior`): a MAP fit that stays
 * sensible when a plan has too few samples for 9 parameters (DS4: six
 * in-plane pairs, 18 residuals).
 *
 * The prior is a Gaussian over the fitter's parameters theta (log kd, log A,
 * log B C, log C, logit of eta; fit/abc_problem.h) estimated from ABC fits
 * of the 100 MERL materials (gonio's own DS1 fits of their NBRDF networks;
 * embedded, with provenance, in fit/abc_prior_table.c), leaving out the
 * material being captured when
 * its name is known: a simulated capture of nbrdf:brass never learns from
 * brass. A real capture uses all 100.
 *
 * It enters as 9 extra residual rows sigma L^-1 (theta - mean) (Sigma = L
 * L^T): the MAP estimate for log-space data residuals of noise sigma. The
 * data cost grows with the sample count and the prior's does not, so the
 * prior's pull shrinks as 9 / (3 n): decisive at n = 6, negligible on DS1
 * (912 samples). See docs/model-choice.md for the choice of sigma. */
#ifndef GONIO_FIT_ABC_PRIOR_H
#define GONIO_FIT_ABC_PRIOR_H

#include <stddef.h>

#include "fit/fit.h"
#include "fit/models.h"

/* Noise level of one log-space residual the prior assumes, i.e. its
 * strength: sigma^2 per unit of squared Mahalanobis distance. Chosen on the
 * DS4 fits of the 10 evaluation materials (leave-one-out, docs/model-choice.md):
 * 0.05 (the ABC misfit level) let six samples pull the lobe anywhere;
 * 0.002 gave the lowest errors (8 of 10 within 0.12) and still moves the
 * DS1-DS3 fits by less than 1e-3 in full-domain log error: the prior's cost
 * is fixed while the data's grows with the samples. */
#define FIT_PRIOR_SIGMA 0.002

/* Floor on kd and A before the log: the table holds exact zeros (metals
 * without a diffuse term), which would put the mean at the log clamp. */
#define FIT_PRIOR_FLOOR 1e-3

/* Warning threshold on the fit's predictive uncertainty (fit_info.sd.pred_log:
 * mean posterior sd of the predicted log(1 + f cos) over an in-plane grid):
 * above it the samples do not pin the BRDF, "these pairs are not enough
 * here". Measured (docs/model-choice.md): DS1-DS3 fits of the 10 evaluation
 * materials 0.000-0.013; abc-prior on DS4 0.023-0.17 for tungsten-carbide,
 * specular-black-phenolic and brass, <= 0.008 for the others. It cannot
 * flag a fit that is confidently wrong (blue-acrylic, alum-bronze on DS4:
 * the model's own misfit near the mirror, not the sample count). */
#define FIT_PRIOR_WARN_PRED_SD 0.02

struct fit_abc_prior {
    double mean[9];      /* theta space (fit/abc_problem.h) */
    double cov[81];      /* row-major */
    size_t n_materials;  /* rows the prior was estimated from */
    double sigma;        /* FIT_PRIOR_SIGMA unless changed */
    char excluded[64];   /* the material left out, or "" */
    /* the members' lobe shapes (B, C, eta), tried as starts */
    double shapes[128][3];
    size_t n_shapes;
};

/* Estimate the prior from the embedded table, leaving out the row named
 * exclude (NULL, "" or a name not in the table: all rows). exclude may be a
 * material spec (nbrdf:NAME, merl:NAME): the part after the colon is used.
 * Returns 0 or a negative code (GONIO_EFIT: covariance not positive
 * definite). */
int fit_abc_prior_build(const char *exclude, struct fit_abc_prior *out, struct gonio_err *err);

/* fit_abc with the prior's residual rows (same options, output and info;
 * info->sd is the posterior standard deviation). Needs at least 1 usable
 * sample. */
int fit_abc_map(const struct fit_sample *samples, size_t n, const struct fit_options *opt,
                const struct fit_abc_prior *prior, struct brdf_abc *out, struct fit_info *info,
                struct gonio_err *err);

/* 1 and a one-line warning in buf when info->sd.pred_log exceeds
 * FIT_PRIOR_WARN_PRED_SD (or is not finite), else 0 and buf empty. */
int fit_abc_prior_warning(const struct fit_info *info, size_t n_samples, char *buf, size_t len);

/* The keys an abc-prior fit adds to its abc model file: the prior it used
 * (`prior`) and the posterior sds (`sd_log_B`, `sd_log_C`, `sd_eta`,
 * `sd_pred_log`). Shared by the registry fit and a capture's final fit, so
 * both files say the same. Returns 0 or a negative code. */
int fit_abc_prior_file_keys(struct fit_model_file *f, const struct fit_abc_prior *prior,
                            const struct fit_info *info);

/* The registry row's fit (`gonio fit --model abc-prior`): writes an "abc"
 * model file. data->material (when set) is left out of the prior; the
 * note carries the sd of log B and the warning. */
int fit_abc_prior_model_fit(const struct fit_data *data, const struct fit_model_options *opt,
                            struct fit_model_file **out, struct fit_model_report *rep,
                            struct gonio_err *err);

#endif
