/* Auto-decoder training: decoder weights and one latent per material,
 * jointly, with Adam, on fresh random pairs of each material's NBRDF
 * network at every step.
 *
 * Determinism: each (step, material) draws its pairs from its own
 * splitmix64 stream, and each material's gradient goes to its own buffer;
 * the buffers are summed in material order. So the weights depend on the
 * seed and the options only, not on the thread count or the scheduling. */
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/domain.h"
#include "brdf/nbrdf.h"
#include "common/paths.h"
#include "fit/latent_private.h"

#define LT_PI 3.14159265358979323846
/* Training pairs keep both polar angles at most this: a little beyond the
 * 80-degree evaluation domain, where NBRDF extrapolations turn wild. */
#define LT_MAX_THETA_DEG 85.0

struct latent_train_options latent_train_default_options(void)
{
    return (struct latent_train_options){
        .nz = 12,
        .layers = 2,
        .width = 64,
        .steps = 12000,
        .samples_per_step = 32,
        .lr = 2e-3,
        .lr_z = 1e-2,
        .lambda_z = 1e-3,
        .z_noise = 0,
        .inplane = 0,
        .seed = 1,
        .threads = 2,
    };
}

static int is_heldout(const char *name)
{
    for (size_t i = 0; i < 10; i++)
        if (!strcmp(name, latent_heldout_materials[i]))
            return 1;
    return 0;
}

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

void latent_names_free(char **names, size_t n)
{
    if (!names)
        return;
    for (size_t i = 0; i < n; i++)
        free(names[i]);
    free(names);
}

int latent_default_training_set(char ***names, size_t *n, struct gonio_err *err)
{
    const char *shared = gonio_shared_dir();
    if (!shared)
        return gonio_err_set(err, GONIO_ENOTFOUND,
                             "shared data folder not found (set GONIO_SHARED)");
    char dir[4096];
    snprintf(dir, sizeof dir, "%s/data/merl/nbrdf_f32", shared);
    DIR *dp = opendir(dir);
    if (!dp)
        return gonio_err_set(err, GONIO_ENOTFOUND, "%s: cannot open: %s", dir, strerror(errno));
    size_t cap = 128, k = 0;
    char **v = malloc(cap * sizeof *v);
    struct dirent *e;
    while (v && (e = readdir(dp))) {
        size_t len = strlen(e->d_name);
        if (len <= 6 || strcmp(e->d_name + len - 6, ".nbrdf") != 0)
            continue;
        if (len - 6 >= LATENT_NAME_MAX)
            continue;
        char *s = strndup(e->d_name, len - 6);
        if (!s)
            break;
        if (is_heldout(s)) {
            free(s);
            continue;
        }
        if (k == cap) {
            char **nv = realloc(v, 2 * cap * sizeof *v);
            if (!nv) {
                free(s);
                break;
            }
            v = nv;
            cap *= 2;
        }
        v[k++] = s;
    }
    closedir(dp);
    if (!v)
        return gonio_err_set(err, ENOMEM, "%s: out of memory", dir);
    qsort(v, k, sizeof *v, cmp_str);
    if (k == 0) {
        free(v);
        return gonio_err_set(err, GONIO_ENOTFOUND, "%s: no training .nbrdf files", dir);
    }
    *names = v;
    *n = k;
    return 0;
}

/* Uniform in [0, 1) from the top 53 bits. */
static double unif(uint64_t *s)
{
    return (double)(brdf_splitmix64(s) >> 11) * (1.0 / 9007199254740992.0);
}

/* Approximately normal (sum of 4 uniforms, variance 1 after scaling):
 * enough for initial weights, and exactly reproducible. */
static double gauss(uint64_t *s)
{
    double a = unif(s) + unif(s) + unif(s) + unif(s) - 2.0;
    return a * sqrt(3.0);
}

struct batch {
    double *x, *c, *t; /* [S][6], [S], [S][3] */
    struct brdf_pair *pairs;
    double *f;
};

/* S random pairs of net: theta_h = u^2 pi/2 (dense near the specular peak,
 * as the MERL grid the errors are measured on), theta_d uniform, phi_d
 * uniform over the full circle; pairs with a polar angle past
 * LT_MAX_THETA_DEG are redrawn. */
static void draw_batch(const struct brdf_nbrdf *net, uint64_t stream, int S, double inplane,
                       struct batch *b)
{
    const double lim = cos(LT_MAX_THETA_DEG * BRDF_DEG);
    uint64_t s = stream;
    for (int k = 0; k < S; k++) {
        struct brdf_pair *p = &b->pairs[k];
        do {
            double u = unif(&s), v = unif(&s), w = unif(&s);
            double pd = (2 * w - 1) * LT_PI;
            if (inplane > 0 && unif(&s) < inplane)
                pd = w < 0.5 ? 0.0 : LT_PI; /* where the rig measures */
            brdf_pair_from_hd(u * u * LT_PI / 2, v * LT_PI / 2, pd, p);
        } while (p->wi[2] < lim || p->wo[2] < lim);
    }
    brdf_nbrdf_eval(net, b->pairs, (size_t)S, b->f);
    for (int k = 0; k < S; k++) {
        latent_encode(&b->pairs[k], b->x + LATENT_NIN * k);
        double c = b->pairs[k].wi[2];
        b->c[k] = c;
        for (int ch = 0; ch < 3; ch++) {
            double f = b->f[3 * k + ch];
            b->t[3 * k + ch] = log1p((f > 0 ? f : 0) * c);
        }
    }
}

struct train_ctx {
    latent_decoder *d;
    const struct brdf_nbrdf *nets;
    size_t M;
    int S;
    long step;
    uint64_t seed;
    double scale;
    double *gw;   /* [M][n_params] */
    double *gz;   /* [M][nz] */
    double *loss; /* [M] */
    int threads;
};

struct worker {
    struct train_ctx *ctx;
    int id;
    struct batch b;
};

static void *work(void *arg)
{
    struct worker *w = arg;
    struct train_ctx *c = w->ctx;
    latent_decoder *d = c->d;
    for (size_t m = (size_t)w->id; m < c->M; m += (size_t)c->threads) {
        uint64_t stream = c->seed ^ (0x9e3779b97f4a7c15ULL * (uint64_t)(c->step + 1)) ^
                          (0xbf58476d1ce4e5b9ULL * (uint64_t)(m + 1));
        draw_batch(&c->nets[m], stream, c->S, d->train.inplane, &w->b);
        double *gw = c->gw + m * d->n_params, *gz = c->gz + m * (size_t)d->nz;
        memset(gw, 0, d->n_params * sizeof *gw);
        memset(gz, 0, (size_t)d->nz * sizeof *gz);
        /* Latent noise: the decoder must answer well in a neighbourhood of
         * each training latent, which smooths it in z (the gradient with
         * respect to the noisy z is the gradient with respect to z). */
        double z[LATENT_MAX_NZ];
        memcpy(z, d->latents + m * (size_t)d->nz, (size_t)d->nz * sizeof *z);
        if (d->train.z_noise > 0) {
            uint64_t ns = stream ^ 0x94d049bb133111ebULL;
            for (int k = 0; k < d->nz; k++)
                z[k] += d->train.z_noise * gauss(&ns);
        }
        c->loss[m] = latent_net_backprop(d, z, (size_t)c->S, w->b.x, w->b.c, w->b.t, NULL, NULL, c->scale,
                                         gw, gz);
    }
    return NULL;
}

static void adam(double *p, const double *g, double *m1, double *m2, size_t n, double lr,
                 long t)
{
    const double b1 = 0.9, b2 = 0.999, eps = 1e-8;
    double c1 = 1 - pow(b1, (double)t), c2 = 1 - pow(b2, (double)t);
    for (size_t i = 0; i < n; i++) {
        m1[i] = b1 * m1[i] + (1 - b1) * g[i];
        m2[i] = b2 * m2[i] + (1 - b2) * g[i] * g[i];
        p[i] -= lr * (m1[i] / c1) / (sqrt(m2[i] / c2) + eps);
    }
}

static double schedule(double lr, long step, long steps)
{
    /* cosine decay to lr / 50 */
    double q = steps > 1 ? (double)step / (double)(steps - 1) : 1.0;
    return lr * (0.02 + 0.98 * 0.5 * (1 + cos(LT_PI * q)));
}

int latent_train(const char *const *materials, size_t n, const struct latent_train_options *opt,
                 latent_decoder **out, struct gonio_err *err)
{
    struct latent_train_options o = opt ? *opt : latent_train_default_options();
    *out = NULL;
    if (n == 0)
        return gonio_err_set(err, GONIO_EUSAGE, "latent_train: no training materials");
    if (o.samples_per_step < 1 || o.steps < 1 || o.threads < 1 || o.threads > 64)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "latent_train: steps %ld, samples_per_step %d, threads %d: each "
                             "must be >= 1 (threads <= 64)",
                             o.steps, o.samples_per_step, o.threads);
    for (size_t m = 0; m < n; m++) {
        if (is_heldout(materials[m]))
            return gonio_err_set(err, GONIO_EUSAGE,
                                 "latent_train: '%s' is a held-out material, never trained on",
                                 materials[m]);
        if (strlen(materials[m]) >= LATENT_NAME_MAX || strchr(materials[m], ' '))
            return gonio_err_set(err, GONIO_EUSAGE, "latent_train: bad material name '%s'",
                                 materials[m]);
    }
    /* After the names: a wrong request is refused as such with or without
     * the data. */
    const char *shared = gonio_shared_dir();
    if (!shared)
        return gonio_err_set(err, GONIO_ENOTFOUND,
                             "shared data folder not found (set GONIO_SHARED)");
    latent_decoder *d = latent_decoder_alloc(o.nz, o.layers, o.width, n);
    if (!d)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "latent_train: shape nz %d, layers %d, width %d out of range", o.nz,
                             o.layers, o.width);
    d->train = o;
    struct brdf_nbrdf *nets = calloc(n, sizeof *nets);
    struct train_ctx ctx = {.d = d, .nets = nets, .M = n, .S = o.samples_per_step,
                            .seed = o.seed, .threads = o.threads};
    ctx.gw = calloc(n * d->n_params, sizeof *ctx.gw);
    ctx.gz = calloc(n * (size_t)d->nz, sizeof *ctx.gz);
    ctx.loss = calloc(n, sizeof *ctx.loss);
    size_t nl = n * (size_t)d->nz;
    double *g = calloc(d->n_params, sizeof *g), *m1 = calloc(d->n_params, sizeof *m1),
           *m2 = calloc(d->n_params, sizeof *m2);
    double *gzr = calloc(nl, sizeof *gzr), *z1 = calloc(nl, sizeof *z1),
           *z2 = calloc(nl, sizeof *z2);
    struct worker *wk = calloc((size_t)o.threads, sizeof *wk);
    int rc = 0;
    if (!nets || !ctx.gw || !ctx.gz || !ctx.loss || !g || !m1 || !m2 || !gzr || !z1 || !z2 ||
        !wk) {
        rc = gonio_err_set(err, ENOMEM, "latent_train: out of memory");
        goto done;
    }
    for (int t = 0; t < o.threads; t++) {
        size_t S = (size_t)o.samples_per_step;
        wk[t].ctx = &ctx;
        wk[t].id = t;
        wk[t].b.x = malloc(S * LATENT_NIN * sizeof(double));
        wk[t].b.c = malloc(S * sizeof(double));
        wk[t].b.t = malloc(S * 3 * sizeof(double));
        wk[t].b.f = malloc(S * 3 * sizeof(double));
        wk[t].b.pairs = malloc(S * sizeof(struct brdf_pair));
        if (!wk[t].b.x || !wk[t].b.c || !wk[t].b.t || !wk[t].b.f || !wk[t].b.pairs) {
            rc = gonio_err_set(err, ENOMEM, "latent_train: out of memory");
            goto done;
        }
    }
    for (size_t m = 0; m < n; m++) {
        char path[4200];
        snprintf(path, sizeof path, "%s/data/merl/nbrdf_f32/%s.nbrdf", shared, materials[m]);
        if ((rc = brdf_nbrdf_load(path, &nets[m], err)) < 0)
            goto done;
        snprintf(d->names[m], LATENT_NAME_MAX, "%s", materials[m]);
    }
    /* He initialisation; latents small (DeepSDF: N(0, 0.01^2)). */
    uint64_t rs = o.seed ^ 0x6a09e667f3bcc908ULL;
    for (int l = 0; l <= d->layers; l++) {
        double sd = sqrt(2.0 / d->din[l]);
        size_t cnt = (size_t)d->din[l] * (size_t)d->dout[l];
        for (size_t i = 0; i < cnt; i++)
            d->params[d->off_w[l] + i] = sd * gauss(&rs);
    }
    for (size_t i = 0; i < nl; i++)
        d->latents[i] = 0.01 * gauss(&rs);

    /* Loss = (1/M) sum_m [ mean |r| over its S x 3 residuals + lambda_z mean(z_m^2) ]. */
    ctx.scale = 1.0 / ((double)n * 3.0 * o.samples_per_step);
    double run_loss = 0;
    long report_every = o.steps / 20 > 0 ? o.steps / 20 : 1;
    pthread_t tid[64];
    for (long step = 0; step < o.steps; step++) {
        ctx.step = step;
        int started = 0;
        for (int t = 1; t < o.threads; t++) {
            if (pthread_create(&tid[t], NULL, work, &wk[t]) != 0)
                break;
            started = t;
        }
        work(&wk[0]);
        for (int t = 1; t <= started; t++)
            pthread_join(tid[t], NULL);
        for (int t = started + 1; t < o.threads; t++)
            work(&wk[t]); /* a thread that could not start: same work, same result */
        memset(g, 0, d->n_params * sizeof *g);
        double loss = 0;
        for (size_t m = 0; m < n; m++) {
            const double *gm = ctx.gw + m * d->n_params;
            for (size_t i = 0; i < d->n_params; i++)
                g[i] += gm[i];
            loss += ctx.loss[m];
        }
        for (size_t i = 0; i < nl; i++)
            gzr[i] = ctx.gz[i] + 2.0 * o.lambda_z / (d->nz * (double)n) * d->latents[i];
        adam(d->params, g, m1, m2, d->n_params, schedule(o.lr, step, o.steps), step + 1);
        adam(d->latents, gzr, z1, z2, nl, schedule(o.lr_z, step, o.steps), step + 1);
        loss *= ctx.scale;
        run_loss = step == 0 ? loss : 0.98 * run_loss + 0.02 * loss;
        if (o.on_progress && ((step + 1) % report_every == 0 || step + 1 == o.steps))
            o.on_progress(o.progress_ctx, step + 1, o.steps, run_loss);
        if (!isfinite(loss)) {
            rc = gonio_err_set(err, GONIO_EFIT, "latent_train: loss not finite at step %ld",
                               step + 1);
            goto done;
        }
    }
    latent_decoder_refresh(d);
    *out = d;
    d = NULL;
done:
    if (wk)
        for (int t = 0; t < o.threads; t++) {
            free(wk[t].b.x);
            free(wk[t].b.c);
            free(wk[t].b.t);
            free(wk[t].b.f);
            free(wk[t].b.pairs);
        }
    free(wk);
    free(nets);
    free(ctx.gw);
    free(ctx.gz);
    free(ctx.loss);
    free(g);
    free(m1);
    free(m2);
    free(gzr);
    free(z1);
    free(z2);
    latent_decoder_free(d);
    return rc;
}
