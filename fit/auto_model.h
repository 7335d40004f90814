/* `--model auto` (fit/models.h): choose the model by K-fold cross-validation
 * on the captured samples, then fit the chosen one to all of them.
 *
 * The candidates are the registry models that predict out of plane (abc,
 * abc-prior, latent; not the in-plane MLP), and aniso-ggx when the samples
 * were taken with the sample turned (a plan's sample_azimuths: an incidence
 * off the sample's x-z plane), so that an anisotropic material captured at
 * a few azimuths gets the anisotropic model when it predicts best. A
 * capture's premise checks (fit_data.auto_evidence) narrow the candidates
 * and overrule the figures as fit/auto_evidence.h says. The samples are grouped by
 * geometry, (theta_h, theta_d, phi_d mod pi) on a 1e-9 rad grid, so that a
 * repeated pair and its reciprocal (phi_d + pi) are held out together: a
 * reciprocal model predicts a held-out sample from its twin in the
 * training set, which would measure nothing. The groups are dealt to
 * FIT_AUTO_FOLDS folds after a seeded shuffle. A candidate's CV error is
 * the mean |log(1 + fhat cos ti) - log(1 + f cos ti)| over every held-out
 * sample and channel (the headline log error of brdf/metrics.h; one-sided
 * for a saturated reading, which is a lower bound); with
 * fit_data.domain_weights each held-out sample counts by its share of the
 * domain (fit/domain_weights.h, over all the samples), as in the weighted
 * candidates' own losses. The lowest wins; a tie goes to the earlier
 * candidate. docs/model-choice.md "auto" says why K = 5.
 *
 * The file written is the chosen model's own (kind abc or latent), so
 * reading it needs nothing new; it carries the choice as keys `auto` (the
 * line of the report note) and `auto_cv_NAME` per candidate. The report's
 * fit status is the chosen model's with its held-out figure replaced by the
 * RMS of its cross-validation residuals (poor-fit decided on that), in the
 * report and in the file's status keys.
 *
 * Saturated readings: each candidate takes them as its own registry row
 * says (fit_model_censors with the default): abc and abc-prior clipped,
 * latent censored. The auto row censors, so its callers pass the flags
 * unless `--saturated clipped` clips them for every model. */
#ifndef GONIO_FIT_AUTO_MODEL_H
#define GONIO_FIT_AUTO_MODEL_H

#include <stddef.h>

#include "fit/auto_evidence.h"
#include "fit/models.h"

#define FIT_AUTO_FOLDS 5
/* Fewer distinct geometries than this is refused: every training set keeps
 * at least FIT_AUTO_FOLDS - 1 of FIT_AUTO_FOLDS + 1 geometries (4 of 6,
 * DS4's six pairs: 12 residuals for abc's 9 parameters) and every fold
 * holds out at least one. */
#define FIT_AUTO_MIN_GEOMETRIES (FIT_AUTO_FOLDS + 1)

struct fit_auto_cv {
    size_t n;                  /* candidates */
    const char *model[FIT_AUTO_MAX_CANDIDATES];
    double cv[FIT_AUTO_MAX_CANDIDATES];  /* CV log error; INFINITY: the candidate failed */
    double cv_rms[FIT_AUTO_MAX_CANDIDATES]; /* RMS of the same held-out residuals */
    char failed[FIT_AUTO_MAX_CANDIDATES][160]; /* why, or "" */
    size_t chosen;             /* the lowest cv, after the checks' evidence (fit_auto_rank) */
    char why[FIT_AUTO_WHY_MAX]; /* what the checks' evidence decided, "" when nothing */
    size_t geometries;         /* distinct geometries (groups) */
};

/* The cross-validation alone (what fit_auto_model_fit decides with).
 * Deterministic for opt->seed. Fewer than FIT_AUTO_MIN_GEOMETRIES
 * distinct geometries, or every candidate failing, is a GONIO_EFIT error
 * saying so. */
int fit_auto_cross_validate(const struct fit_data *data, const struct fit_model_options *opt,
                            struct fit_auto_cv *out, struct gonio_err *err);

/* "auto: abc cv 0.0213, abc-prior cv 0.0215, latent cv 0.0347 -> abc (5 folds
 * over 632 geometries, seed 1)" into buf. */
void fit_auto_line(const struct fit_auto_cv *cv, unsigned long long seed, char *buf, size_t len);

int fit_auto_model_fit(const struct fit_data *data, const struct fit_model_options *opt,
                       struct fit_model_file **out, struct fit_model_report *rep,
                       struct gonio_err *err);

#endif
