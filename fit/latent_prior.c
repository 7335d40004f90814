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
    /* Golden-section search on log h over [rms/1000, rms]: the leave-one-out
     * likelihood of a kernel density is unimodal in h for data like these
     * (too small: each point sees no neighbour; too large: all is flat). */
    const double g = 0.6180339887498949;
    double lo = log(rms * 1e-3), hi = log(rms);
    double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
    double f1 = loo_loglik(d2, m, nz, exp(x1)), f2 = loo_loglik(d2, m, nz, exp(x2));
    for (int it = 0; it < 60 && hi - lo > 1e-4; it++) {
        if (f1 >= f2) {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - g * (hi - lo);
            f1 = loo_loglik(d2, m, nz, exp(x1));
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + g * (hi - lo);
            f2 = loo_loglik(d2, m, nz, exp(x2));
        }
    }
    free(d2);
    return exp(0.5 * (lo + hi));
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
