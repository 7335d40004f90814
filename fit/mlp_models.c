/* The RGB and spectral MLPs as registry models (fit/models.h): gathering
 * training rows from samples, writing model files, and materials. */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/colour.h"
#include "brdf/material_private.h"
#include "fit/mlp.h"
#include "fit/model_file.h"
#include "fit/sample_order.h"

#define RGB_VERSION 1
#define SPECTRAL_VERSION 1

static const int rgb_widths[] = {2, 20, 20, 20, 20, 20, 3};
static const int spectral_widths[] = {3, 10, 10, 10, 1};

/* In-plane angles of a pair whose directions and the normal are coplanar
 * to within tol (fit/mlp.h): an isotropic material's value there is its
 * value in the incidence plane, so the pair is first turned about the
 * normal into the x-z plane and its off-plane part dropped, keeping
 * theta_i and theta_o. Returns -1 for a pair farther out of its plane. */
int fit_mlp_inplane_angles(const struct brdf_pair *p, double tol, double *ti, double *tr)
{
    const double *a = p->wi, *b = p->wo;
    double ra = hypot(a[0], a[1]), rb = hypot(b[0], b[1]);
    /* The sine of the out-of-plane angle of the direction nearer the
     * normal, from the plane of the other and the normal. */
    double big = ra > rb ? ra : rb;
    if (fabs(a[0] * b[1] - a[1] * b[0]) > tol * big + 1e-9 * (1.0 + ra * rb))
        return -1;
    if (fabs(a[1]) <= 1e-9 && fabs(b[1]) <= 1e-9)
        return brdf_pair_to_inplane(p, ti, tr);
    const double *ref = ra >= rb ? a : b;
    double cs = ref[0] / big, sn = ref[1] / big;
    double ax = cs * a[0] + sn * a[1], bx = cs * b[0] + sn * b[1];
    /* the horizontal parts' lengths kept, along +-x */
    double ai[3] = {ax < 0 ? -ra : ra, 0, a[2]};
    double bo[3] = {bx < 0 ? -rb : rb, 0, b[2]};
    struct brdf_pair q;
    brdf_pair_from_dirs(ai, bo, &q);
    return brdf_pair_to_inplane(&q, ti, tr);
}

/* Distinct (theta_i, theta_r) among m training rows u (stride values a
 * row), a reciprocal twin (twin[i] < i) not counted again. */
static size_t row_geometries(const double *u, size_t stride, const size_t *twin, size_t m)
{
    double(*p)[2] = malloc((m ? m : 1) * sizeof *p);
    if (!p)
        return 0;
    size_t k = 0;
    for (size_t i = 0; i < m; i++)
        if (twin[i] == SIZE_MAX || twin[i] > i) {
            p[k][0] = u[stride * i];
            p[k][1] = u[stride * i + 1];
            k++;
        }
    size_t g = fit_status_distinct_pairs(p, k);
    free(p);
    return g;
}

/* Held-out rows below which a network's held-out residual is a guess. */
#define MLP_MIN_HELDOUT 10

/* A network's status: its weights outnumber any capture, so what checks it
 * is its held-out rows: with fewer than MLP_MIN_HELDOUT (DS4's 6 samples
 * give 12 rows with their reciprocals, 2 held out) it is underdetermined;
 * their RMS log error is the held-out residual; an epoch limit is not
 * convergence. */
static struct fit_status mlp_status(const struct fit_mlp_train_report *r, size_t geometries)
{
    struct fit_status st = fit_status_init();
    st.geometries = geometries;
    st.insample = sqrt(r->train_loss);
    st.heldout = r->n_val ? sqrt(r->val_loss) : NAN;
    if (!r->early_stopped)
        st.findings |= 1u << FIT_STATUS_NOT_CONVERGED;
    if (r->n_val < MLP_MIN_HELDOUT)
        st.findings |= 1u << FIT_STATUS_UNDERDETERMINED;
    fit_status_decide(&st);
    return st;
}

static void set_train_keys(struct fit_model_file *f, const struct fit_model_options *opt,
                           const struct fit_mlp_train_report *r, const struct fit_status *st)
{
    fit_model_file_set(f, "seed", "%llu", (unsigned long long)opt->seed);
    fit_model_file_set(f, "epochs", "%d", r->epochs);
    fit_model_file_set(f, "best_epoch", "%d", r->best_epoch);
    fit_model_file_set(f, "rows_train", "%zu", r->n_train);
    fit_model_file_set(f, "rows_heldout", "%zu", r->n_val);
    fit_model_file_set(f, "loss_train", "%.6g", r->train_loss);
    fit_model_file_set(f, "loss_heldout", "%.6g", r->val_loss);
    fit_status_file_keys(f, st);
}

static void fill_report(struct fit_model_report *rep, const struct fit_mlp_train_report *r,
                        const struct fit_status *st, size_t left_out)
{
    if (!rep)
        return;
    rep->converged = r->early_stopped;
    rep->status = *st;
    snprintf(rep->note, sizeof rep->note,
             "%d epochs (%s), weights of epoch %d; loss %.3g -> %.3g train, %.3g held-out "
             "(%zu/%zu rows)%s",
             r->epochs, r->early_stopped ? "early stop" : "epoch limit", r->best_epoch,
             r->train_loss0, r->train_loss, r->val_loss, r->n_train, r->n_val,
             left_out ? "; out-of-plane or unusable samples left out" : "");
}

/* Train the RGB network on the usable in-plane samples. */
int fit_mlp_rgb_train_samples(const struct fit_sample *s, size_t n, const unsigned char *lower,
                              uint64_t seed,
                              int max_epochs, int quiet, struct fit_mlp *net,
                              struct fit_mlp_train_report *rep, size_t *left_out,
                              size_t *geometries, struct gonio_err *err)
{
    /* The samples in canonical order (fit/sample_order.h): the held-out
     * rows and the batches are drawn by row, from the seed. */
    struct fit_sample *sorted;
    unsigned char *sorted_lower;
    if (fit_samples_canonical(s, lower, n, &sorted, &sorted_lower) < 0)
        return gonio_err_set(err, ENOMEM, "mlp: out of memory");
    s = sorted;
    lower = sorted_lower;
    /* Two rows a sample: itself and its reciprocal. */
    size_t cap = 2 * (n ? n : 1);
    double *u = malloc(cap * 2 * sizeof *u), *f = malloc(cap * 3 * sizeof *f),
           *c = malloc(cap * sizeof *c);
    size_t *twin = malloc(cap * sizeof *twin);
    unsigned char *lo = lower ? malloc(cap) : NULL;
    if (!u || !f || !c || !twin || (lower && !lo)) {
        free(u);
        free(f);
        free(c);
        free(twin);
        free(lo);
        free(sorted);
        free(sorted_lower);
        return gonio_err_set(err, ENOMEM, "mlp: out of memory");
    }
    size_t m = 0, used = 0;
    for (size_t i = 0; i < n; i++) {
        double ti, tr;
        if (fit_mlp_inplane_angles(&s[i].g, FIT_MLP_PLANE_TOL, &ti, &tr) ||
            !(s[i].g.wi[2] > 0) || !(s[i].g.wo[2] > 0))
            continue;
        if (!isfinite(s[i].rgb[0]) || !isfinite(s[i].rgb[1]) || !isfinite(s[i].rgb[2]))
            continue;
        used++;
        u[2 * m] = ti;
        u[2 * m + 1] = tr;
        memcpy(f + 3 * m, s[i].rgb, sizeof s[i].rgb);
        c[m] = s[i].g.wi[2];
        twin[m] = SIZE_MAX;
        if (lo)
            lo[m] = lower[i] != 0;
        m++;
        /* Helmholtz reciprocity: light and detector swapped is the same
         * value. In-plane, (ti, tr) swaps to (tr, ti) for tr >= 0 and to
         * (-tr, -ti) for tr < 0 (brdf_pair_to_inplane's theta_i >= 0). A
         * sparse grid's samples then also cover its theta_r values as
         * incidence angles, which is where a DS2 grid is thinnest. */
        double ti2 = tr >= 0 ? tr : -tr, tr2 = tr >= 0 ? ti : -ti;
        if (fabs(ti2 - ti) < 1e-9 && fabs(tr2 - tr) < 1e-9)
            continue;
        u[2 * m] = ti2;
        u[2 * m + 1] = tr2;
        memcpy(f + 3 * m, s[i].rgb, sizeof s[i].rgb);
        c[m] = cos(ti2 * BRDF_DEG);
        twin[m] = m - 1;
        twin[m - 1] = m;
        if (lo)
            lo[m] = lo[m - 1];
        m++;
    }
    if (left_out)
        *left_out = n - used;
    if (geometries)
        *geometries = row_geometries(u, 2, twin, m);
    int rc;
    if (used < 4) {
        rc = gonio_err_set(err, GONIO_EFIT, "mlp: %zu usable in-plane samples (need 4)", used);
    } else {
        rc = fit_mlp_init(net, 6, rgb_widths, err);
        if (!rc) {
            struct fit_mlp_train_options o = fit_mlp_default_train_options();
            o.seed = seed;
            o.max_epochs = max_epochs;
            o.quiet = quiet;
            o.twin = twin;
            o.lower = lo;
            rc = fit_mlp_train(net, u, f, c, m, &o, rep, err);
            if (rc)
                fit_mlp_free(net);
        }
    }
    free(u);
    free(f);
    free(c);
    free(twin);
    free(lo);
    free(sorted);
    free(sorted_lower);
    return rc;
}

int fit_mlp_rgb_fit(const struct fit_data *data, const struct fit_model_options *opt,
                    struct fit_model_file **out, struct fit_model_report *rep,
                    struct gonio_err *err)
{
    struct fit_model_options o = opt ? *opt : fit_model_default_options();
    if (!data->n_rgb)
        return gonio_err_set(err, GONIO_EUSAGE, "mlp: needs RGB samples");
    struct fit_mlp net;
    struct fit_mlp_train_report r;
    size_t left_out, geometries;
    int rc = fit_mlp_rgb_train_samples(data->rgb, data->n_rgb, data->rgb_lower, o.seed,
                                       o.max_epochs, o.quiet,
                                       &net, &r, &left_out, &geometries, err);
    if (rc)
        return rc;
    struct fit_model_file *f = fit_model_file_new("mlp", RGB_VERSION);
    rc = f ? fit_model_file_set(f, "inputs", "theta_i_deg,theta_r_deg") : -ENOMEM;
    rc = rc ? rc : fit_model_file_set(f, "outputs", "r,g,b");
    rc = rc ? rc : fit_mlp_to_file(&net, f);
    fit_mlp_free(&net);
    if (rc) {
        fit_model_file_free(f);
        return gonio_err_set(err, ENOMEM, "mlp: out of memory");
    }
    struct fit_status st = mlp_status(&r, geometries);
    set_train_keys(f, &o, &r, &st);
    fill_report(rep, &r, &st, left_out);
    *out = f;
    return 0;
}

int fit_mlp_spectral_fit(const struct fit_data *data, const struct fit_model_options *opt,
                         struct fit_model_file **out, struct fit_model_report *rep,
                         struct gonio_err *err)
{
    struct fit_model_options o = opt ? *opt : fit_model_default_options();
    size_t n = data->n_spectral;
    if (!n)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "mlp-spectral: needs spectral samples (theta_i,theta_r,"
                             "wavelength_nm,value)");
    /* Each sample and its reciprocal, as for the RGB network. */
    double *u = malloc(2 * n * 3 * sizeof *u), *f = malloc(2 * n * sizeof *f),
           *c = malloc(2 * n * sizeof *c);
    size_t *twin = malloc(2 * n * sizeof *twin);
    unsigned char *lo = malloc(2 * n);
    if (!u || !f || !c || !twin || !lo) {
        free(u);
        free(f);
        free(c);
        free(twin);
        free(lo);
        return gonio_err_set(err, ENOMEM, "mlp-spectral: out of memory");
    }
    int any_lower = 0;
    size_t m = 0, used = 0;
    for (size_t i = 0; i < n; i++) {
        const struct fit_spectral_sample *s = &data->spectral[i];
        /* theta_i >= 0 by convention: a negative one is the mirrored plane. */
        double ti = s->theta_i < 0 ? -s->theta_i : s->theta_i;
        double tr = s->theta_i < 0 ? -s->theta_r : s->theta_r;
        double ci = cos(ti * BRDF_DEG);
        if (!isfinite(ti) || !isfinite(tr) || !isfinite(s->wavelength_nm) ||
            !isfinite(s->value) || !(ci > 0) || fabs(tr) >= 90)
            continue;
        used++;
        u[3 * m] = ti;
        u[3 * m + 1] = tr;
        u[3 * m + 2] = s->wavelength_nm;
        f[m] = s->value;
        c[m] = ci;
        twin[m] = SIZE_MAX;
        lo[m] = s->saturated != 0;
        any_lower |= lo[m];
        m++;
        double ti2 = tr >= 0 ? tr : -tr, tr2 = tr >= 0 ? ti : -ti;
        if (fabs(ti2 - ti) < 1e-9 && fabs(tr2 - tr) < 1e-9)
            continue;
        u[3 * m] = ti2;
        u[3 * m + 1] = tr2;
        u[3 * m + 2] = s->wavelength_nm;
        f[m] = s->value;
        c[m] = cos(ti2 * BRDF_DEG);
        twin[m] = m - 1;
        twin[m - 1] = m;
        lo[m] = lo[m - 1];
        m++;
    }
    int rc = 0;
    size_t geometries = row_geometries(u, 3, twin, m);
    struct fit_mlp net = {0};
    struct fit_mlp_train_report r;
    if (used < 4)
        rc = gonio_err_set(err, GONIO_EFIT, "mlp-spectral: %zu usable samples (need 4)", used);
    if (!rc)
        rc = fit_mlp_init(&net, 4, spectral_widths, err);
    if (!rc) {
        struct fit_mlp_train_options to = fit_mlp_default_train_options();
        to.seed = o.seed;
        to.max_epochs = o.max_epochs;
        to.quiet = o.quiet;
        to.twin = twin;
        to.lower = any_lower ? lo : NULL;
        rc = fit_mlp_train(&net, u, f, c, m, &to, &r, err);
    }
    free(u);
    free(f);
    free(c);
    free(twin);
    free(lo);
    struct fit_model_file *mf = NULL;
    if (!rc) {
        mf = fit_model_file_new("mlp-spectral", SPECTRAL_VERSION);
        rc = mf ? fit_model_file_set(mf, "inputs", "theta_i_deg,theta_r_deg,wavelength_nm")
                : -ENOMEM;
        rc = rc ? rc : fit_model_file_set(mf, "outputs", "value");
        rc = rc ? rc : fit_mlp_to_file(&net, mf);
        if (rc)
            rc = gonio_err_set(err, ENOMEM, "mlp-spectral: out of memory");
    }
    fit_mlp_free(&net);
    if (rc) {
        fit_model_file_free(mf);
        return rc;
    }
    struct fit_status st = mlp_status(&r, geometries);
    set_train_keys(mf, &o, &r, &st);
    fill_report(rep, &r, &st, n - used);
    *out = mf;
    return 0;
}

void fit_mlp_spectral_eval(const struct fit_mlp *net, const double *u, size_t n,
                           double *value)
{
    for (size_t i = 0; i < n; i++) {
        double z;
        fit_mlp_forward(net, u + 3 * i, 1, &z);
        value[i] = fit_mlp_value(z);
    }
}

/* ---- materials ---- */

#define SPEC_N 31 /* 400..700 nm in 10 nm steps */

struct mlp_priv {
    struct fit_mlp net;
    int spectral;
    double lambda[SPEC_N], w[3 * SPEC_N]; /* colour weights (spectral only) */
};

static void mlp_eval(const void *pv, const struct brdf_pair *pairs, size_t n, double *rgb)
{
    const struct mlp_priv *p = pv;
    for (size_t i = 0; i < n; i++) {
        double ti, tr, *out = rgb + 3 * i;
        if (fit_mlp_inplane_angles(&pairs[i], 0, &ti, &tr) || !(pairs[i].wi[2] > 0) ||
            !(pairs[i].wo[2] > 0)) {
            /* Out of plane: the network has no meaning there. Below the
             * horizon: the BRDF is 0 as for every other material. */
            double v = fit_mlp_inplane_angles(&pairs[i], 0, &ti, &tr) ? NAN : 0.0;
            out[0] = out[1] = out[2] = v;
            continue;
        }
        if (!p->spectral) {
            double u[2] = {ti, tr}, z[3];
            fit_mlp_forward(&p->net, u, 1, z);
            for (int k = 0; k < 3; k++)
                out[k] = fit_mlp_value(z[k]);
            continue;
        }
        double xyz[3] = {0, 0, 0};
        for (int k = 0; k < SPEC_N; k++) {
            double u[3] = {ti, tr, p->lambda[k]}, z;
            fit_mlp_forward(&p->net, u, 1, &z);
            double v = fit_mlp_value(z);
            for (int c = 0; c < 3; c++)
                xyz[c] += p->w[3 * k + c] * v;
        }
        brdf_colour_xyz_to_srgb_linear(xyz, out);
        for (int c = 0; c < 3; c++)
            out[c] = out[c] > 0 ? out[c] : 0.0;
    }
}

static void mlp_free_priv(void *pv)
{
    struct mlp_priv *p = pv;
    if (p)
        fit_mlp_free(&p->net);
    free(p);
}

static const struct brdf_material_ops mlp_ops = {"mlp", mlp_eval, mlp_free_priv};

static brdf_material *open_common(const struct fit_model_file *f, const char *name,
                                  int spectral, struct gonio_err *err)
{
    const char *path = name && !strncmp(name, "model:", 6) ? name + 6 : name ? name : "(model)";
    int want_version = spectral ? SPECTRAL_VERSION : RGB_VERSION;
    if (f->version != want_version) {
        gonio_err_set(err, GONIO_EBADDATA, "%s: %s model version %d (this gonio reads %d)",
                      path, f->kind, f->version, want_version);
        return NULL;
    }
    struct mlp_priv *p = calloc(1, sizeof *p);
    if (!p) {
        gonio_err_set(err, ENOMEM, "%s: out of memory", path);
        return NULL;
    }
    p->spectral = spectral;
    if (fit_mlp_from_file(f, path, &p->net, err)) {
        free(p);
        return NULL;
    }
    int nin = spectral ? 3 : 2, nout = spectral ? 1 : 3;
    if (p->net.width[0] != nin || p->net.width[p->net.n_layers] != nout) {
        gonio_err_set(err, GONIO_EBADDATA, "%s: %s model must have %d inputs and %d outputs",
                      path, f->kind, nin, nout);
        mlp_free_priv(p);
        return NULL;
    }
    if (spectral) {
        for (int k = 0; k < SPEC_N; k++)
            p->lambda[k] = 400.0 + 10.0 * k;
        if (brdf_colour_weights(p->lambda, SPEC_N, p->w, err)) {
            mlp_free_priv(p);
            return NULL;
        }
    }
    brdf_material *m = brdf_material_new(&mlp_ops, p, name ? name : f->kind);
    if (!m)
        gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    return m;
}

brdf_material *fit_mlp_rgb_open(const struct fit_model_file *f, const char *name,
                                struct gonio_err *err)
{
    return open_common(f, name, 0, err);
}

brdf_material *fit_mlp_spectral_open(const struct fit_model_file *f, const char *name,
                                     struct gonio_err *err)
{
    return open_common(f, name, 1, err);
}
