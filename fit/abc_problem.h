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

/* Samples reduced to what the residuals need (structure of arrays). */
struct abc_problem {
    size_t n;       /* samples; residuals are 3n, ordered sample-major */
    double *x;      /* 1 - n.h */
    double *vh;     /* v.h */
    double *gterm;  /* G / ((n.l)(n.v)) */
    double *cosi;   /* n.l: the log loss weight */
    double *f;      /* measured RGB, 3n */
    double *y;      /* log(1 + f cos theta_i), 3n */
};

/* Build from validated samples (finite, above the horizon, 1 + f cos > 0).
 * idx (may be NULL) selects which samples, in order. */
int abc_problem_init(struct abc_problem *pb, const struct fit_sample *s, const size_t *idx,
                     size_t n);
void abc_problem_free(struct abc_problem *pb);

void abc_theta_to_params(const double theta[ABC_NPAR], struct brdf_abc *p);
void abc_params_to_theta(const struct brdf_abc *p, double theta[ABC_NPAR]);

/* Residuals r[3n] = log(1 + fhat cos) - log(1 + f cos) and, when J is not
 * NULL, the Jacobian dr/dtheta, row-major 3n x 9. r may be NULL when only
 * the Jacobian is wanted. */
void abc_problem_eval(const struct abc_problem *pb, const double theta[ABC_NPAR], double *r,
                      double *J);

/* 0.5 * sum of squared residuals. */
double abc_problem_cost(const struct abc_problem *pb, const double theta[ABC_NPAR]);

/* Start search (abc_start.c): score a (B, C, eta) grid with kd and A per
 * channel solved by weighted non-negative least squares, and write up to
 * max_starts distinct starting points, best first. Returns the count. */
int abc_grid_starts(const struct abc_problem *pb, int max_starts, double *starts);

#endif
