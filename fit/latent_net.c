/* The decoder's forward and backward passes, one sample at a time so that
 * every activation stays in L1 cache; inner loops run over a layer's
 * outputs, contiguous in [in][out] storage, so the compiler vectorises them.
 *
 * The latent's contribution to the first layer, z W1[6..], is the same for
 * every sample of a material: it is folded into an effective bias once,
 * and its gradients are formed once from the summed first-layer deltas. */
#include <math.h>
#include <string.h>

#include "fit/latent_private.h"

void latent_encode(const struct brdf_pair *p, double x[LATENT_NIN])
{
    double st = sin(p->theta_h), ct = cos(p->theta_h);
    double sd = sin(p->theta_d), cd = cos(p->theta_d);
    x[0] = st;
    x[1] = 0.0;
    x[2] = ct;
    x[3] = sd * cos(p->phi_d);
    x[4] = sd * sin(p->phi_d);
    x[5] = cd;
}

/* b1 + z W1[6..6+nz) */
static void effective_bias(const latent_decoder *d, const double *z, double *b1)
{
    const int w = d->dout[0];
    const double *W = d->params + d->off_w[0];
    memcpy(b1, d->params + d->off_b[0], (size_t)w * sizeof *b1);
    for (int k = 0; k < d->nz; k++) {
        const double *row = W + (size_t)(LATENT_NIN + k) * (size_t)w;
        for (int j = 0; j < w; j++)
            b1[j] += z[k] * row[j];
    }
}

/* Pre-activations of every layer for one sample: h[l][dout[l]]. */
static void forward_one(const latent_decoder *d, const double *b1, const double *x,
                        double h[][LATENT_MAX_WIDTH], double a[][LATENT_MAX_WIDTH])
{
    const double *P = d->params;
    int w = d->dout[0];
    for (int j = 0; j < w; j++)
        h[0][j] = b1[j];
    for (int i = 0; i < LATENT_NIN; i++) {
        const double *row = P + d->off_w[0] + (size_t)i * (size_t)w;
        double xi = x[i];
        for (int j = 0; j < w; j++)
            h[0][j] += xi * row[j];
    }
    for (int j = 0; j < w; j++)
        a[0][j] = h[0][j] > 0 ? h[0][j] : 0;
    for (int l = 1; l <= d->layers; l++) {
        int in = d->din[l], out = d->dout[l];
        const double *W = P + d->off_w[l];
        memcpy(h[l], P + d->off_b[l], (size_t)out * sizeof(double));
        for (int i = 0; i < in; i++) {
            double ai = a[l - 1][i];
            if (ai == 0)
                continue; /* ReLU zeros: about half the units */
            const double *row = W + (size_t)i * (size_t)out;
            for (int j = 0; j < out; j++)
                h[l][j] += ai * row[j];
        }
        if (l < d->layers)
            for (int j = 0; j < out; j++)
                a[l][j] = h[l][j] > 0 ? h[l][j] : 0;
    }
}

void latent_net_forward(const latent_decoder *d, const double *z, size_t n, const double *x,
                        double *o)
{
    double b1[LATENT_MAX_WIDTH];
    double h[LATENT_MAX_LAYERS + 1][LATENT_MAX_WIDTH], a[LATENT_MAX_LAYERS + 1][LATENT_MAX_WIDTH];
    effective_bias(d, z, b1);
    for (size_t s = 0; s < n; s++) {
        forward_one(d, b1, x + LATENT_NIN * s, h, a);
        for (int c = 0; c < LATENT_NOUT; c++) {
            double v = h[d->layers][c];
            o[LATENT_NOUT * s + c] = v < LATENT_O_MAX ? v : LATENT_O_MAX;
        }
    }
}

double latent_net_backprop(const latent_decoder *d, const double *z, size_t n, const double *x,
                           const double *c, const double *t, const unsigned char *lower,
                           const double *weight, double scale, double *gw, double *gz)
{
    const int L = d->layers;
    const double *P = d->params;
    double b1[LATENT_MAX_WIDTH], sum_d1[LATENT_MAX_WIDTH] = {0};
    double h[LATENT_MAX_LAYERS + 1][LATENT_MAX_WIDTH], a[LATENT_MAX_LAYERS + 1][LATENT_MAX_WIDTH];
    double dh[LATENT_MAX_WIDTH], da[LATENT_MAX_WIDTH];
    double loss = 0;
    effective_bias(d, z, b1);
    for (size_t s = 0; s < n; s++) {
        const double *xs = x + LATENT_NIN * s;
        forward_one(d, b1, xs, h, a);
        /* Output: r = log(1 + (e^o - 1) c) - t; d|r|/do = sign(r) c e^o / (1 + (e^o - 1) c).
         * 1 + (e^o - 1) c >= min(1, e^o) > 0 for c in [0, 1], so training
         * needs no clamp at f = 0 (the clamp would stop the gradient). */
        double cs = c[s], ws = weight ? weight[s] : 1.0;
        for (int k = 0; k < LATENT_NOUT; k++) {
            double o = h[L][k];
            if (o > LATENT_O_MAX) {
                o = LATENT_O_MAX;
                dh[k] = 0;
            } else {
                dh[k] = 1;
            }
            double eo = exp(o);
            double den = 1 + (eo - 1) * cs;
            double r = log(den) - t[LATENT_NOUT * s + k];
            if (lower && lower[s] && r > 0)
                r = 0; /* above a lower bound: censored */
            loss += ws * fabs(r);
            double sg = r > 0 ? 1.0 : (r < 0 ? -1.0 : 0.0);
            dh[k] *= scale * ws * sg * cs * eo / den;
        }
        /* Backward through layers L..1; dh holds dLoss/dh[l]. */
        for (int l = L; l >= 1; l--) {
            int in = d->din[l], out = d->dout[l];
            const double *W = P + d->off_w[l];
            if (gw) {
                double *gW = gw + d->off_w[l], *gb = gw + d->off_b[l];
                for (int j = 0; j < out; j++)
                    gb[j] += dh[j];
                for (int i = 0; i < in; i++) {
                    double ai = a[l - 1][i];
                    if (ai == 0)
                        continue;
                    double *grow = gW + (size_t)i * (size_t)out;
                    for (int j = 0; j < out; j++)
                        grow[j] += ai * dh[j];
                }
            }
            for (int i = 0; i < in; i++) {
                if (h[l - 1][i] <= 0) {
                    da[i] = 0;
                    continue;
                }
                const double *row = W + (size_t)i * (size_t)out;
                double acc = 0;
                for (int j = 0; j < out; j++)
                    acc += row[j] * dh[j];
                da[i] = acc;
            }
            memcpy(dh, da, (size_t)in * sizeof *dh);
        }
        /* First layer: dh is dLoss/dh[0]. */
        int w = d->dout[0];
        if (gw) {
            double *gW = gw + d->off_w[0];
            for (int i = 0; i < LATENT_NIN; i++) {
                double xi = xs[i];
                if (xi == 0)
                    continue;
                double *grow = gW + (size_t)i * (size_t)w;
                for (int j = 0; j < w; j++)
                    grow[j] += xi * dh[j];
            }
        }
        for (int j = 0; j < w; j++)
            sum_d1[j] += dh[j];
    }
    int w = d->dout[0];
    const double *Wz = P + d->off_w[0] + (size_t)LATENT_NIN * (size_t)w;
    if (gw) {
        double *gb = gw + d->off_b[0], *gWz = gw + d->off_w[0] + (size_t)LATENT_NIN * (size_t)w;
        for (int j = 0; j < w; j++)
            gb[j] += sum_d1[j];
        for (int k = 0; k < d->nz; k++)
            for (int j = 0; j < w; j++)
                gWz[(size_t)k * (size_t)w + j] += z[k] * sum_d1[j];
    }
    if (gz)
        for (int k = 0; k < d->nz; k++) {
            double acc = 0;
            for (int j = 0; j < w; j++)
                acc += Wz[(size_t)k * (size_t)w + j] * sum_d1[j];
            gz[k] += acc;
        }
    return loss;
}
