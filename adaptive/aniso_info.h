/* The adaptive policy's picture of an anisotropic material (model
 * aniso-ggx, docs/adaptive.md, "Sample azimuths"): the aniso-ggx fit to
 * the samples so far and, linearised there, the Gaussian posterior of its
 * nine parameters, so that a candidate pair on the turned sample is worth
 * what its reading would take off the posterior variance over the full
 * domain (the turned domain of the error, brdf/domain.h), and the fit's
 * full-domain error is predicted from what the parameters leave open.
 *
 * The value a reading gives is v = log(1 + f cos theta_i), mean over the
 * channels, with noise of variance s2 (the fit's own residual, at least
 * ANISO_INFO_NOISE_FLOOR squared); the prior is broad and independent per
 * parameter (ANISO_INFO_PRIOR_SD in the fit's coordinates: logs of the
 * scales and roughnesses, the orientation in radians), so one slice of the
 * sample, which leaves ax, ay and phi free, keeps their prior spread. */
#ifndef GONIO_ADAPTIVE_ANISO_INFO_H
#define GONIO_ADAPTIVE_ANISO_INFO_H

#include <stddef.h>

#include "brdf/angles.h"
#include "fit/fit.h"

#define ANISO_INFO_NPAR 9
#define ANISO_INFO_PRIOR_SD 1.0
#define ANISO_INFO_NOISE_FLOOR 0.002

struct aniso_info {
    int ok;                    /* 1 once fitted */
    size_t cold_n;             /* samples at the latest fit from the grid of starts */
    double x[ANISO_INFO_NPAR]; /* the fit (fit_aniso_ggx_solve's coordinates) */
    double s2;                 /* the noise variance of v */
    double cov[ANISO_INFO_NPAR][ANISO_INFO_NPAR]; /* the posterior covariance */
    /* cov (mean over the domain of g g^T) cov, g = dv/dx at a node
     * (aniso_info_domain) */
    double dom[ANISO_INFO_NPAR][ANISO_INFO_NPAR];
};

void aniso_info_init(struct aniso_info *ai);

/* Refit to s[0..n) (sample geometries on the turned sample) and update the
 * posterior: from the grid of starts whenever n has doubled since the last
 * such fit, else warm from the previous one. 0, -ENOMEM, or -GONIO_EFIT
 * (ai->ok 0) when the fit fails. */
int aniso_info_update(struct aniso_info *ai, const struct fit_sample *s, size_t n);

/* Over the n pairs of a domain (on the turned sample): fill ai->dom and
 * return the mean posterior sd of v there. */
double aniso_info_domain(struct aniso_info *ai, const struct brdf_pair *pairs, size_t n);

/* The expected reduction of the mean posterior variance of v over that
 * domain if p were read (Cohn's ALC, as the ABC ensemble's):
 * g^T dom g / (s2 + var(p)). */
double aniso_info_alc(const struct aniso_info *ai, const struct brdf_pair *p);

#endif
