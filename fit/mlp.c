/* MLP training and evaluation (fit/mlp.h). Activations are kept row-major
 * per mini-batch (batch x width), so the inner loops are dot products and
 * axpys over contiguous rows that the compiler vectorises; all buffers are
 * allocated before the first epoch. */
#include "fit/mlp.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/domain.h"
#include "common/clock.h"
#include "fit/model_file.h"

/* Outputs beyond this are clamped in the loss: e^60 is far past any BRDF,
 * and the clamp keeps a wild early step from overflowing to inf. */
#define Z_MAX 60.0
#define Z_MIN -30.0

int fit_mlp_init(struct fit_mlp *net, int n_layers, const int *width, struct gonio_err *err)
{
    memset(net, 0, sizeof *net);
    if (n_layers < 1 || n_layers > FIT_MLP_MAX_LAYERS)
        return gonio_err_set(err, GONIO_EBADDATA, "mlp: %d layers (1..%d)", n_layers,
                             FIT_MLP_MAX_LAYERS);
    size_t np = 0;
    for (int l = 0; l <= n_layers; l++) {
        if (width[l] < 1 || width[l] > FIT_MLP_MAX_WIDTH)
            return gonio_err_set(err, GONIO_EBADDATA, "mlp: layer %d width %d (1..%d)", l,
                                 width[l], FIT_MLP_MAX_WIDTH);
        net->width[l] = width[l];
        if (l < n_layers)
            np += (size_t)width[l + 1] * (size_t)(width[l] + 1);
    }
    net->n_layers = n_layers;
    for (int k = 0; k < FIT_MLP_MAX_WIDTH; k++)
        net->scale[k] = 1.0;
    net->params = calloc(np, sizeof *net->params);
    if (!net->params)
        return gonio_err_set(err, ENOMEM, "mlp: out of memory");
    net->n_params = np;
    return 0;
}

void fit_mlp_free(struct fit_mlp *net)
{
    free(net->params);
    net->params = NULL;
}

double fit_mlp_value(double z)
{
    if (!(z > 0))
        return 0.0; /* also NAN */
    if (z > 69.0)
        return 1e30;
    double f = expm1(z);
    return f > 1e30 ? 1e30 : f;
}

/* One dense layer over a batch: out[b][j] = b_j + W_j . in[b], ReLU unless
 * last. */
static void layer_forward(const double *W, const double *bias, int nin, int nout,
                          const double *in, double *out, size_t nb, int relu)
{
    for (size_t b = 0; b < nb; b++) {
        const double *x = in + b * (size_t)nin;
        double *y = out + b * (size_t)nout;
        for (int j = 0; j < nout; j++) {
            const double *w = W + (size_t)j * (size_t)nin;
            double s = bias[j];
            for (int i = 0; i < nin; i++)
                s += w[i] * x[i];
            y[j] = relu && s < 0 ? 0.0 : s;
        }
    }
}

void fit_mlp_forward(const struct fit_mlp *net, const double *u, size_t n, double *z)
{
    double a[2][FIT_MLP_MAX_WIDTH];
    int nin = net->width[0], nout = net->width[net->n_layers];
    for (size_t r = 0; r < n; r++) {
        for (int i = 0; i < nin; i++)
            a[0][i] = (u[r * (size_t)nin + (size_t)i] - net->offset[i]) * net->scale[i];
        const double *p = net->params;
        int cur = 0;
        for (int l = 0; l < net->n_layers; l++) {
            int wi = net->width[l], wo = net->width[l + 1];
            layer_forward(p, p + (size_t)wo * (size_t)wi, wi, wo, a[cur], a[1 - cur], 1,
                          l + 1 < net->n_layers);
            p += (size_t)wo * (size_t)(wi + 1);
            cur = 1 - cur;
        }
        memcpy(z + r * (size_t)nout, a[cur], (size_t)nout * sizeof(double));
    }
}

/* The loss of one value and its derivative in z: p = log(1 + expm1(z) c)
 * - t with t = log(1 + f c); loss p^2. A target that is a lower bound (a
 * saturated reading, lower 1) is censored: no loss and no slope while the
 * output is above it. */
static double value_loss(double z, double c, double t, int lower, double *dz)
{
    double zc = z > Z_MAX ? Z_MAX : z < Z_MIN ? Z_MIN : z;
    double e = expm1(zc);
    double q = 1.0 + e * c;
    double p = log1p(e * c) - t;
    if (lower && p > 0)
        p = 0;
    if (dz)
        *dz = (z == zc) ? 2.0 * p * c * (e + 1.0) / q : 0.0;
    return p * p;
}

double fit_mlp_loss(const struct fit_mlp *net, const double *u, const double *f,
                    const double *c, size_t n)
{
    int nout = net->width[net->n_layers], nin = net->width[0];
    double z[FIT_MLP_MAX_WIDTH], sum = 0;
    for (size_t r = 0; r < n; r++) {
        fit_mlp_forward(net, u + r * (size_t)nin, 1, z);
        for (int k = 0; k < nout; k++)
            sum += value_loss(z[k], c[r], log1p(f[r * (size_t)nout + (size_t)k] * c[r]), 0, NULL);
    }
    return n ? sum / ((double)n * nout) : NAN;
}

struct fit_mlp_train_options fit_mlp_default_train_options(void)
{
    return (struct fit_mlp_train_options){
        .seed = 1, .batch = 32, .lr = 2e-3, .beta1 = 0.9, .beta2 = 0.999, .eps = 1e-8,
        .max_epochs = 0, .max_steps = 60000, .patience = 400, .min_patience_steps = 10000,
        .twin = NULL,
        .holdout = 0.15, .quiet = 1,
    };
}

static double uniform01(uint64_t *s)
{
    return (double)(brdf_splitmix64(s) >> 11) * 0x1.0p-53;
}

static size_t below(uint64_t *s, size_t n)
{
    /* n is small (rows of a training set): the modulo bias of a 64-bit draw
     * is below 2^-40 and irrelevant to a shuffle. */
    return (size_t)(brdf_splitmix64(s) % (uint64_t)n);
}

static void shuffle(size_t *idx, size_t n, uint64_t *s)
{
    for (size_t i = n; i > 1; i--) {
        size_t j = below(s, i);
        size_t t = idx[i - 1];
        idx[i - 1] = idx[j];
        idx[j] = t;
    }
}

/* Everything an epoch touches, allocated once. */
struct work {
    size_t B;
    double *act[FIT_MLP_MAX_LAYERS + 1]; /* B x width[l] */
    double *d0, *d1;                    /* B x max width: deltas */
    double *grad, *m, *v, *best;
    double *wt;                         /* weights transposed, for the forward pass */
    double *X, *T, *C;                  /* normalised inputs, log targets, cosines */
    const unsigned char *lower;         /* fit_mlp_train_options.lower */
    size_t *idx;
};

static void work_free(struct work *w)
{
    for (int l = 0; l <= FIT_MLP_MAX_LAYERS; l++)
        free(w->act[l]);
    free(w->d0);
    free(w->d1);
    free(w->grad);
    free(w->m);
    free(w->v);
    free(w->best);
    free(w->wt);
    free(w->X);
    free(w->T);
    free(w->C);
    free(w->idx);
}

/* The one kernel of training: out[0..N) = init[0..N) (or 0) plus
 * sum_k coef[k cs] * rows[k rs + 0..N), k ascending. Forward passes,
 * weight gradients and back-propagated deltas all have this shape. For the
 * widths of the registry's networks N is a compile-time constant, so the
 * accumulators stay in registers and the loop over N vectorises; the sums
 * are the same, in the same order, as a plain loop's. */
static inline void acc_rows_n(double *restrict out, const double *restrict init,
                              const double *restrict coef, size_t cs,
                              const double *restrict rows, size_t rs, int K, const int N)
{
    double acc[FIT_MLP_MAX_WIDTH];
    for (int j = 0; j < N; j++)
        acc[j] = init ? init[j] : 0.0;
    for (int k = 0; k < K; k++) {
        double c = coef[(size_t)k * cs];
        const double *r = rows + (size_t)k * rs;
        for (int j = 0; j < N; j++)
            acc[j] += c * r[j];
    }
    for (int j = 0; j < N; j++)
        out[j] = acc[j];
}

/* AVX2 where the CPU has it (4 doubles a vector instead of SSE2's 2),
 * chosen once at load time; without FMA contraction (C17 mode) both
 * versions compute the same bits. */
__attribute__((target_clones("avx2", "default")))
static void acc_rows(double *restrict out, const double *restrict init,
                     const double *restrict coef, size_t cs, const double *restrict rows,
                     size_t rs, int K, int N)
{
    switch (N) {
    case 20: acc_rows_n(out, init, coef, cs, rows, rs, K, 20); break;
    case 10: acc_rows_n(out, init, coef, cs, rows, rs, K, 10); break;
    case 3: acc_rows_n(out, init, coef, cs, rows, rs, K, 3); break;
    case 2: acc_rows_n(out, init, coef, cs, rows, rs, K, 2); break;
    case 1: acc_rows_n(out, init, coef, cs, rows, rs, K, 1); break;
    default: acc_rows_n(out, init, coef, cs, rows, rs, K, N); break;
    }
}

/* One dense layer over a batch from transposed weights Wt (nin x nout):
 * out[b][:] = bias + sum_i in[b][i] Wt[i][:], the same sums in the same
 * order as layer_forward. */
static void layer_forward_t(const double *Wt, const double *bias, int nin, int nout,
                            const double *in, double *out, size_t nb, int relu)
{
    for (size_t b = 0; b < nb; b++) {
        double *y = out + b * (size_t)nout;
        acc_rows(y, bias, in + b * (size_t)nin, 1, Wt, (size_t)nout, nin, nout);
        if (relu)
            for (int j = 0; j < nout; j++)
                y[j] = y[j] < 0 ? 0.0 : y[j];
    }
}

/* The transposed weights of every layer into w->wt (once per step). */
static void transpose_weights(const struct fit_mlp *net, struct work *w)
{
    const double *p = net->params;
    double *t = w->wt;
    for (int l = 0; l < net->n_layers; l++) {
        int wi = net->width[l], wo = net->width[l + 1];
        for (int j = 0; j < wo; j++)
            for (int i = 0; i < wi; i++)
                t[(size_t)i * (size_t)wo + (size_t)j] = p[(size_t)j * (size_t)wi + (size_t)i];
        p += (size_t)wo * (size_t)(wi + 1);
        t += (size_t)wo * (size_t)wi;
    }
}

/* Forward the rows idx[0..nb) into w->act (outputs in act[n_layers]);
 * w->wt must hold the current weights transposed. */
static void batch_forward(const struct fit_mlp *net, struct work *w, const size_t *idx,
                          size_t nb)
{
    int nin = net->width[0];
    for (size_t b = 0; b < nb; b++)
        memcpy(w->act[0] + b * (size_t)nin, w->X + idx[b] * (size_t)nin,
               (size_t)nin * sizeof(double));
    const double *p = net->params, *t = w->wt;
    for (int l = 0; l < net->n_layers; l++) {
        int wi = net->width[l], wo = net->width[l + 1];
        layer_forward_t(t, p + (size_t)wo * (size_t)wi, wi, wo, w->act[l], w->act[l + 1], nb,
                        l + 1 < net->n_layers);
        p += (size_t)wo * (size_t)(wi + 1);
        t += (size_t)wo * (size_t)wi;
    }
}

/* Sum of the loss over rows idx[0..nb), without gradients. */
static double batch_loss(const struct fit_mlp *net, struct work *w, const size_t *idx,
                         size_t nb)
{
    double sum = 0;
    transpose_weights(net, w);
    for (size_t s = 0; s < nb; s += w->B) {
        size_t m = nb - s < w->B ? nb - s : w->B;
        batch_forward(net, w, idx + s, m);
        int nout = net->width[net->n_layers];
        const double *z = w->act[net->n_layers];
        for (size_t b = 0; b < m; b++)
            for (int k = 0; k < nout; k++)
                sum += value_loss(z[b * (size_t)nout + (size_t)k], w->C[idx[s + b]],
                                  w->T[idx[s + b] * (size_t)nout + (size_t)k],
                                  w->lower && w->lower[idx[s + b]], NULL);
    }
    return sum;
}

/* One Adam step on the mini-batch idx[0..nb); t is the 1-based step.
 * Returns the batch's summed loss before the step. */
static double train_step(struct fit_mlp *net, struct work *w, const size_t *idx, size_t nb,
                       const struct fit_mlp_train_options *o, double lr, long t)
{
    int L = net->n_layers, nout = net->width[L];
    transpose_weights(net, w);
    batch_forward(net, w, idx, nb);
    /* Output deltas: d loss_mean / dz, the mean over batch and outputs as
     * in PyTorch's MSELoss. */
    double inv = 1.0 / ((double)nb * nout);
    const double *z = w->act[L];
    double *d = w->d0, *dn = w->d1, loss = 0;
    for (size_t b = 0; b < nb; b++)
        for (int k = 0; k < nout; k++) {
            double dz;
            size_t r = idx[b];
            loss += value_loss(z[b * (size_t)nout + (size_t)k], w->C[r],
                               w->T[r * (size_t)nout + (size_t)k], w->lower && w->lower[r], &dz);
            d[b * (size_t)nout + (size_t)k] = dz * inv;
        }
    /* Back through the layers; parameter offsets from the end. */
    size_t off = net->n_params;
    for (int l = L - 1; l >= 0; l--) {
        int wi = net->width[l], wo = net->width[l + 1];
        off -= (size_t)wo * (size_t)(wi + 1);
        const double *W = net->params + off;
        double *gW = w->grad + off, *gb = gW + (size_t)wo * (size_t)wi;
        /* gW[j][:] = sum_b d[b][j] a[b][:]; gb[j] = sum_b d[b][j]. */
        const double *a = w->act[l];
        for (int j = 0; j < wo; j++) {
            acc_rows(gW + (size_t)j * (size_t)wi, NULL, d + j, (size_t)wo, a, (size_t)wi,
                     (int)nb, wi);
            double sb = 0;
            for (size_t b = 0; b < nb; b++)
                sb += d[b * (size_t)wo + (size_t)j];
            gb[j] = sb;
        }
        if (l == 0)
            break;
        /* delta of the layer below: W^T d, times ReLU' (active where a > 0). */
        for (size_t b = 0; b < nb; b++) {
            const double *ab = a + b * (size_t)wi;
            double *e = dn + b * (size_t)wi;
            acc_rows(e, NULL, d + b * (size_t)wo, 1, W, (size_t)wi, wo, wi);
            for (int i = 0; i < wi; i++)
                e[i] = ab[i] > 0 ? e[i] : 0.0;
        }
        double *tmp = d;
        d = dn;
        dn = tmp;
    }
    /* Adam, in PyTorch's arrangement of the bias corrections. */
    double bc1 = 1.0 - pow(o->beta1, (double)t), bc2 = 1.0 - pow(o->beta2, (double)t);
    double step = lr / bc1, rs2 = 1.0 / sqrt(bc2);
    double b1 = o->beta1, b2 = o->beta2, eps = o->eps;
    double *p = net->params, *g = w->grad, *m = w->m, *v = w->v;
    for (size_t k = 0; k < net->n_params; k++) {
        m[k] = b1 * m[k] + (1.0 - b1) * g[k];
        v[k] = b2 * v[k] + (1.0 - b2) * g[k] * g[k];
        p[k] -= step * m[k] / (sqrt(v[k]) * rs2 + eps);
    }
    return loss;
}

struct keyed {
    double key;
    size_t row;
};

static int cmp_keyed(const void *a, const void *b)
{
    const struct keyed *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return (x->row > y->row) - (x->row < y->row); /* a total order: qsort is not stable */
}

/* Put the held-out rows first in w->idx (see fit_mlp_train). */
static int stratify(struct work *w, size_t n, int nout, size_t *n_val_io, const size_t *twin,
                    uint64_t *rng)
{
    size_t n_val = *n_val_io;
    struct keyed *k = malloc(n * sizeof *k);
    unsigned char *held = calloc(n, 1);
    if (!k || !held) {
        free(k);
        free(held);
        return -1;
    }
    for (size_t i = 0; i < n; i++) {
        k[i].row = i;
        k[i].key = 0;
        for (int j = 0; j < nout; j++)
            k[i].key += w->T[i * (size_t)nout + (size_t)j];
    }
    qsort(k, n, sizeof *k, cmp_keyed);
    /* With twins, half as many strata: each pick brings its twin. */
    size_t strata = twin ? (n_val + 1) / 2 : n_val;
    for (size_t s = 0; s < strata; s++) {
        size_t lo = s * n / strata, hi = (s + 1) * n / strata;
        held[k[lo + below(rng, hi - lo)].row] = 1;
    }
    /* A held-out row's twin (the same measurement seen another way) is
     * held out with it, or the held-out loss would be a training loss. */
    if (twin)
        for (size_t i = 0; i < n; i++)
            if (held[i] == 1 && twin[i] < n && !held[twin[i]])
                held[twin[i]] = 2;
    n_val = 0;
    for (size_t i = 0; i < n; i++)
        n_val += held[i] != 0;
    if (n_val >= n) { /* only twins: keep the strata picks alone */
        for (size_t i = 0; i < n; i++)
            held[i] = held[i] == 1;
        n_val = 0;
        for (size_t i = 0; i < n; i++)
            n_val += held[i] != 0;
    }
    *n_val_io = n_val;
    size_t a = 0, b = n_val;
    for (size_t i = 0; i < n; i++)
        w->idx[held[i] ? a++ : b++] = i;
    free(k);
    free(held);
    return 0;
}

/* Every training row finite, its cosine in [0, 1] and its log target defined. */
static int check_rows(const struct fit_mlp *net, const double *u, const double *f,
                      const double *c, size_t n, struct gonio_err *err)
{
    int nin = net->width[0], nout = net->width[net->n_layers];
    for (size_t i = 0; i < n; i++) {
        int ok = isfinite(c[i]) && c[i] >= 0 && c[i] <= 1;
        for (int k = 0; k < nin; k++)
            ok = ok && isfinite(u[i * (size_t)nin + (size_t)k]);
        for (int k = 0; k < nout; k++)
            ok = ok && isfinite(f[i * (size_t)nout + (size_t)k]) &&
                 f[i * (size_t)nout + (size_t)k] * c[i] > -1;
        if (!ok)
            return gonio_err_set(err, GONIO_EBADDATA,
                                 "mlp: training row %zu has a non-finite or out-of-range value",
                                 i);
    }
    return 0;
}

/* Input normalisation: each input's range onto [-1, 1]. */
static void set_normalisation(struct fit_mlp *net, const double *u, size_t n)
{
    int nin = net->width[0];
    for (int k = 0; k < nin; k++) {
        double lo = INFINITY, hi = -INFINITY;
        for (size_t i = 0; i < n; i++) {
            double x = u[i * (size_t)nin + (size_t)k];
            lo = x < lo ? x : lo;
            hi = x > hi ? x : hi;
        }
        net->offset[k] = 0.5 * (lo + hi);
        net->scale[k] = hi > lo ? 2.0 / (hi - lo) : 1.0;
    }
}

/* He-uniform weights (ReLU layers; the linear output layer the same,
 * which keeps the initial outputs small), zero biases. */
static void init_weights(struct fit_mlp *net, uint64_t *rng)
{
    double *p = net->params;
    for (int l = 0; l < net->n_layers; l++) {
        int wi = net->width[l], wo = net->width[l + 1];
        double lim = sqrt(6.0 / wi);
        for (size_t k = 0; k < (size_t)wo * (size_t)wi; k++)
            p[k] = lim * (2.0 * uniform01(rng) - 1.0);
        memset(p + (size_t)wo * (size_t)wi, 0, (size_t)wo * sizeof(double));
        p += (size_t)wo * (size_t)(wi + 1);
    }
}

/* The work buffers for n rows in batches of B; -1 (all freed) when out of memory. */
static int work_alloc(struct work *w, const struct fit_mlp *net, size_t n, size_t B)
{
    int L = net->n_layers, nin = net->width[0], nout = net->width[L];
    int maxw = 0;
    for (int l = 0; l <= L; l++)
        maxw = net->width[l] > maxw ? net->width[l] : maxw;
    w->B = B;
    int oom = 0;
    for (int l = 0; l <= L; l++)
        oom |= !(w->act[l] = malloc(w->B * (size_t)net->width[l] * sizeof(double)));
    oom |= !(w->d0 = malloc(w->B * (size_t)maxw * sizeof(double)));
    oom |= !(w->d1 = malloc(w->B * (size_t)maxw * sizeof(double)));
    oom |= !(w->grad = calloc(net->n_params, sizeof(double)));
    oom |= !(w->m = calloc(net->n_params, sizeof(double)));
    oom |= !(w->v = calloc(net->n_params, sizeof(double)));
    oom |= !(w->best = malloc(net->n_params * sizeof(double)));
    oom |= !(w->wt = malloc(net->n_params * sizeof(double)));
    oom |= !(w->X = malloc(n * (size_t)nin * sizeof(double)));
    oom |= !(w->T = malloc(n * (size_t)nout * sizeof(double)));
    oom |= !(w->C = malloc(n * sizeof(double)));
    oom |= !(w->idx = malloc(n * sizeof(size_t)));
    if (oom) {
        work_free(w);
        return -1;
    }
    return 0;
}

/* The rows as training sees them: normalised inputs, log targets, cosines. */
static void work_load(struct work *w, const struct fit_mlp *net, const double *u,
                      const double *f, const double *c, size_t n)
{
    int nin = net->width[0], nout = net->width[net->n_layers];
    for (size_t i = 0; i < n; i++) {
        for (int k = 0; k < nin; k++)
            w->X[i * (size_t)nin + (size_t)k] =
                (u[i * (size_t)nin + (size_t)k] - net->offset[k]) * net->scale[k];
        for (int k = 0; k < nout; k++)
            w->T[i * (size_t)nout + (size_t)k] = log1p(f[i * (size_t)nout + (size_t)k] * c[i]);
        w->C[i] = c[i];
        w->idx[i] = i;
    }
}

/* The rows of one training run: the training rows and the held-out ones. */
struct split {
    size_t *tr, *val;
    size_t n_tr, n_val;
};

/* The epochs: Adam steps over shuffled batches, the best parameters (by
 * held-out loss, else training loss) kept in w->best, early stopping and
 * step halving. Fills r's epochs, best_epoch and early_stopped. */
static void train_epochs(struct fit_mlp *net, struct work *w, const struct split *sp,
                         const struct fit_mlp_train_options *o, uint64_t *rng,
                         struct fit_mlp_train_report *r)
{
    int nout = net->width[net->n_layers];
    size_t *tr = sp->tr, *val = sp->val, n_tr = sp->n_tr, n_val = sp->n_val;
    size_t per_epoch = (n_tr + w->B - 1) / w->B;
    long max_epochs = o->max_epochs > 0 ? o->max_epochs
                                        : (long)((o->max_steps + (long)per_epoch - 1) /
                                                 (long)per_epoch);
    if (max_epochs < 1)
        max_epochs = 1;
    /* Patience in epochs, but never fewer than min_patience_steps steps:
     * with a few hundred samples an epoch is a handful of steps, and a
     * small held-out set that misses the specular peak looks flat long
     * before the network has learnt the peak. */
    long patience = o->patience;
    long min_pat = (long)((o->min_patience_steps + (long)per_epoch - 1) / (long)per_epoch);
    patience = patience > min_pat ? patience : min_pat;
    long cut_after = (patience + 2) / 3;
    double best = INFINITY, best_train = INFINITY, lr = o->lr;
    long since_best = 0, since_cut = 0;
    long t = 0;
    memcpy(w->best, net->params, net->n_params * sizeof(double));
    for (long ep = 1; ep <= max_epochs; ep++) {
        shuffle(tr, n_tr, rng);
        double epoch_loss = 0;
        for (size_t s = 0; s < n_tr; s += w->B) {
            size_t nb = n_tr - s < w->B ? n_tr - s : w->B;
            epoch_loss += train_step(net, w, tr + s, nb, o, lr, ++t);
        }
        r->epochs = (int)ep;
        /* Without a held-out split, the training loss decides. */
        double score = n_val ? batch_loss(net, w, val, n_val) : batch_loss(net, w, tr, n_tr);
        if (!isfinite(score) || !isfinite(epoch_loss))
            break;
        if (score < best) {
            best = score;
            r->best_epoch = (int)ep;
            memcpy(w->best, net->params, net->n_params * sizeof(double));
            since_best = 0;
        } else {
            since_best++;
        }
        if (n_val && since_best >= patience) {
            r->early_stopped = ep < max_epochs;
            break;
        }
        /* The step is halved when the training loss (mean over the epoch's
         * batches) has not improved for a third of the patience. */
        if (epoch_loss < best_train) {
            best_train = epoch_loss;
            since_cut = 0;
        } else if (++since_cut >= cut_after) {
            lr *= 0.5;
            since_cut = 0;
        }
        if (!o->quiet && ep % 500 == 0)
            fprintf(stderr, "mlp: epoch %ld, loss %.3g, best %.3g at %d\n", ep,
                    score / ((double)(n_val ? n_val : n_tr) * nout),
                    best / ((double)(n_val ? n_val : n_tr) * nout), r->best_epoch);
    }
}

int fit_mlp_train(struct fit_mlp *net, const double *u, const double *f, const double *c,
                  size_t n, const struct fit_mlp_train_options *opt,
                  struct fit_mlp_train_report *rep, struct gonio_err *err)
{
    struct fit_mlp_train_options o = opt ? *opt : fit_mlp_default_train_options();
    struct fit_mlp_train_report r = {0};
    int nout = net->width[net->n_layers];
    if (n < 1)
        return gonio_err_set(err, GONIO_EFIT, "mlp: no training rows");
    if (o.batch < 1 || !(o.lr > 0) || o.patience < 1 || !(o.holdout >= 0 && o.holdout < 1))
        return gonio_err_set(err, GONIO_EUSAGE, "mlp: bad training options");
    int rc = check_rows(net, u, f, c, n, err);
    if (rc < 0)
        return rc;
    uint64_t rng = o.seed;
    set_normalisation(net, u, n);
    init_weights(net, &rng);
    struct work w = {0};
    if (work_alloc(&w, net, n, (size_t)o.batch) < 0)
        return gonio_err_set(err, ENOMEM, "mlp: out of memory for %zu rows", n);
    w.lower = o.lower;
    work_load(&w, net, u, f, c, n);
    /* Held-out rows, stratified by value: rows sorted by their summed log
     * target, cut into n_val strata, one seeded pick from each. A plain
     * random split of a sparse capture can miss every specular row, and a
     * held-out set without peaks rewards a network that ignores them. */
    size_t n_val = n >= 8 ? (size_t)floor(o.holdout * (double)n + 0.5) : 0;
    if (n_val >= n)
        n_val = n - 1;
    if (n_val && stratify(&w, n, nout, &n_val, o.twin, &rng)) {
        work_free(&w);
        return gonio_err_set(err, ENOMEM, "mlp: out of memory for %zu rows", n);
    }
    struct split sp = {.val = w.idx, .tr = w.idx + n_val, .n_tr = n - n_val, .n_val = n_val};
    r.n_train = sp.n_tr;
    r.n_val = n_val;
    r.train_loss0 = batch_loss(net, &w, sp.tr, sp.n_tr) / ((double)sp.n_tr * nout);
    double t0 = gonio_monotonic_s();
    train_epochs(net, &w, &sp, &o, &rng, &r);
    r.seconds = gonio_monotonic_s() - t0;
    memcpy(net->params, w.best, net->n_params * sizeof(double));
    r.train_loss = batch_loss(net, &w, sp.tr, sp.n_tr) / ((double)sp.n_tr * nout);
    r.val_loss = n_val ? batch_loss(net, &w, sp.val, n_val) / ((double)n_val * nout) : NAN;
    work_free(&w);
    if (rep)
        *rep = r;
    if (!isfinite(r.train_loss))
        return gonio_err_set(err, GONIO_EFIT, "mlp: training diverged (loss not finite)");
    return 0;
}

/* x[n] as "a,b,c": hexadecimal floats (%a, bit-exact) or integers. */
static int append_list(char *buf, size_t cap, const double *x, int n, int hex)
{
    size_t len = 0;
    buf[0] = 0;
    for (int k = 0; k < n; k++) {
        int m = hex ? snprintf(buf + len, cap - len, "%s%a", k ? "," : "", x[k])
                    : snprintf(buf + len, cap - len, "%s%.0f", k ? "," : "", x[k]);
        if (m < 0 || (size_t)m >= cap - len)
            return -EINVAL;
        len += (size_t)m;
    }
    return 0;
}

int fit_mlp_to_file(const struct fit_mlp *net, struct fit_model_file *f)
{
    char buf[FIT_MODEL_VALUE_MAX];
    double wd[FIT_MLP_MAX_LAYERS + 1];
    for (int l = 0; l <= net->n_layers; l++)
        wd[l] = net->width[l];
    int rc = append_list(buf, sizeof buf, wd, net->n_layers + 1, 0);
    rc = rc ? rc : fit_model_file_set(f, "widths", "%s", buf);
    rc = rc ? rc : fit_model_file_set(f, "activation", "relu");
    rc = rc ? rc : fit_model_file_set(f, "output", "log1p_f");
    /* %a: hexadecimal floats, so the normalisation comes back bit-exact. */
    rc = rc ? rc : append_list(buf, sizeof buf, net->offset, net->width[0], 1);
    rc = rc ? rc : fit_model_file_set(f, "input_offset", "%s", buf);
    rc = rc ? rc : append_list(buf, sizeof buf, net->scale, net->width[0], 1);
    rc = rc ? rc : fit_model_file_set(f, "input_scale", "%s", buf);
    rc = rc ? rc : fit_model_file_set_data(f, net->params, net->n_params);
    return rc;
}

/* Parse "a,b,c" into exactly n doubles. */
static int parse_list(const char *s, double *x, int n)
{
    for (int k = 0; k < n; k++) {
        char *end;
        errno = 0;
        x[k] = strtod(s, &end);
        if (end == s || errno == ERANGE || !isfinite(x[k]))
            return -1;
        if (k + 1 < n && *end != ',')
            return -1;
        s = end + (k + 1 < n);
        if (k + 1 == n && *end)
            return -1;
    }
    return 0;
}

int fit_mlp_from_file(const struct fit_model_file *f, const char *path, struct fit_mlp *net,
                      struct gonio_err *err)
{
    memset(net, 0, sizeof *net);
    const char *ws = fit_model_file_get(f, "widths");
    const char *act = fit_model_file_get(f, "activation");
    const char *out = fit_model_file_get(f, "output");
    const char *off = fit_model_file_get(f, "input_offset");
    const char *sc = fit_model_file_get(f, "input_scale");
    if (!ws || !act || !out || !off || !sc)
        return gonio_err_set(err, GONIO_EBADDATA,
                             "%s: %s model needs widths, activation, output, input_offset "
                             "and input_scale", path, f->kind);
    if (strcmp(act, "relu") || strcmp(out, "log1p_f"))
        return gonio_err_set(err, GONIO_EBADDATA,
                             "%s: activation '%s' / output '%s' not supported (relu, log1p_f)",
                             path, act, out);
    int commas = 0;
    for (const char *s = ws; *s; s++)
        commas += *s == ',';
    double wd[FIT_MLP_MAX_LAYERS + 1];
    int width[FIT_MLP_MAX_LAYERS + 1];
    if (commas < 1 || commas > FIT_MLP_MAX_LAYERS || parse_list(ws, wd, commas + 1))
        return gonio_err_set(err, GONIO_EBADDATA, "%s: bad widths '%s'", path, ws);
    for (int l = 0; l <= commas; l++) {
        if (wd[l] != floor(wd[l]) || wd[l] < 1 || wd[l] > FIT_MLP_MAX_WIDTH)
            return gonio_err_set(err, GONIO_EBADDATA, "%s: bad widths '%s'", path, ws);
        width[l] = (int)wd[l];
    }
    int rc = fit_mlp_init(net, commas, width, err);
    if (rc)
        return rc;
    if (parse_list(off, net->offset, width[0]) || parse_list(sc, net->scale, width[0])) {
        fit_mlp_free(net);
        return gonio_err_set(err, GONIO_EBADDATA, "%s: bad input_offset/input_scale", path);
    }
    if (f->n_data != net->n_params) {
        size_t want = net->n_params;
        fit_mlp_free(net);
        return gonio_err_set(err, GONIO_EBADDATA, "%s: %zu weights for widths %s (need %zu)",
                             path, f->n_data, ws, want);
    }
    for (size_t k = 0; k < f->n_data; k++)
        if (!isfinite(f->data[k])) {
            fit_mlp_free(net);
            return gonio_err_set(err, GONIO_EBADDATA, "%s: weight %zu is not finite", path, k);
        }
    memcpy(net->params, f->data, f->n_data * sizeof(double));
    return 0;
}
