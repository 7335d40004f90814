/* Fitting a material's latent with the decoder frozen.
 *
 * The objective is the training objective of one material: mean |log(1 +
 * fhat cos ti) - log(1 + f cos ti)| (weighted by the samples' domain
 * shares when latent_fit_options.domain_weights) + lambda_z mean(z^2), so a
 * fitted z is what training would have given the material (MAP under the latent prior
 * the decoder was trained with), plus the population prior of
 * latent_prior.c with the weight Bayes gives it for n samples (b / 3n):
 * with six samples many z fit the data equally well, and the prior picks
 * those near real materials. It is minimised by Adam on z, full batch,
 * from the training latents that fit the samples best at the start: the
 * L1 objective is not smooth (ReLU kinks, |r|) and Gauss-Newton on it would
 * have to fall back to least squares, which lets a few bad specular samples
 * pull z; with dim(z) ~ 12 an Adam iteration costs one backward pass. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/domain.h"
#include "fit/domain_weights.h"
#include "fit/latent_private.h"
#include "fit/sample_order.h"

#define LF_PI 3.14159265358979323846

struct latent_fit_options latent_fit_default_options(void)
{
    return (struct latent_fit_options){
        .max_iter = 300,
        .weighted_iter = 1000,
        .n_starts = 2,
        .weighted_starts = 4,
        .max_samples = 4096,
        .lr = 0.05,
        .lambda_z = -1,
        .prior_scale = LATENT_PRIOR_SCALE,
        .bandwidth = 0,
        .seed = 1,
    };
}

/* The priors of a fit: lambda mean(z^2) (the training objective's) and
 * w (-log kernel density of the training latents, bandwidth h). */
struct fit_prior {
    double lambda, w, h;
};

/* The samples' weight in all: n unweighted (w NULL). */
static double weight_sum(const double *w, size_t n)
{
    if (!w)
        return (double)n;
    double s = 0;
    for (size_t k = 0; k < n; k++)
        s += w[k];
    return s;
}

static double objective(const latent_decoder *d, const double *z, size_t n, const double *x,
                        const double *c, const double *t, const unsigned char *lw,
                        const double *w, const struct fit_prior *p, double *gz)
{
    double ws = weight_sum(w, n);
    if (gz)
        memset(gz, 0, (size_t)d->nz * sizeof *gz);
    if (!(ws > 0)) /* a subset of weight 0 says nothing */
        return INFINITY;
    double scale = 1.0 / (3.0 * ws);
    double l = latent_net_backprop(d, z, n, x, c, t, lw, w, scale, NULL, gz) * scale;
    double r = 0;
    for (int k = 0; k < d->nz; k++) {
        r += z[k] * z[k];
        if (gz)
            gz[k] += 2.0 * p->lambda / d->nz * z[k];
    }
    double kde = p->w > 0 ? p->w * latent_prior_nll(d, p->h, z, p->w, gz) : 0.0;
    return l + p->lambda * r / d->nz + kde;
}

/* The mean |r| part only, for reporting (weighted by w, NULL: none). */
static double data_loss(const latent_decoder *d, const double *z, size_t n, const double *x,
                        const double *c, const double *t, const unsigned char *lw,
                        const double *w)
{
    double ws = weight_sum(w, n);
    return ws > 0 ? latent_net_backprop(d, z, n, x, c, t, lw, w, 0.0, NULL, NULL) / (3.0 * ws)
                  : NAN;
}

/* RMS of the log residuals log(1 + fhat c) - t over n samples and the
 * channels (none above a lower bound, lw; weighted by w, NULL: none): the
 * figure every model's status compares (fit/fit_status.h). */
static double rms_log(const latent_decoder *d, const double *z, size_t n, const double *x,
                      const double *c, const double *t, const unsigned char *lw,
                      const double *w)
{
    enum { BLOCK = 256 };
    double o[3 * BLOCK], s = 0;
    for (size_t i = 0; i < n; i += BLOCK) {
        size_t nb = n - i < BLOCK ? n - i : BLOCK;
        latent_net_forward(d, z, nb, x + LATENT_NIN * i, o);
        for (size_t k = 0; k < 3 * nb; k++) {
            double f = expm1(o[k]);
            double r = log1p((f > 0 ? f : 0.0) * c[i + k / 3]) - t[3 * i + k];
            if (lw && lw[i + k / 3] && r > 0)
                r = 0;
            s += (w ? w[i + k / 3] : 1.0) * r * r;
        }
    }
    double ws = weight_sum(w, n);
    return ws > 0 ? sqrt(s / (3.0 * ws)) : NAN;
}

/* Adam on z from z; returns the best objective and leaves its z in z.
 * *gain: the share of the objective's whole fall that came in the last
 * tenth of the steps (still falling: not converged). */
static double adam_z(const latent_decoder *d, double *z, size_t n, const double *x,
                     const double *c, const double *t, const unsigned char *lw,
                     const double *w, const struct fit_prior *p,
                     const struct latent_fit_options *o, double *gain)
{
    int late = o->max_iter - (o->max_iter + 9) / 10;
    double f_late = INFINITY, f_first = INFINITY;
    const int nz = d->nz;
    double m1[LATENT_MAX_NZ] = {0}, m2[LATENT_MAX_NZ] = {0}, g[LATENT_MAX_NZ];
    double best[LATENT_MAX_NZ], best_f = INFINITY;
    for (int it = 0; it < o->max_iter; it++) {
        if (it == late)
            f_late = best_f;
        double f = objective(d, z, n, x, c, t, lw, w, p, g);
        if (it == 0)
            f_first = f;
        if (f < best_f) {
            best_f = f;
            memcpy(best, z, (size_t)nz * sizeof *z);
        }
        double q = o->max_iter > 1 ? (double)it / (o->max_iter - 1) : 1.0;
        double lr = o->lr * (0.05 + 0.95 * 0.5 * (1 + cos(LF_PI * q)));
        double c1 = 1 - pow(0.9, it + 1), c2 = 1 - pow(0.999, it + 1);
        for (int k = 0; k < nz; k++) {
            m1[k] = 0.9 * m1[k] + 0.1 * g[k];
            m2[k] = 0.999 * m2[k] + 0.001 * g[k] * g[k];
            z[k] -= lr * (m1[k] / c1) / (sqrt(m2[k] / c2) + 1e-12);
        }
    }
    double f = objective(d, z, n, x, c, t, lw, w, p, NULL);
    if (f < best_f) {
        best_f = f;
        memcpy(best, z, (size_t)nz * sizeof *z);
    }
    memcpy(z, best, (size_t)nz * sizeof *z);
    if (gain)
        *gain = isfinite(f_late) && f_first > best_f ? (f_late - best_f) / (f_first - best_f)
                                                     : 0.0;
    return best_f;
}

/* Every HOLDOUT_EVERY-th sample is held out for the held-out residual. */
#define HOLDOUT_EVERY 5

/* The held-out RMS log residual: z refitted from z0 without every
 * HOLDOUT_EVERY-th sample, judged on those. The encodings are reordered
 * (the kept samples first) in copies. NAN below 2 HOLDOUT_EVERY samples. */
static double heldout_rms(const latent_decoder *d, const double *z0, size_t n, const double *x,
                          const double *c, const double *t, const unsigned char *lw,
                          const double *w, const struct fit_prior *p,
                          const struct latent_fit_options *o)
{
    if (n < 2 * HOLDOUT_EVERY)
        return NAN;
    double *x2 = malloc(n * LATENT_NIN * sizeof *x2), *c2 = malloc(n * sizeof *c2),
           *t2 = malloc(n * 3 * sizeof *t2);
    unsigned char *l2 = lw ? malloc(n) : NULL;
    double *w2 = w ? malloc(n * sizeof *w2) : NULL;
    double r = NAN;
    if (x2 && c2 && t2 && (!lw || l2) && (!w || w2)) {
        size_t nk = n - n / HOLDOUT_EVERY, a = 0, b = nk;
        for (size_t k = 0; k < n; k++) {
            size_t at = (k + 1) % HOLDOUT_EVERY ? a++ : b++;
            memcpy(x2 + LATENT_NIN * at, x + LATENT_NIN * k, LATENT_NIN * sizeof *x);
            c2[at] = c[k];
            memcpy(t2 + 3 * at, t + 3 * k, 3 * sizeof *t);
            if (l2)
                l2[at] = lw[k];
            if (w2)
                w2[at] = w[k];
        }
        double z[LATENT_MAX_NZ];
        memcpy(z, z0, (size_t)d->nz * sizeof *z);
        struct fit_prior pk = *p;
        pk.w = p->w * (double)n / (double)nk; /* the weight Bayes gives nk samples */
        adam_z(d, z, nk, x2, c2, t2, l2, w2, &pk, o, NULL);
        r = rms_log(d, z, n - nk, x2 + LATENT_NIN * nk, c2 + nk, t2 + 3 * nk,
                    l2 ? l2 + nk : NULL, w2 ? w2 + nk : NULL);
    }
    free(w2);
    free(l2);
    free(x2);
    free(c2);
    free(t2);
    return r;
}

/* The samples a fit uses, in canonical order: their indices, finite and
 * inside the log's domain once the data's scale (fit/fit.h fit_data_scale)
 * is divided out, since the decoder knows materials in 1/sr. *idx (n + 1
 * slots) is the caller's to free; -1 when out of memory. */
static int usable_samples(const struct fit_sample *samples, size_t n, size_t **idx_out,
                          size_t *used_out, double *scale_out)
{
    size_t *idx = malloc((n + 1) * sizeof *idx);
    if (!idx)
        return -1;
    size_t used = 0;
    for (size_t i = 0; i < n; i++) {
        const struct fit_sample *s = &samples[i];
        double ci = s->g.wi[2], co = s->g.wo[2];
        int ok = isfinite(ci) && isfinite(co) && ci > 0 && co > 0 && isfinite(s->g.theta_h) &&
                 isfinite(s->g.theta_d) && isfinite(s->g.phi_d);
        for (int ch = 0; ch < 3 && ok; ch++)
            ok = isfinite(s->rgb[ch]);
        if (ok)
            idx[used++] = i;
    }
    double scale = used ? fit_data_scale(samples, idx, used) : 1.0;
    size_t kept = 0;
    for (size_t k = 0; k < used; k++) {
        const struct fit_sample *s = &samples[idx[k]];
        int ok = 1;
        for (int ch = 0; ch < 3 && ok; ch++)
            ok = 1 + s->rgb[ch] / scale * s->g.wi[2] > 0;
        if (ok)
            idx[kept++] = idx[k];
    }
    *idx_out = idx;
    *used_out = kept;
    *scale_out = scale;
    return 0;
}

/* A seeded subset of max indices of idx[0..*used) for large inputs:
 * partial Fisher-Yates, kept in (canonical) input order. */
static void subsample(size_t *idx, size_t *used, size_t max, uint64_t seed)
{
    if (*used <= max)
        return;
    uint64_t s = seed ^ 0x243f6a8885a308d3ULL;
    for (size_t k = 0; k < max; k++) {
        size_t j = k + (size_t)(brdf_splitmix64(&s) % (uint64_t)(*used - k));
        size_t tmp = idx[k];
        idx[k] = idx[j];
        idx[j] = tmp;
    }
    *used = max;
    for (size_t a = 1; a < max; a++) /* insertion sort: back in canonical order */
        for (size_t b = a; b > 0 && idx[b - 1] > idx[b]; b--) {
            size_t tmp = idx[b];
            idx[b] = idx[b - 1];
            idx[b - 1] = tmp;
        }
}

/* The used samples as the objective takes them: encoded geometries,
 * cosines, log targets, lower-bound flags and domain weights (or NULL). */
struct encoded {
    size_t n;
    double *x, *c, *t;
    unsigned char *lw;
    double *w;
};

static void encoded_free(struct encoded *e)
{
    free(e->x);
    free(e->c);
    free(e->t);
    free(e->lw);
    free(e->w);
}

/* e for samples idx[0..used) divided by scale; -1 (e freed by the caller)
 * when out of memory. */
static int encode_samples(const struct fit_sample *samples, const size_t *idx, size_t used,
                          double scale, const unsigned char *lower, int weigh, struct encoded *e)
{
    e->n = used;
    e->x = malloc(used * LATENT_NIN * sizeof *e->x);
    e->c = malloc(used * sizeof *e->c);
    e->t = malloc(used * 3 * sizeof *e->t);
    e->lw = lower ? malloc(used) : NULL;
    e->w = weigh ? malloc(used * sizeof *e->w) : NULL;
    if (!e->x || !e->c || !e->t || (lower && !e->lw) || (weigh && !e->w) ||
        (e->w && fit_domain_weights(samples, idx, used, e->w) < 0))
        return -1;
    for (size_t k = 0; k < used; k++) {
        const struct fit_sample *s = &samples[idx[k]];
        latent_encode(&s->g, e->x + LATENT_NIN * k);
        e->c[k] = s->g.wi[2];
        for (int ch = 0; ch < 3; ch++)
            e->t[3 * k + ch] = log1p(s->rgb[ch] / scale * e->c[k]);
        if (e->lw)
            e->lw[k] = lower[idx[k]] != 0;
    }
    return 0;
}

/* Training latent m of the decoder, or its mean for m == n_materials. */
static const double *candidate(const latent_decoder *d, size_t m)
{
    return m < d->n_materials ? d->latents + m * (size_t)d->nz : d->mean;
}

/* Starts: score every training latent and the mean on (a subset of) the
 * samples, keep the best ns (at most 16) in best_i, best first. */
static void best_starts(const latent_decoder *d, const struct encoded *e,
                        const struct fit_prior *pr, int ns, size_t *best_i)
{
    size_t ncand = d->n_materials + 1;
    size_t nscore = e->n < 1024 ? e->n : 1024;
    double best_s[16];
    for (int k = 0; k < ns; k++) {
        best_i[k] = 0;
        best_s[k] = INFINITY;
    }
    for (size_t m = 0; m < ncand; m++) {
        double sc = objective(d, candidate(d, m), nscore, e->x, e->c, e->t, e->lw, e->w, pr,
                              NULL);
        for (int k = 0; k < ns; k++)
            if (sc < best_s[k]) {
                for (int q = ns - 1; q > k; q--) {
                    best_s[q] = best_s[q - 1];
                    best_i[q] = best_i[q - 1];
                }
                best_s[k] = sc;
                best_i[k] = m;
                break;
            }
    }
}

/* The outcome of the fit from its best start. */
struct best_fit {
    double z[LATENT_MAX_NZ];
    double f, start_loss, gain;
};

/* Adam from each start; the one with the lowest objective wins. */
static void fit_from_starts(const latent_decoder *d, const struct encoded *e,
                            const struct fit_prior *pr, const struct latent_fit_options *o,
                            const size_t *best_i, int ns, struct best_fit *b)
{
    const int nz = d->nz;
    b->f = INFINITY;
    b->start_loss = NAN;
    b->gain = 0;
    for (int k = 0; k < ns; k++) {
        double zk[LATENT_MAX_NZ];
        memcpy(zk, candidate(d, best_i[k]), (size_t)nz * sizeof *zk);
        double s0 = data_loss(d, zk, e->n, e->x, e->c, e->t, e->lw, e->w);
        double gk;
        double f = adam_z(d, zk, e->n, e->x, e->c, e->t, e->lw, e->w, pr, o, &gk);
        if (f < b->f) {
            b->f = f;
            b->gain = gk;
            b->start_loss = s0;
            memcpy(b->z, zk, (size_t)nz * sizeof *zk);
        }
    }
}

/* What fit_latent reports of a fit: losses, counts and its status. */
static void fill_info(const latent_decoder *d, const struct fit_sample *samples,
                      const size_t *idx, const struct encoded *e, const struct best_fit *b,
                      const struct fit_prior *pr, const struct latent_fit_options *o, int ns,
                      size_t dropped, double scale, struct latent_fit_info *info)
{
    size_t used = e->n;
    info->loss = data_loss(d, b->z, used, e->x, e->c, e->t, e->lw, e->w);
    info->start_loss = b->start_loss;
    info->iterations = o->max_iter;
    info->starts = ns;
    info->used = used;
    info->dropped = dropped;
    info->prior_weight = pr->w;
    info->bandwidth = pr->h;
    info->scale = scale;
    info->gain = b->gain;
    info->domain_weights = e->w != NULL;
    struct fit_status *st = &info->status;
    *st = fit_status_init();
    st->geometries = fit_status_geometries(samples, idx, used);
    st->params = d->nz;
    st->insample = rms_log(d, b->z, used, e->x, e->c, e->t, e->lw, e->w);
    st->heldout = heldout_rms(d, b->z, used, e->x, e->c, e->t, e->lw, e->w, pr, o);
    if (b->gain > LATENT_FIT_GAIN_TOL)
        st->findings |= 1u << FIT_STATUS_NOT_CONVERGED;
    fit_status_decide(st);
}

/* fit_latent on samples in canonical order (fit/sample_order.h). */
static int fit_latent_canonical(const latent_decoder *d, const struct fit_sample *samples,
                                size_t n, struct latent_fit_options o, double *z,
                                struct latent_fit_info *info, struct gonio_err *err)
{
    if (o.max_iter < 1)
        o.max_iter = 1;
    if (o.max_samples < 3)
        o.max_samples = 3;
    size_t *idx, used;
    double scale;
    if (usable_samples(samples, n, &idx, &used, &scale) < 0)
        return gonio_err_set(err, ENOMEM, "fit_latent: out of memory");
    size_t dropped = n - used;
    if (used < 3) {
        free(idx);
        return gonio_err_set(err, GONIO_EFIT,
                             "fit_latent: %zu usable samples of %zu (need at least 3)", used, n);
    }
    subsample(idx, &used, o.max_samples, o.seed);
    /* each sample's share of the full domain (fit/domain_weights.h), as the
     * weighted ABC fit's: the loss then estimates the full-domain error */
    int weigh = o.domain_weights && used >= FIT_DOMAIN_WEIGHTS_MIN_SAMPLES;
    if (weigh && o.weighted_iter > 0)
        o.max_iter = o.weighted_iter;
    if (weigh && o.weighted_starts > 0)
        o.n_starts = o.weighted_starts;
    struct encoded e = {0};
    if (encode_samples(samples, idx, used, scale, o.lower, weigh, &e) < 0) {
        free(idx);
        encoded_free(&e);
        return gonio_err_set(err, ENOMEM, "fit_latent: out of memory");
    }
    /* Priors. The data term is a mean over 3 used residuals, so Laplace noise
     * of scale b puts the prior's -log density at b / (3 used): decisive for
     * six samples, 1e-5 for DS1's 912. */
    struct fit_prior pr = {
        .lambda = o.lambda_z >= 0 ? o.lambda_z : d->train.lambda_z,
        .w = o.prior_scale > 0 ? o.prior_scale / (3.0 * (double)used) : 0.0,
        .h = o.bandwidth > 0 ? o.bandwidth : d->prior_h,
    };
    size_t ncand = d->n_materials + 1;
    int ns = o.n_starts < 1 ? 1 : o.n_starts;
    if ((size_t)ns > ncand)
        ns = (int)ncand;
    if (ns > 16)
        ns = 16;
    size_t best_i[16];
    best_starts(d, &e, &pr, ns, best_i);
    struct best_fit b;
    fit_from_starts(d, &e, &pr, &o, best_i, ns, &b);
    memcpy(z, b.z, (size_t)d->nz * sizeof *z);
    if (info)
        fill_info(d, samples, idx, &e, &b, &pr, &o, ns, dropped, scale, info);
    free(idx);
    encoded_free(&e);
    if (!isfinite(b.f))
        return gonio_err_set(err, GONIO_EFIT, "fit_latent: objective not finite");
    return 0;
}

int fit_latent(const latent_decoder *d, const struct fit_sample *samples, size_t n,
               const struct latent_fit_options *opt, double *z, struct latent_fit_info *info,
               struct gonio_err *err)
{
    struct latent_fit_options o = opt ? *opt : latent_fit_default_options();
    struct fit_sample *sorted;
    unsigned char *lower;
    if (fit_samples_canonical(samples, o.lower, n, &sorted, &lower) < 0)
        return gonio_err_set(err, ENOMEM, "fit_latent: out of memory");
    o.lower = lower;
    int rc = fit_latent_canonical(d, sorted, n, o, z, info, err);
    free(sorted);
    free(lower);
    return rc;
}
