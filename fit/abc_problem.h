/* Internal to fit/: the ABC least-squares problem in the fitter's own
 * parametrisation, shared by the start search, the GSL solve and the tests
 * (which check the analytic Jacobian against finite differences).
 *
 * Parameters theta[9]:
 *   theta[0..2] = log kd      theta[3..5] = log A
 *   theta[6]    = log (B C)   theta[7]    = log C
 *   theta[8]    = e, eta = 1 + (ABC_ETA_MAX - 1) * sigmoid(e)
 * so kd, A, B, C > 0 and 1 < eta < ABC_ETA_MAX by construction. Each log
 * (log B = theta[6] - theta[7]) is clamped to a range where exp() is finite
 * and the model is well scaled; beyond a clamp the parameter stops moving
 * (zero derivative).
 *
 * Why log(B C) and not log B: for B x << 1 the lobe is exp(-B C x), so broad
 * lobes lie in a long curved valley B -> 0, C -> infinity at fixed B C. In
 * (log B, log C) that valley is diagonal and LM crawls along it for hundreds
 * of iterations (gold-metallic-paint); with B C as a coordinate the valley
 * is one axis where the function flattens, and the solve stops. */
#ifndef GONIO_FIT_ABC_PROBLEM_H
#define GONIO_FIT_ABC_PROBLEM_H

#include <stddef.h>

#include "brdf/abc.h"
#include "fit/fit.h"

#define ABC_NPAR 9

/* Upper bound on eta: the guard against the eta -> infinity, kd -> 0 basin
 * a single start falls into on metals (beyond ~20 F is flat in v.h anyway). */
#define ABC_ETA_MAX 40.0

#define ABC_LOGKD_MIN (-30.0)
#define ABC_LOGKD_MAX 5.0
#define ABC_LOGA_MIN (-30.0)
#define ABC_LOGA_MAX 25.0
#define ABC_LOGB_MIN (-7.0)
#define ABC_LOGB_MAX 19.0  /* B up to ~1.8e8 */
#define ABC_LOGC_MIN (-7.0)
#define ABC_LOGC_MAX 3.5   /* C up to ~33 */
#define ABC_E_MIN (-30.0)
#define ABC_E_MAX 30.0

/* A Gaussian prior on theta as extra residual rows (MAP): the rows are
 * W (theta - mean), so their cost is 0.5 |W (theta - mean)|^2. With W =
 * sigma L^-1 (Sigma = L L^T) that is sigma^2 times the negative log prior
 * for data residuals of noise sigma (fit/abc_prior.h). */
struct abc_prior_term {
    double mean[ABC_NPAR];
    double W[ABC_NPAR * ABC_NPAR]; /* row-major */
    /* Lobe shapes (B, C, eta) of the population's members: each, with kd
     * and A solved linearly, is scored by the MAP cost and the best
     * ABC_PRIOR_SHAPE_STARTS become extra starts. n_shapes may be 0. */
    const double (*shapes)[3];
    size_t n_shapes;
};

#define ABC_PRIOR_SHAPE_STARTS 3

/* Samples reduced to what the residuals need (structure of arrays). */
struct abc_problem {
    size_t n;       /* samples; data residuals are 3n, ordered sample-major */
    double *x;      /* 1 - n.h */
    double *vh;     /* v.h */
    double *gterm;  /* G / ((n.l)(n.v)) */
    double *cosi;   /* n.l: the log loss weight */
    double *f;      /* measured RGB, 3n */
    double *y;      /* log(1 + f cos theta_i), 3n (the grid scores with it whatever the loss) */
    double *iy;     /* 1 / (1 + f cos theta_i), 3n channel-major (iy[c n + k]):
                     * abc_problem_resid's log((1 + fhat cos) iy) */
    /* Distinct values of x and v.h (an in-plane plan repeats them: DS1's 912
     * samples have 397 and 297), so that the lobe and the Fresnel term are
     * evaluated once per value: ux[nux], uvh[nuv], and per sample its
     * index xi[k], vi[k]. */
    size_t nux, nuv;
    double *ux, *uvh;
    unsigned *xi, *vi;
    /* lower[k] 1: sample k's values are lower bounds (fit_options.lower_bound):
     * its residuals count only while negative (the model below the value).
     * NULL when no sample is (abc_problem_set_lower). */
    unsigned char *lower;
    /* sw[k]: the square root of sample k's weight (fit_options.domain_weights),
     * multiplying its residuals and their slopes. NULL: all 1
     * (abc_problem_set_weights). */
    double *sw;
    /* mw[3k + c]: the square root of value (k, c)'s measurement weight, 1 /
     * the sd of its residual under the fit's loss (abc_problem_set_sigma),
     * multiplying its residual and slopes on top of sw. NULL: all 1. */
    double *mw;
    enum fit_loss loss; /* FIT_LOSS_LOG after init; abc_problem_set_loss changes it */
    double *s;      /* linear losses: r = (fhat - f) s, 3n (NULL for the log loss) */
    const struct abc_prior_term *prior; /* NULL: no prior rows */
};

/* Relative loss: r = (fhat - f) / (|f| + FIT_REL_FLOOR); the floor (1/sr)
 * keeps black samples from dominating (a tenth of a dark diffuse level). */
#define FIT_REL_FLOOR 1e-3

/* Build from validated samples (finite, above the horizon, 1 + f cos > 0).
 * idx (may be NULL) selects which samples, in order. */
int abc_problem_init(struct abc_problem *pb, const struct fit_sample *s, const size_t *idx,
                     size_t n);
void abc_problem_free(struct abc_problem *pb);

/* The problem abc_problem_init would build from src's samples rows[k],
 * k < n (positions in src), without recomputing their geometry: the
 * held-out folds' problems. Lower bounds, weights, loss and prior are
 * left to the setters, as after abc_problem_init. */
int abc_problem_subset(struct abc_problem *pb, const struct abc_problem *src, const size_t *rows,
                       size_t n);

/* Mark the samples whose values are lower bounds: flags[idx[k]] (idx as
 * given to abc_problem_init; flags NULL: none). Returns 0, -1 on no memory. */
int abc_problem_set_lower(struct abc_problem *pb, const unsigned char *flags, const size_t *idx);

/* Weigh the samples: w[idx[k]] (idx as given to abc_problem_init; w NULL:
 * none), each >= 0, multiplies sample k's squared residuals. Returns 0, -1
 * on no memory. */
int abc_problem_set_weights(struct abc_problem *pb, const double *w, const size_t *idx);

/* Weigh each value by the inverse variance of its residual: u[3 idx[k] + c]
 * is the standard uncertainty (in the problem's units) of sample k's value
 * c (idx as given to abc_problem_init; u NULL: none), carried through the
 * loss's residual to first order: mw = 1 / (u |dr/df|), dr/df = cos / (1 +
 * f cos) for the log loss, s for the linear ones. Set after the loss.
 * Returns 0, -1 on no memory. */
int abc_problem_set_sigma(struct abc_problem *pb, const double *u, const size_t *idx);

/* The square root of value (k, c)'s whole weight: sw[k] mw[3k + c]. */
static inline double abc_row_weight(const struct abc_problem *pb, size_t k, int c)
{
    return (pb->sw ? pb->sw[k] : 1.0) * (pb->mw ? pb->mw[3 * k + (size_t)c] : 1.0);
}

/* Switch the data residuals to another loss (fit/fit.h enum fit_loss).
 * Returns 0, or -1 for an unknown loss or no memory. */
int abc_problem_set_loss(struct abc_problem *pb, enum fit_loss loss);

/* Residual rows: 3n data rows, then ABC_NPAR prior rows when pb->prior. */
size_t abc_problem_nres(const struct abc_problem *pb);

void abc_theta_to_params(const double theta[ABC_NPAR], struct brdf_abc *p);
void abc_params_to_theta(const struct brdf_abc *p, double theta[ABC_NPAR]);

/* Residuals r[nres] (log loss: log(1 + fhat cos) - log(1 + f cos); the
 * linear losses (fhat - f) s; each times its sample's sw) and, when J is not NULL, the Jacobian
 * dr/dtheta, row-major nres x 9. r may be NULL when only the Jacobian is
 * wanted. nres = abc_problem_nres(pb). */
void abc_problem_eval(const struct abc_problem *pb, const double theta[ABC_NPAR], double *r,
                      double *J);

/* The solver's fused path. GSL's trust region evaluates the Jacobian only
 * at an accepted trial point, right after its residuals: so the residual
 * pass leaves in the cache what the Jacobian needs (the specular shape and
 * its derivatives per sample, dr/dfhat per row), and the normal equations
 * are then a pass of multiply-adds without a transcendental. The Jacobian
 * is never stored: each data row has 5 non-zeros (kd and A of its channel,
 * B C, C, eta), and J^T J is accumulated from per-channel sums. */
struct abc_cache {
    double theta[ABC_NPAR]; /* where spec and w were computed */
    int valid;
    /* Structure of arrays, contiguous over the samples k (the passes
     * vectorise): */
    double *spec;           /* 4n: S, and dS/dtheta6..8 without A: spec[j n + k] */
    double *w;              /* 3n: dr/dfhat per data row, channel-major: w[c n + k] */
    double *q;              /* nres: the residuals at theta, data rows channel-major
                             * (q[c n + k]), then the prior rows */
    double *lobe;           /* 3 nux: D, dD/dB, dD/dC per distinct x (lobe[j nux + i]) */
    double *fres;           /* 2 nuv: F, dF/deta per distinct v.h (fres[j nuv + i]) */
};

int abc_cache_init(struct abc_cache *c, const struct abc_problem *pb);
void abc_cache_free(struct abc_cache *c);

/* Residuals r[nres] (NULL: only the cache and the cost) at theta, the same
 * values as abc_problem_eval to rounding (the log loss as log((1 + fhat cos)
 * / (1 + f cos)): one log, not a log1p, per row). Fills the cache. Returns
 * 0.5 sum r^2. */
double abc_problem_resid(const struct abc_problem *pb, const double th[ABC_NPAR], double *r,
                         struct abc_cache *c);

/* At theta (from the cache when it holds theta): v = J^T u (trans, u of
 * nres, v of 9; u NULL: the residuals at theta, i.e. the gradient) or
 * v = J u (!trans, u of 9, v of nres) when v is not NULL, and J^T J
 * (9 x 9, row-major, both triangles) when JTJ is not NULL. */
void abc_problem_normal(const struct abc_problem *pb, const double th[ABC_NPAR], int trans,
                        const double *u, double *v, double *JTJ, struct abc_cache *c);

/* The non-zero block of channel ch's data rows of J at theta (the cache
 * must hold theta): Jc[5k + j], k < n, for the columns ch, 3 + ch, 6, 7, 8. */
void abc_problem_jblock(const struct abc_problem *pb, const double th[ABC_NPAR],
                        const struct abc_cache *c, int ch, double *Jc);

/* 0.5 * sum of squared residuals (prior rows included). */
double abc_problem_cost(const struct abc_problem *pb, const double theta[ABC_NPAR]);

/* Start search (abc_start.c): score a (B, C, eta) grid with kd and A per
 * channel solved by weighted non-negative least squares, and write up to
 * max_starts distinct starting points, best first. Returns the count. */
int abc_grid_starts(const struct abc_problem *pb, int max_starts, double *starts);

/* Score of one (B, C, eta): kd and A per channel by the weighted
 * non-negative linear solve of abc_grid_starts, then the true log loss
 * (sum of squares, each times its sample's weight sw^2). spec[n] is scratch. Returns INFINITY if not finite. */
double abc_linear_score(const struct abc_problem *pb, double B, double C, double eta,
                        double kd[3], double A[3], double *spec);

/* Differential-evolution start search (abc_global.c): the same linear
 * solve for kd and A inside, a seeded search over (log B, log C, eta)
 * instead of the grid. Same contract as abc_grid_starts. */
int abc_de_starts(const struct abc_problem *pb, unsigned seed, int max_starts, double *starts);

/* A square root of J^T J at theta (abc_status.c): rows K (nk x 9,
 * row-major; room for 15 + ABC_NPAR rows) with K^T K = J^T J (the prior's
 * rows included when pb->prior), and cn[j] > 0 exactly when J's column j is
 * not zero. Returns nk, 0 on no memory. */
size_t abc_jacobian_root(const struct abc_problem *pb, const double th[ABC_NPAR], double *K,
                         double cn[ABC_NPAR]);

struct fit_status;
/* The status figures of a fit at theta (fit/fit_status.h): the parameters
 * on a bound (at_bound; kd or A at their lower clamp are absent terms,
 * neither free nor named), params (the free ones), and the rank and
 * condition number of the data rows of J on the free columns scaled to
 * unit length. K: the first nk rows of abc_jacobian_root at theta, its
 * data rows (without a prior's); overwritten. Findings are left to
 * fit_status_decide. */
void abc_status_figures(const double th[ABC_NPAR], double *K, size_t nk, struct fit_status *st);

/* fit_abc with an optional prior (NULL: fit_abc itself). prior_sigma is the
 * noise level the prior rows assume, used for the posterior covariance. */
int abc_fit_run(const struct fit_sample *samples, size_t n, const struct fit_options *opt,
                const struct abc_prior_term *prior, double prior_sigma, struct brdf_abc *out,
                struct fit_info *info, struct gonio_err *err);

#endif
