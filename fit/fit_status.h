/* How a fit ended, in one vocabulary every model reports (docs/fitting.md
 * "Fit status"), with the figures behind the verdict.
 *
 * A fit can end with parameters and still not know them. The findings:
 *   not-converged    the solver or trainer stopped at its iteration or
 *                    epoch limit, not at its stopping rule
 *   underdetermined  fewer distinct geometries than free parameters, or a
 *                    data Jacobian of lower rank: the data cannot pick the
 *                    parameters (a prior, a start or chance did)
 *   poor-fit         the model's residual on held-out samples (or on the
 *                    samples it was fitted to, when that is larger: a
 *                    model that misses what it was shown) is far above
 *                    what the noise explains
 *   at-bound         parameters ended on a bound of the fitter (named)
 *   ill-conditioned  the condition number of J^T J (unit columns) is above
 *                    FIT_STATUS_COND_MAX
 *   peak-unbounded   the largest reading is a lower bound (saturated, fitted
 *                    censored) and the model exceeds a lower bound by more
 *                    than FIT_STATUS_PEAK_FACTOR: its peak comes from the
 *                    shoulders or a prior, no reading bounds it from above
 *                    (the ABC fits; docs/fitting.md "Saturated readings")
 * A fit with none of them is "converged". The status a line shows is the
 * first finding in the order above; every finding is kept. */
#ifndef GONIO_FIT_FIT_STATUS_H
#define GONIO_FIT_FIT_STATUS_H

#include <stddef.h>

enum fit_status_code {
    FIT_STATUS_CONVERGED = 0,
    FIT_STATUS_NOT_CONVERGED,
    FIT_STATUS_UNDERDETERMINED,
    FIT_STATUS_POOR_FIT,
    FIT_STATUS_AT_BOUND,
    FIT_STATUS_ILL_CONDITIONED,
    FIT_STATUS_PEAK_UNBOUNDED,
};

/* cond(J^T J) of the free parameters' columns scaled to unit length above
 * this: cond(J) 1e6, so the normal equations lose 12 of double's 16 digits
 * and a change of 1e-4 relative in the data can move the parameters by
 * 100 times their size. */
#define FIT_STATUS_COND_MAX 1e12

/* The noise level, in RMS log(1 + f cos theta_i), that held-out residuals
 * are judged against: the lab scene's detector noise (shot noise at 1e4 to
 * 1e5 electrons, 0.5 % drift; docs/scenes.md) is near 1 %, and 0.05 leaves
 * room for what a 9-parameter model of a measured material cannot hold:
 * the ABC DS1 fits of the ten study materials (ideal scene) hold out at
 * 0.013 to 0.099 RMS, but tungsten-carbide at 0.171, its index of
 * refraction beyond the model's bound (docs/fitting.md "Fit status"). */
#define FIT_STATUS_NOISE_LOG 0.05
/* poor-fit: held-out RMS above this many times the noise level */
#define FIT_STATUS_POOR_FACTOR 3.0
/* peak-unbounded: the model above a censored reading by more than this
 * factor. The lab detector clips the metals' in-plane ridge by a factor 2.6
 * at most, so a model 10 times above its clip is not read from the data.
 * Measured on the study's lab captures, ABC censored: lab DS1 brass,
 * tungsten-carbide and specular-black-phenolic 24x, 38x and 13x (the
 * overshooting lobes, relative RMSE up to 2.5), blue-acrylic 9.5x;
 * abc-prior on DS3 tungsten-carbide 12x (relative RMSE 13). */
#define FIT_STATUS_PEAK_FACTOR 10.0

struct fit_status {
    unsigned findings;   /* 1u << code for each finding; 0: converged */
    size_t geometries;   /* distinct geometries among the samples used */
    int params;          /* free parameters (not at a bound; -1: not counted, the networks) */
    int rank;            /* numerical rank of the data Jacobian on them (-1: not computed) */
    double cond;         /* cond(J^T J), unit columns (NAN: not computed) */
    char at_bound[64];   /* the parameters at a bound, comma-separated, or "" */
    double insample;     /* RMS log residual on the samples fitted (NAN: none) */
    double heldout;      /* RMS log residual on held-out samples (NAN: none held out) */
};

/* An empty status: no findings, figures unknown (NAN, -1). */
struct fit_status fit_status_init(void);

/* Add the findings the figures imply: underdetermined (geometries or rank
 * below params), ill-conditioned, at-bound (at_bound not empty), poor-fit
 * (heldout or insample above FIT_STATUS_POOR_FACTOR * FIT_STATUS_NOISE_LOG;
 * fmax ignores a NAN). A limit is
 * the caller's: st->findings |= 1u << FIT_STATUS_NOT_CONVERGED. */
void fit_status_decide(struct fit_status *st);

/* The status to show: the first finding in severity order, or converged. */
enum fit_status_code fit_status_code(const struct fit_status *st);

/* "converged", "not-converged", "underdetermined", "poor-fit", "at-bound",
 * "ill-conditioned", "peak-unbounded". */
const char *fit_status_name(enum fit_status_code c);

/* Every finding, comma-separated in severity order ("converged" when none),
 * into buf. */
void fit_status_findings(const struct fit_status *st, char *buf, size_t len);

/* One line for people: "at-bound (eta); 41 geometries, rank 9 of 9 free,
 * condition 3.1e+05, held-out 0.021 vs in-sample 0.019 RMS log". */
void fit_status_line(const struct fit_status *st, char *buf, size_t len);

/* Distinct geometries: the number of distinct pairs (p[i][0], p[i][1]) on
 * a grid of 1e-9 (rad or degrees), non-finite pairs left out. Rounds
 * and compacts p in place (and may reorder it). RGB fits
 * count (theta_h, theta_d), the angles an isotropic model mostly depends
 * on; the spectral MLP (theta_i, theta_r). */
size_t fit_status_distinct_pairs(double (*p)[2], size_t n);

struct fit_sample;
/* fit_status_distinct_pairs over the (theta_h, theta_d) of samples s[idx[k]],
 * k < n (idx NULL: s[0..n)). Returns (size_t)-1 when out of memory. */
size_t fit_status_geometries(const struct fit_sample *s, const size_t *idx, size_t n);

struct fit_model_file;
/* The status and its figures as model file keys (status, findings,
 * geometries, params, rank, condition, at_bound, rms_log_insample,
 * rms_log_heldout). Returns 0 or a negative code. */
int fit_status_file_keys(struct fit_model_file *f, const struct fit_status *st);

#endif
