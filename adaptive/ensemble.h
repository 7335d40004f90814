/* The policy's picture of what the samples do not pin down: a delete-group
 * jackknife ensemble of ABC fits (adaptive/ensemble.c, docs/adaptive.md).
 *
 * The samples, in the order they arrived, fall into ENS_GROUPS groups
 * (sample k in group k mod ENS_GROUPS). Member g is the ABC fit without
 * group g, warm-started from the fit to all samples. Where the members
 * disagree, the data leave the model free; each member's error on the
 * group it did not see is a cross-validated error of the model. */
#ifndef GONIO_ADAPTIVE_ENSEMBLE_H
#define GONIO_ADAPTIVE_ENSEMBLE_H

#include <stddef.h>

#include "brdf/abc.h"
#include "brdf/angles.h"
#include "fit/fit.h"

#define ENS_GROUPS 5

struct ens {
    struct brdf_abc full;                 /* the fit to every sample */
    struct brdf_abc member[ENS_GROUPS];   /* the fit without group g */
    int ok;                               /* 1 once full and every member are fitted */
    size_t cold_n;                        /* samples at the latest global-start fit */
    double fit_error;                     /* full's log error on the samples */
    double cv_error;                      /* members' log error on their held-out groups */
    double *cv_resid;                     /* sample k's held-out |log residual|, mean
                                             over channels (the member without it) */
    struct fit_sample *scratch;           /* a member's samples */
    size_t cap;
};

void ens_init(struct ens *e);
void ens_free(struct ens *e);

/* Refit to samples[0..n), each fit weighting the samples by their domain
 * share when weighted (fit_options.domain_weights). Returns 0, -ENOMEM, or
 * -GONIO_EFIT when too few samples (or a failed fit) leave no ensemble;
 * e->ok says whether the ensemble is usable. Deterministic for the same
 * samples. */
int ens_fit(struct ens *e, const struct fit_sample *s, size_t n, int weighted);

/* log(1 + f cos theta_i) of params at p, mean over the channels. */
double ens_log_value(const struct brdf_abc *params, const struct brdf_pair *p);

/* The members' deviations from their mean of that value at p, scaled so
 * that the sum of their squares is the jackknife variance: dev[g],
 * g < ENS_GROUPS. The covariance of the predictions at two pairs is the
 * dot product of their deviations. */
void ens_deviations(const struct ens *e, const struct brdf_pair *p, double dev[ENS_GROUPS]);

/* The jackknife variance of that value at p: (G - 1) / G times the sum of
 * the members' squared deviations from their mean. */
double ens_variance(const struct ens *e, const struct brdf_pair *p);

#endif
