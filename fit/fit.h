/* Fitting reflectance models to captured samples.
 *
 * GSL stays inside fit/: this header uses plain doubles and gonio structs.
 * A fit that does not converge is a normal result reported in fit_info,
 * never an abort. */
#ifndef GONIO_FIT_FIT_H
#define GONIO_FIT_FIT_H

#include <stddef.h>

#include "brdf/abc.h"
#include "brdf/angles.h"
#include "common/err.h"
#include "fit/fit_status.h"

/* One measured sample: the geometry and the RGB BRDF (1/sr). */
struct fit_sample {
    struct brdf_pair g;
    double rgb[3];
    /* Standard uncertainty of each value (1/sr, k = 1): 0 or not finite,
     * none. When every usable sample of a fit has all three, the ABC fit
     * weights each residual by its inverse variance (docs/fitting.md
     * "Measurement weights"); otherwise u is ignored. */
    double u[3];
};

enum fit_loss {
    FIT_LOSS_LOG = 0,      /* log(1 + f cos theta_i) residuals: the robust default */
    FIT_LOSS_RELATIVE = 1, /* (fhat - f) / (|f| + 1e-3): relative error per sample */
    FIT_LOSS_COS_L2 = 2,   /* (fhat - f) cos theta_i: plain L2 on the reflected radiance */
};

/* How the starting points of the local solves are found (docs/fitting.md). */
enum fit_global {
    FIT_GLOBAL_GRID = 0, /* 945-node (B, C, eta) grid, best distinct nodes: the default */
    FIT_GLOBAL_DE = 1,   /* seeded differential evolution over (log B, log C, eta) */
};

struct fit_options {
    enum fit_loss loss;
    int max_iter;      /* per local solve */
    int n_starts;      /* local solves started from the best grid nodes (<= 32) */
    unsigned seed;     /* for the subset the starts use above 8000 samples */
    double xtol, gtol; /* MINPACK's step and gradient tests (fit/abc_solve.c) */
    double ftol;       /* stop when the cost fell less than this, relative, in 8 steps */
    const struct brdf_abc *warm_start; /* NULL: global start; else refine from here */
    enum fit_global global; /* start search when warm_start is NULL */
    /* NULL, or one flag per sample given (in their order): 1 when the
     * detector saturated on that reading, so each of its values is a lower
     * bound of the BRDF (the clipped channel's, and the others' too: their
     * true value is at least what was read). Fitted one-sided, as censored
     * data: no residual while the model is above the value
     * (docs/fitting.md "Saturated readings"). */
    const unsigned char *lower_bound;
    /* 1: each sample's squared residuals weighted by its share of the full
     * domain (fit/domain_weights.h), so that the loss estimates the
     * full-domain error rather than the error at the samples: for samples
     * not spread like the domain (an adaptive capture's). 0 (default): all
     * alike. The in-sample and held-out residuals of the status are then
     * weighted means. Fewer than FIT_DOMAIN_WEIGHTS_MIN_SAMPLES usable
     * samples are fitted unweighted (fit_info.domain_weights says). */
    int domain_weights;
    /* 1 (default): the fit status's held-out residual (fit_info.status),
     * five coarse refits; 0 leaves it NaN, for fits whose status nobody
     * reads (the streaming fit's rounds, which hold out samples their own
     * way). */
    int heldout;
    /* Per channel, the relative standard uncertainty shared by all values
     * (k = 1): one error of the whole capture (the reference standard's
     * certificate and shape, the placement), part of each sample's u. Used
     * only by fits weighted by the samples' u: their weights take u without
     * it, and their parameter sds add its effect in quadrature; 0: none. */
    double u_systematic[3];
};

struct fit_options fit_default_options(void);

/* Standard deviations of the fitted parameters in natural units, from the
 * Jacobian at the optimum (covariance s^2 (J^T J)^-1, s^2 the residual
 * variance 2 cost / (residuals - 9); for a prior fit the prior's noise
 * level, fit/abc_prior.h; for a fit weighted by domain share the sandwich
 * s^2 H^-1 (J^T W^2 J) H^-1, H = J^T W J, with the residuals counted as
 * Kish's effective number, docs/fitting.md "Domain weights"; for a fit
 * weighted by the samples' u, (J^T W J)^-1 with no rescale, the sandwich
 * with the domain weights, plus the shared systematic error's effect
 * (fit_options.u_systematic) in quadrature). INFINITY:
 * the data do not determine the parameter (no influence, or clamped at a
 * bound); all NaN: not computed (fewer residuals, or for a weighted fit
 * fewer effective ones, than parameters without a prior). */
struct fit_uncertainty {
    double log_kd[3], log_A[3];
    double log_B, log_C, eta;
    double pred_log; /* mean sd of the predicted log(1 + f cos theta_i) over an in-plane
                        grid (theta_i 0..80, theta_r -80..80): what the uncertainty
                        means for the BRDF, in the design's log-error units */
};

struct fit_info {
    int starts;          /* local solves run */
    int iterations;      /* iterations of the winning solve */
    double cost;         /* final 0.5 * sum of squared residuals */
    int converged;       /* 1 when the winning solve met a tolerance */
    const char *reason;  /* why the winning solve stopped (static string) */
    size_t dropped;      /* samples left out: non-finite value or geometry, below the
                            horizon (cos theta_i or cos theta_o <= 0), 1 + f cos <= 0, or an
                            exact duplicate (same directions and value) of an earlier one */
    struct fit_uncertainty sd; /* parameter standard deviations (see above) */
    double scale;        /* the data were divided by it before the fit (fit_data_scale);
                            cost is in those units */
    struct fit_status status; /* what the fit can know (fit/fit_status.h) */
    int domain_weights;  /* 1: the samples were weighted by their domain share */
    int measurement_weights; /* 1: each value was weighted by 1 / (its residual's sd)^2,
                                from fit_sample.u: sd are then absolute (no residual-
                                variance rescale) and include u_systematic */
};

/* Scale normalisation. The log loss log(1 + f cos theta_i) has a scale of
 * its own (the 1, in 1/sr), so a fit of data multiplied by k is not the
 * fit of the data: counts for 1/sr change the lobe's shape. Fits divide
 * the data by the power of 10^FIT_SCALE_STEP_LOG10 nearest to their median
 * |f cos theta_i| / 10^-1.5, and multiply the fitted amplitudes back:
 * calibrated data (median 3e-5 to 30 1/sr) are fitted as they are, and
 * data off by a factor 10^(6 k) (a detector reporting counts, a table in
 * other units) give the same shape and scaled amplitudes. Within a factor
 * 10^3 the shape still depends on the scale (docs/fitting.md "Scale").
 * Returns the factor (1 for no finite non-zero value) for samples s[idx[k]],
 * k < n (idx NULL: s[0..n)). */
#define FIT_SCALE_STEP_LOG10 6.0
double fit_data_scale(const struct fit_sample *s, const size_t *idx, size_t n);

/* Fit the 9-parameter ABC model to n samples. Positivity and eta > 1 hold by
 * construction; on success out holds finite parameters. Unusable samples are
 * dropped and counted in info->dropped; fewer than 3 usable samples (9
 * residuals for 9 parameters) is a GONIO_EFIT error. opt may be NULL for the
 * defaults; info may be NULL. The result does not depend on the samples'
 * order (fit/sample_order.h). The first call turns GSL's abort-on-error
 * handler off (gsl_set_error_handler_off) for the whole process: a fit
 * that fails is a normal result here, never an abort. See docs/fitting.md. */
int fit_abc(const struct fit_sample *samples, size_t n, const struct fit_options *opt,
            struct brdf_abc *out, struct fit_info *info, struct gonio_err *err);

#endif
