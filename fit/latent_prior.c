/* The population prior of latent fits: a Gaussian kernel density over the
 * decoder's training latents (fit/latent_private.h, docs/latent.md).
 *
 * Why a kernel density and not one Gaussian: the training latents are
 * clusters (metals, plastics, paints, fabrics) with empty space between
 * them, and the decoder is only trained at those points. A Gaussian around
 * their mean calls the space between clusters likely; the mixture says
 * "near some real material", which is what six samples cannot tell on
 * their own. Its one parameter, the bandwidth, is set by the data (leave-
 * one-out likelihood of the latents), so a retrained decoder gets its own. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_min.h>

#include "fit/latent_private.h"

static double sqdist(const double *a, const double *b, int n)
{
    double s = 0;
    for (int k = 0; k < n; k++) {
        double u = a[k] - b[k];
        s += u * u;
    }
    return s;
}

/* Mean over latents of log of the leave-one-out kernel density at it
 * (d2: the M x M squared distances). Constant terms are kept that depend
 * on h (-nz log h), so that values for different h compare. */
static double loo_loglik(const double *d2, size_t m, int nz, double h)
{
    double s = 0, inv = 1.0 / (2 * h * h);
    for (size_t a = 0; a < m; a++) {
        double mn = INFINITY;
        for (size_t b = 0; b < m; b++)
            if (b != a && d2[a * m + b] < mn)
                mn = d2[a * m + b];
        double acc = 0;
        for (size_t b = 0; b < m; b++)
            if (b != a)
                acc += exp(-(d2[a * m + b] - mn) * inv);
        s += -mn * inv + log(acc / (double)(m - 1)) - nz * log(h);
    }
    return s / (double)m;
}

struct loo_ctx {
    const double *d2;
    size_t m;
    int nz;
};

/* -loo_loglik at h = e^x: what the minimiser minimises. */
static double neg_loo_loglik(double x, void *p)
{
    const struct loo_ctx *c = p;
    return -loo_loglik(c->d2, c->m, c->nz, exp(x));
}

double latent_prior_bandwidth(const latent_decoder *d)
{
    size_t m = d->n_materials;
    int nz = d->nz;
    if (m < 2)
        return 0;
    double *d2 = malloc(m * m * sizeof *d2);
    if (!d2)
        return 0;
    double rms = 0;
    for (size_t a = 0; a < m; a++)
        for (size_t b = 0; b < m; b++) {
            d2[a * m + b] = sqdist(d->latents + a * (size_t)nz, d->latents + b * (size_t)nz, nz);
            rms += d2[a * m + b];
        }
    rms = sqrt(rms / (double)(m * m));
    if (!(rms > 0) || !isfinite(rms)) {
        free(d2);
        return 0;
    }
    /* The leave-one-out likelihood of a kernel density is unimodal in h for
     * data like these (too small: each point sees no neighbour; too large:
     * all is flat). A coarse scan of log h over [rms/1000, rms] brackets the
     * maximum; GSL's Brent minimiser refines it. */
    struct loo_ctx ctx = {d2, m, nz};
    gsl_function fn = {neg_loo_loglik, &ctx};
    enum { SCAN = 12 };
    double lo = log(rms * 1e-3), hi = log(rms), step = (hi - lo) / (SCAN - 1);
    double fbest = INFINITY;
    int best = 0;
    for (int k = 0; k < SCAN; k++) {
        double f = neg_loo_loglik(lo + k * step, &ctx);
        if (f < fbest) {
            fbest = f;
            best = k;
        }
    }
    double x = lo + best * step;
    double fl = best > 0 ? neg_loo_loglik(x - step, &ctx) : -INFINITY;
    double fr = best < SCAN - 1 ? neg_loo_loglik(x + step, &ctx) : -INFINITY;
    if (fbest < fl && fbest < fr) { /* a bracket, as gsl_min needs */
        gsl_min_fminimizer *s = gsl_min_fminimizer_alloc(gsl_min_fminimizer_brent);
        if (s && gsl_min_fminimizer_set_with_values(s, &fn, x, fbest, x - step, fl, x + step,
                                                    fr) == GSL_SUCCESS) {
            for (int it = 0; it < 100; it++) {
                if (gsl_min_fminimizer_iterate(s) != GSL_SUCCESS)
                    break;
                if (gsl_min_test_interval(gsl_min_fminimizer_x_lower(s),
                                          gsl_min_fminimizer_x_upper(s), 1e-5, 0) == GSL_SUCCESS)
                    break;
            }
            x = gsl_min_fminimizer_x_minimum(s);
        }
        gsl_min_fminimizer_free(s);
    }
    free(d2);
    return exp(x);
}

double latent_prior_nll(const latent_decoder *d, double h, const double *z, double scale,
                        double *gz)
{
    size_t m = d->n_materials;
    int nz = d->nz;
    if (!m || !(h > 0))
        return 0;
    double inv = 1.0 / (2 * h * h), mn = INFINITY;
    /* The distances are recomputed (twice) rather than stored: no allocation
     * per call, and 2 x M x nz operations are small next to one pass of the
     * decoder over the samples. */
    for (size_t k = 0; k < m; k++) {
        double s = sqdist(z, d->latents + k * (size_t)nz, nz);
        if (s < mn)
            mn = s;
    }
    double acc = 0, g[LATENT_MAX_NZ] = {0};
    for (size_t k = 0; k < m; k++) {
        const double *zk = d->latents + k * (size_t)nz;
        double w = exp(-(sqdist(z, zk, nz) - mn) * inv);
        acc += w;
        if (gz)
            for (int j = 0; j < nz; j++)
                g[j] += w * (z[j] - zk[j]);
    }
    if (gz)
        for (int j = 0; j < nz; j++)
            gz[j] += scale * g[j] / (acc * h * h);
    return mn * inv - log(acc / (double)m);
}
