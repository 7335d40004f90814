/* Inside the latent model only: the decoder's fields and the shared
 * forward/backward kernel of training and fitting. */
#ifndef GONIO_FIT_LATENT_PRIVATE_H
#define GONIO_FIT_LATENT_PRIVATE_H

#include <stddef.h>
#include <stdint.h>

#include "fit/latent.h"

/* Outputs above this are clipped (exp(25) - 1 ~ 7e10 1/sr): no material
 * comes near, and it keeps exp finite for any z. */
#define LATENT_O_MAX 25.0

struct latent_decoder {
    int nz, layers, width;
    /* Layer l (0..layers) maps din[l] to dout[l]: W at params + off_w[l]
     * ([in][out] row-major), b at params + off_b[l]. Layer 0's inputs are
     * the 6 encoding values, then z. */
    int din[LATENT_MAX_LAYERS + 1], dout[LATENT_MAX_LAYERS + 1];
    size_t off_w[LATENT_MAX_LAYERS + 1], off_b[LATENT_MAX_LAYERS + 1];
    size_t n_params;
    double *params;
    size_t n_materials;
    char (*names)[LATENT_NAME_MAX];
    double *latents; /* [n_materials][nz] */
    double *mean;    /* [nz] */
    double prior_h;  /* kernel bandwidth of the population prior (latent_prior.c) */
    struct latent_train_options train; /* as trained (from the file header) */
    uint32_t crc;
};

/* A decoder of this shape with zeroed weights and n_materials latents. */
latent_decoder *latent_decoder_alloc(int nz, int layers, int width, size_t n_materials);

/* Recompute the mean latent and the data CRC after the weights change. */
void latent_decoder_refresh(latent_decoder *d);

/* The population prior of fits (latent_prior.c): a Gaussian kernel density
 * over the training latents. latent_prior_bandwidth: the bandwidth that
 * maximises the latents' leave-one-out likelihood (0 with fewer than 2).
 * latent_prior_nll: -log of the density at z (up to a constant; 0 when
 * h <= 0 or no latents); adds scale * its gradient to gz when not NULL. */
double latent_prior_bandwidth(const latent_decoder *d);
double latent_prior_nll(const latent_decoder *d, double h, const double *z, double scale,
                        double *gz);

/* The NBRDF input encoding of a pair. */
void latent_encode(const struct brdf_pair *p, double x[LATENT_NIN]);

/* Forward and backward over n samples of one material with latent z:
 * x[n][6] encodings, c[n] = cos theta_i, t[n][3] = log(1 + f c) targets.
 * Returns the sum over samples and channels of |log(1 + fhat c) - t|,
 * where lower (NULL, or n flags) marks the samples whose targets are lower
 * bounds (saturated readings): no residual while fhat is above them, and
 * weight (NULL: all 1) weighs each sample's residuals.
 * When gw is not NULL, adds scale * d(sum)/d(network parameters) to
 * gw[n_params];
 * when gz is not NULL, adds scale * d(sum)/dz to gz[nz]. */
double latent_net_backprop(const latent_decoder *d, const double *z, size_t n, const double *x,
                           const double *c, const double *t, const unsigned char *lower,
                           const double *weight, double scale, double *gw, double *gz);

/* The raw outputs o (log(1 + f), clipped) at n encodings, into o[3n]. */
void latent_net_forward(const latent_decoder *d, const double *z, size_t n, const double *x,
                        double *o);

#endif
