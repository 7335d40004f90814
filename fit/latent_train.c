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

/* A request latent_train refuses before it reads any data. */
static int check_request(const char *const *materials, size_t n,
                         const struct latent_train_options *o, struct gonio_err *err)
{
    if (n == 0)
        return gonio_err_set(err, GONIO_EUSAGE, "latent_train: no training materials");
    if (o->samples_per_step < 1 || o->steps < 1 || o->threads < 1 || o->threads > 64)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "latent_train: steps %ld, samples_per_step %d, threads %d: each "
                             "must be >= 1 (threads <= 64)",
                             o->steps, o->samples_per_step, o->threads);
    for (size_t m = 0; m < n; m++) {
        if (is_heldout(materials[m]))
            return gonio_err_set(err, GONIO_EUSAGE,
                                 "latent_train: '%s' is a held-out material, never trained on",
                                 materials[m]);
        if (strlen(materials[m]) >= LATENT_NAME_MAX || strchr(materials[m], ' '))
            return gonio_err_set(err, GONIO_EUSAGE, "latent_train: bad material name '%s'",
                                 materials[m]);
    }
    return 0;
}

/* A training run's state besides the decoder: the per-material gradients
 * (ctx), the summed ones, the Adam moments and the workers. */
struct trainer {
    struct train_ctx ctx;
    struct brdf_nbrdf *nets; /* [M], ctx.nets */
    size_t nl;           /* number of latent coordinates: M nz */
    double *g, *m1, *m2; /* decoder weights: gradient, Adam moments */
    double *gzr, *z1, *z2; /* latents: regularised gradient, Adam moments */
    struct worker *wk;   /* [threads] */
};

static void trainer_free(struct trainer *tr)
{
    if (tr->wk)
        for (int t = 0; t < tr->ctx.threads; t++) {
            free(tr->wk[t].b.x);
            free(tr->wk[t].b.c);
            free(tr->wk[t].b.t);
            free(tr->wk[t].b.f);
            free(tr->wk[t].b.pairs);
        }
    free(tr->wk);
    free(tr->nets);
    free(tr->ctx.gw);
    free(tr->ctx.gz);
    free(tr->ctx.loss);
    free(tr->g);
    free(tr->m1);
    free(tr->m2);
    free(tr->gzr);
    free(tr->z1);
    free(tr->z2);
}

/* Every buffer of a run for decoder d on n materials; tr is freed by
 * trainer_free whether or not this succeeds. */
static int trainer_alloc(struct trainer *tr, latent_decoder *d, size_t n,
                         const struct latent_train_options *o, struct gonio_err *err)
{
    struct brdf_nbrdf *nets = tr->nets = calloc(n, sizeof *nets);
    tr->ctx = (struct train_ctx){.d = d, .nets = nets, .M = n, .S = o->samples_per_step,
                                 .seed = o->seed, .threads = o->threads};
    tr->ctx.gw = calloc(n * d->n_params, sizeof *tr->ctx.gw);
    tr->ctx.gz = calloc(n * (size_t)d->nz, sizeof *tr->ctx.gz);
    tr->ctx.loss = calloc(n, sizeof *tr->ctx.loss);
    size_t nl = tr->nl = n * (size_t)d->nz;
    tr->g = calloc(d->n_params, sizeof *tr->g);
    tr->m1 = calloc(d->n_params, sizeof *tr->m1);
    tr->m2 = calloc(d->n_params, sizeof *tr->m2);
    tr->gzr = calloc(nl, sizeof *tr->gzr);
    tr->z1 = calloc(nl, sizeof *tr->z1);
    tr->z2 = calloc(nl, sizeof *tr->z2);
    tr->wk = calloc((size_t)o->threads, sizeof *tr->wk);
    if (!nets || !tr->ctx.gw || !tr->ctx.gz || !tr->ctx.loss || !tr->g || !tr->m1 || !tr->m2 ||
        !tr->gzr || !tr->z1 || !tr->z2 || !tr->wk)
        return gonio_err_set(err, ENOMEM, "latent_train: out of memory");
    for (int t = 0; t < o->threads; t++) {
        size_t S = (size_t)o->samples_per_step;
        struct worker *w = &tr->wk[t];
        w->ctx = &tr->ctx;
        w->id = t;
        w->b.x = malloc(S * LATENT_NIN * sizeof(double));
        w->b.c = malloc(S * sizeof(double));
        w->b.t = malloc(S * 3 * sizeof(double));
        w->b.f = malloc(S * 3 * sizeof(double));
        w->b.pairs = malloc(S * sizeof(struct brdf_pair));
        if (!w->b.x || !w->b.c || !w->b.t || !w->b.f || !w->b.pairs)
            return gonio_err_set(err, ENOMEM, "latent_train: out of memory");
    }
    return 0;
}

/* Each material's NBRDF network from the shared data, its name into d. */
static int load_nets(const char *const *materials, size_t n, const char *shared,
                     struct brdf_nbrdf *nets, latent_decoder *d, struct gonio_err *err)
{
    for (size_t m = 0; m < n; m++) {
        char path[4200];
        snprintf(path, sizeof path, "%s/data/merl/nbrdf_f32/%s.nbrdf", shared, materials[m]);
        int rc = brdf_nbrdf_load(path, &nets[m], err);
        if (rc < 0)
            return rc;
        snprintf(d->names[m], LATENT_NAME_MAX, "%s", materials[m]);
    }
    return 0;
}

/* He initialisation; latents small (DeepSDF: N(0, 0.01^2)). */
static void init_decoder(latent_decoder *d, size_t nl, uint64_t seed)
{
    uint64_t rs = seed ^ 0x6a09e667f3bcc908ULL;
    for (int l = 0; l <= d->layers; l++) {
        double sd = sqrt(2.0 / d->din[l]);
        size_t cnt = (size_t)d->din[l] * (size_t)d->dout[l];
        for (size_t i = 0; i < cnt; i++)
            d->params[d->off_w[l] + i] = sd * gauss(&rs);
    }
    for (size_t i = 0; i < nl; i++)
        d->latents[i] = 0.01 * gauss(&rs);
}

/* Every material's gradient, on the workers' threads (or on this one for
 * a thread that could not start: same work, same result). */
static void gradients(struct trainer *tr)
{
    pthread_t tid[64];
    int threads = tr->ctx.threads, started = 0;
    for (int t = 1; t < threads; t++) {
        if (pthread_create(&tid[t], NULL, work, &tr->wk[t]) != 0)
            break;
        started = t;
    }
    work(&tr->wk[0]);
    for (int t = 1; t <= started; t++)
        pthread_join(tid[t], NULL);
    for (int t = started + 1; t < threads; t++)
        work(&tr->wk[t]);
}

/* One training step: the gradients summed in material order, one Adam
 * step each for the weights and the latents. The step's loss. */
static double train_step(struct trainer *tr, const struct latent_train_options *o, long step)
{
    latent_decoder *d = tr->ctx.d;
    size_t n = tr->ctx.M;
    tr->ctx.step = step;
    gradients(tr);
    memset(tr->g, 0, d->n_params * sizeof *tr->g);
    double loss = 0;
    for (size_t m = 0; m < n; m++) {
        const double *gm = tr->ctx.gw + m * d->n_params;
        for (size_t i = 0; i < d->n_params; i++)
            tr->g[i] += gm[i];
        loss += tr->ctx.loss[m];
    }
    for (size_t i = 0; i < tr->nl; i++)
        tr->gzr[i] = tr->ctx.gz[i] + 2.0 * o->lambda_z / (d->nz * (double)n) * d->latents[i];
    adam(d->params, tr->g, tr->m1, tr->m2, d->n_params, schedule(o->lr, step, o->steps),
         step + 1);
    adam(d->latents, tr->gzr, tr->z1, tr->z2, tr->nl, schedule(o->lr_z, step, o->steps),
         step + 1);
    return loss * tr->ctx.scale;
}

int latent_train(const char *const *materials, size_t n, const struct latent_train_options *opt,
                 latent_decoder **out, struct gonio_err *err)
{
    struct latent_train_options o = opt ? *opt : latent_train_default_options();
    *out = NULL;
    int rc = check_request(materials, n, &o, err);
    if (rc < 0)
        return rc;
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
    struct trainer tr = {0};
    if ((rc = trainer_alloc(&tr, d, n, &o, err)) < 0)
        goto done;
    if ((rc = load_nets(materials, n, shared, tr.nets, d, err)) < 0)
        goto done;
    init_decoder(d, tr.nl, o.seed);

    /* Loss = (1/M) sum_m [ mean |r| over its S x 3 residuals + lambda_z mean(z_m^2) ]. */
    tr.ctx.scale = 1.0 / ((double)n * 3.0 * o.samples_per_step);
    double run_loss = 0;
    long report_every = o.steps / 20 > 0 ? o.steps / 20 : 1;
    for (long step = 0; step < o.steps; step++) {
        double loss = train_step(&tr, &o, step);
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
    trainer_free(&tr);
    latent_decoder_free(d);
    return rc;
}
