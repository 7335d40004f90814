/* The anisotropic GGX fit (fit/aniso_ggx_model.h): a grid of starts over
 * the roughnesses, the orientation and the specular scale, the best few
 * refined with GSL's trust-region Levenberg-Marquardt on a subset of the
 * samples, the best of those refined on all of them. */
#include "fit/aniso_ggx_model.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_blas.h>
#include <gsl/gsl_eigen.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_multifit_nlinear.h>

#include "fit/model_file.h"

#define NPAR 9
/* The local solves from the starts run on at most this many samples (an
 * out-of-plane reference holds 200,000); the winner is refined on all. */
#define SUBSET 6000
#define N_LOCAL 4
#define MAX_ITER 300
#define ROUGH_MIN 0.001
#define ROUGH_MAX 2.0
/* rho and f0 are exp(x): below e^-30 they are 0 to the data. */
#define LOG_MIN (-30.0)
#define LOG_MAX 5.0

struct problem {
    const struct fit_sample *s;
    const unsigned char *lower; /* censored readings (fit_data.rgb_lower), or NULL */
    const size_t *idx;          /* the samples solved on */
    size_t n;
    const double *target;       /* log(1 + f cos theta_i), 3 per sample of s */
};

static double clampd(double x, double lo, double hi)
{
    return x < lo ? lo : x > hi ? hi : x;
}

void fit_aniso_ggx_to_params(const double x[9], struct brdf_aniso_ggx *a)
{
    for (int k = 0; k < 3; k++) {
        a->rho[k] = exp(clampd(x[k], LOG_MIN, LOG_MAX));
        a->f0[k] = exp(clampd(x[3 + k], LOG_MIN, LOG_MAX));
    }
    a->ax = exp(clampd(x[6], log(ROUGH_MIN), log(ROUGH_MAX)));
    a->ay = exp(clampd(x[7], log(ROUGH_MIN), log(ROUGH_MAX)));
    a->phi_deg = x[8] / BRDF_DEG;
}

/* The residual of sample i's channels under a, into r[3]. */
static void residual3(const struct problem *p, const struct brdf_aniso_ggx *a, size_t i,
                      double r[3])
{
    const struct fit_sample *s = &p->s[i];
    double rgb[3];
    brdf_aniso_ggx_eval(a, &s->g, rgb);
    for (int k = 0; k < 3; k++) {
        r[k] = log1p(rgb[k] * s->g.wi[2]) - p->target[3 * i + k];
        if (p->lower && p->lower[i] && r[k] > 0)
            r[k] = 0; /* a lower bound the model is above: no residual */
    }
}

static int gsl_residuals(const gsl_vector *xv, void *user, gsl_vector *f)
{
    const struct problem *p = user;
    double x[NPAR];
    for (int j = 0; j < NPAR; j++)
        x[j] = gsl_vector_get(xv, (size_t)j);
    struct brdf_aniso_ggx a;
    fit_aniso_ggx_to_params(x, &a);
    for (size_t j = 0; j < p->n; j++) {
        double r[3];
        residual3(p, &a, p->idx[j], r);
        for (int k = 0; k < 3; k++)
            gsl_vector_set(f, 3 * j + (size_t)k, r[k]);
    }
    return GSL_SUCCESS;
}

static double cost_of(const struct problem *p, const double *x)
{
    struct brdf_aniso_ggx a;
    fit_aniso_ggx_to_params(x, &a);
    double c = 0;
    for (size_t j = 0; j < p->n; j++) {
        double r[3];
        residual3(p, &a, p->idx[j], r);
        c += r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
    }
    return 0.5 * c;
}

/* cond(J^T J) with J's columns scaled to unit length, and its numerical
 * rank (eigenvalues above 1e-12 of the largest), as fit/fit_status.h. */
static void conditioning(const gsl_matrix *J, struct fit_status *st)
{
    double a[NPAR * NPAR] = {0}, norm[NPAR], ev[NPAR];
    for (int i = 0; i < NPAR; i++) {
        gsl_vector_const_view ci = gsl_matrix_const_column(J, (size_t)i);
        norm[i] = gsl_blas_dnrm2(&ci.vector);
    }
    for (int i = 0; i < NPAR; i++)
        for (int k = 0; k < NPAR; k++) {
            gsl_vector_const_view ci = gsl_matrix_const_column(J, (size_t)i),
                                  ck = gsl_matrix_const_column(J, (size_t)k);
            double d;
            gsl_blas_ddot(&ci.vector, &ck.vector, &d);
            a[i * NPAR + k] = norm[i] > 0 && norm[k] > 0 ? d / (norm[i] * norm[k]) : 0;
        }
    gsl_matrix_view av = gsl_matrix_view_array(a, NPAR, NPAR);
    gsl_vector_view evv = gsl_vector_view_array(ev, NPAR);
    gsl_eigen_symm_workspace *w = gsl_eigen_symm_alloc(NPAR);
    if (!w || gsl_eigen_symm(&av.matrix, &evv.vector, w) != GSL_SUCCESS) {
        gsl_eigen_symm_free(w);
        return;
    }
    gsl_eigen_symm_free(w);
    double lo = INFINITY, hi = 0;
    for (int i = 0; i < NPAR; i++)
        hi = fmax(hi, ev[i]);
    st->rank = 0;
    for (int i = 0; i < NPAR; i++) {
        lo = fmin(lo, fmax(ev[i], 0));
        st->rank += ev[i] > 1e-12 * hi;
    }
    st->cond = lo > 0 ? hi / lo : INFINITY;
}

/* A local solve from x (refined in place); *cost its end. With st, the
 * conditioning at the end goes there. */
static int solve(const struct problem *p, double *x, int *iters, int *converged, double *cost,
                 struct fit_status *st)
{
    gsl_multifit_nlinear_parameters par = gsl_multifit_nlinear_default_parameters();
    par.solver = gsl_multifit_nlinear_solver_cholesky; /* tall problems: 9 x 9 normal eqs */
    gsl_multifit_nlinear_fdf fdf = {
        .f = gsl_residuals, .df = NULL, .fvv = NULL, .n = 3 * p->n, .p = NPAR,
        .params = (void *)p};
    gsl_multifit_nlinear_workspace *w =
        gsl_multifit_nlinear_alloc(gsl_multifit_nlinear_trust, &par, 3 * p->n, NPAR);
    if (!w)
        return -ENOMEM;
    gsl_vector_view xv = gsl_vector_view_array(x, NPAR);
    int info = 0;
    int rc = gsl_multifit_nlinear_init(&xv.vector, &fdf, w);
    if (rc == GSL_SUCCESS)
        rc = gsl_multifit_nlinear_driver(MAX_ITER, 1e-10, 1e-10, 1e-12, NULL, NULL, &info, w);
    const gsl_vector *at = gsl_multifit_nlinear_position(w);
    for (int j = 0; j < NPAR; j++)
        x[j] = gsl_vector_get(at, (size_t)j);
    *iters = (int)gsl_multifit_nlinear_niter(w);
    /* ENOPROG: no step lowers the cost any more, at the minimum to the
     * precision of the finite-difference Jacobian (noisy data end there
     * rather than at the step and gradient tests). */
    *converged = rc == GSL_SUCCESS || rc == GSL_ENOPROG;
    *cost = cost_of(p, x);
    if (st)
        conditioning(gsl_multifit_nlinear_jac(w), st);
    gsl_multifit_nlinear_free(w);
    return 0;
}

/* The rho of a start: pi times the 10th percentile of each channel. */
static void start_rho(const struct problem *p, double rho[3])
{
    double *v = malloc((p->n ? p->n : 1) * sizeof *v);
    for (int k = 0; k < 3; k++) {
        rho[k] = 0.01;
        if (!v)
            continue;
        for (size_t j = 0; j < p->n; j++)
            v[j] = p->s[p->idx[j]].rgb[k];
        size_t q = p->n / 10;
        for (size_t a = 0; a <= q && a < p->n; a++) /* partial selection: q is small */
            for (size_t b = a + 1; b < p->n; b++)
                if (v[b] < v[a]) {
                    double t = v[a];
                    v[a] = v[b];
                    v[b] = t;
                }
        if (p->n)
            rho[k] = clampd(3.14159265358979 * v[q < p->n ? q : p->n - 1], 1e-4, 1);
    }
    free(v);
}

/* The N_LOCAL best nodes of the start grid, into best[N_LOCAL][NPAR]. */
static void grid_starts(const struct problem *p, double best[N_LOCAL][NPAR])
{
    static const double rough[] = {0.02, 0.05, 0.12, 0.3, 0.6};
    static const double f0s[] = {0.04, 0.3, 1.0};
    const int nr = (int)(sizeof rough / sizeof *rough);
    double rho[3], cost[N_LOCAL];
    start_rho(p, rho);
    for (int b = 0; b < N_LOCAL; b++)
        cost[b] = INFINITY;
    for (int i = 0; i < nr; i++)
        for (int j = i; j < nr; j++)
            for (int ph = 0; ph < (i == j ? 1 : 6); ph++)
                for (size_t f = 0; f < sizeof f0s / sizeof *f0s; f++) {
                    double x[NPAR] = {log(rho[0]),  log(rho[1]),  log(rho[2]),
                                      log(f0s[f]),  log(f0s[f]),  log(f0s[f]),
                                      log(rough[i]), log(rough[j]), ph * 30.0 * BRDF_DEG};
                    double c = cost_of(p, x);
                    int at = N_LOCAL;
                    while (at > 0 && !(c >= cost[at - 1]))
                        at--;
                    if (at == N_LOCAL)
                        continue;
                    for (int b = N_LOCAL - 1; b > at; b--) {
                        cost[b] = cost[b - 1];
                        memcpy(best[b], best[b - 1], sizeof best[b]);
                    }
                    cost[at] = c;
                    memcpy(best[at], x, sizeof best[at]);
                }
}

/* ax <= ay, phi in [0, 180): one name for each lobe. */
static void canonical(struct brdf_aniso_ggx *a)
{
    if (a->ax > a->ay) {
        double t = a->ax;
        a->ax = a->ay;
        a->ay = t;
        a->phi_deg += 90.0;
    }
    a->phi_deg = fmod(a->phi_deg, 180.0);
    if (a->phi_deg < 0)
        a->phi_deg += 180.0;
}

struct outcome {
    struct brdf_aniso_ggx a;
    int starts, iters, converged;
    double cost;
    struct fit_status status;
};

/* Fit the usable samples idx[n] of s. */
static int fit_usable(const struct fit_sample *s, const unsigned char *lower, const size_t *idx,
                      size_t n, const double *target, struct outcome *out)
{
    size_t m = n < SUBSET ? n : SUBSET;
    size_t *sub = malloc(m * sizeof *sub);
    if (!sub)
        return -ENOMEM;
    for (size_t j = 0; j < m; j++)
        sub[j] = idx[j * n / m]; /* evenly through the samples */
    struct problem p = {s, lower, sub, m, target};
    double starts[N_LOCAL][NPAR], x[NPAR], cost = INFINITY;
    grid_starts(&p, starts);
    memcpy(x, starts[0], sizeof x);
    int rc = 0;
    for (int b = 0; b < N_LOCAL && rc == 0; b++) {
        double c;
        int it, conv;
        if ((rc = solve(&p, starts[b], &it, &conv, &c, NULL)) == 0 && c < cost) {
            cost = c;
            memcpy(x, starts[b], sizeof x);
            out->iters = it;
            out->converged = conv;
        }
    }
    out->starts = N_LOCAL;
    p.idx = idx;
    p.n = n;
    out->status = fit_status_init();
    if (rc == 0)
        rc = solve(&p, x, &out->iters, &out->converged, &out->cost, &out->status);
    free(sub);
    fit_aniso_ggx_to_params(x, &out->a);
    canonical(&out->a);
    return rc;
}

int fit_aniso_ggx_usable(const struct fit_sample *s)
{
    if (!(s->g.wi[2] > 0) || !(s->g.wo[2] > 0))
        return 0;
    for (int k = 0; k < 3; k++)
        if (!isfinite(s->rgb[k]) || !(1 + s->rgb[k] * s->g.wi[2] > 0))
            return 0;
    return 1;
}

/* The usable samples of s[0..n): their indices into idx, their targets
 * log(1 + f cos theta_i) into target (3 per sample of s, at 3 i); their
 * count. */
static size_t select_usable(const struct fit_sample *s, size_t n, size_t *idx, double *target)
{
    size_t m = 0;
    for (size_t i = 0; i < n; i++) {
        if (!fit_aniso_ggx_usable(&s[i]))
            continue;
        idx[m++] = i;
        for (int k = 0; k < 3; k++)
            target[3 * i + (size_t)k] = log1p(s[i].rgb[k] * s[i].g.wi[2]);
    }
    return m;
}

static struct fit_model_file *model_file(const struct outcome *o, unsigned long long seed)
{
    const struct brdf_aniso_ggx *a = &o->a;
    double x[NPAR] = {a->rho[0], a->rho[1], a->rho[2], a->f0[0], a->f0[1],
                      a->f0[2],  a->ax,     a->ay,     a->phi_deg};
    struct fit_model_file *f = fit_model_file_new("aniso-ggx", FIT_ANISO_GGX_FILE_VERSION);
    if (!f || fit_model_file_set(f, "layout", "rho_r,rho_g,rho_b,f0_r,f0_g,f0_b,ax,ay,phi_deg") ||
        fit_model_file_set(f, "seed", "%llu", seed) ||
        fit_model_file_set(f, "cost", "%.6g", o->cost) || fit_model_file_set_data(f, x, NPAR) ||
        fit_status_file_keys(f, &o->status)) {
        fit_model_file_free(f);
        return NULL;
    }
    return f;
}

int fit_aniso_ggx_model_fit(const struct fit_data *data, const struct fit_model_options *opt,
                            struct fit_model_file **out, struct fit_model_report *rep,
                            struct gonio_err *err)
{
    struct fit_model_options o = opt ? *opt : fit_model_default_options();
    if (!data->n_rgb)
        return gonio_err_set(err, GONIO_EUSAGE, "aniso-ggx: needs RGB samples");
    gsl_set_error_handler_off(); /* a failed solve is a result, not an abort */
    size_t *idx = malloc(data->n_rgb * sizeof *idx);
    double *target = malloc(3 * data->n_rgb * sizeof *target);
    if (!idx || !target) {
        free(idx);
        free(target);
        return gonio_err_set(err, ENOMEM, "aniso-ggx: out of memory");
    }
    size_t n = select_usable(data->rgb, data->n_rgb, idx, target);
    struct outcome oc = {0};
    int rc = n < 3 ? gonio_err_set(err, GONIO_EFIT,
                                   "aniso-ggx: %zu usable samples of %zu (need 3 for 9 "
                                   "parameters)", n, data->n_rgb)
                   : fit_usable(data->rgb, data->rgb_lower, idx, n, target, &oc);
    if (rc == -ENOMEM)
        rc = gonio_err_set(err, ENOMEM, "aniso-ggx: out of memory");
    if (rc == 0) {
        oc.status.geometries = n;
        oc.status.params = NPAR;
        oc.status.insample = sqrt(2 * oc.cost / (3.0 * (double)n));
        if (!oc.converged)
            oc.status.findings |= 1u << FIT_STATUS_NOT_CONVERGED;
        fit_status_decide(&oc.status);
        *out = model_file(&oc, (unsigned long long)o.seed);
        if (!*out)
            rc = gonio_err_set(err, ENOMEM, "aniso-ggx: out of memory");
    }
    if (rc == 0 && rep) {
        rep->converged = oc.converged;
        rep->status = oc.status;
        snprintf(rep->note, sizeof rep->note,
                 "%d starts, %d iterations; ax %.4g, ay %.4g, phi %.1f deg; %zu samples "
                 "dropped", oc.starts, oc.iters, oc.a.ax, oc.a.ay, oc.a.phi_deg,
                 data->n_rgb - n);
    }
    free(idx);
    free(target);
    return rc;
}

int fit_aniso_ggx_params(const struct fit_model_file *f, const char *path,
                         struct brdf_aniso_ggx *a, struct gonio_err *err)
{
    if (strcmp(f->kind, "aniso-ggx") || f->version != FIT_ANISO_GGX_FILE_VERSION)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: %s version %d is not an aniso-ggx "
                             "model version %d", path, f->kind, f->version,
                             FIT_ANISO_GGX_FILE_VERSION);
    if (f->n_data != NPAR)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: aniso-ggx model holds %zu values "
                             "(need %d)", path, f->n_data, NPAR);
    const double *x = f->data;
    for (int k = 0; k < NPAR; k++)
        if (!isfinite(x[k]) || (k < 8 && x[k] < 0))
            return gonio_err_set(err, GONIO_EBADDATA, "%s: aniso-ggx parameter %d is %g "
                                 "(must be finite, and >= 0 but for phi)", path, k, x[k]);
    for (int k = 6; k < 8; k++)
        if (x[k] < ROUGH_MIN || x[k] > ROUGH_MAX)
            return gonio_err_set(err, GONIO_EBADDATA, "%s: aniso-ggx roughness %g outside "
                                 "%g..%g", path, x[k], ROUGH_MIN, ROUGH_MAX);
    *a = (struct brdf_aniso_ggx){.ax = x[6], .ay = x[7], .phi_deg = x[8]};
    memcpy(a->rho, x, sizeof a->rho);
    memcpy(a->f0, x + 3, sizeof a->f0);
    return 0;
}

int fit_aniso_ggx_solve(const struct fit_sample *s, size_t n, int cold, double x[9],
                        double *rms)
{
    gsl_set_error_handler_off();
    size_t *idx = malloc((n ? n : 1) * sizeof *idx), m = 0;
    double *target = malloc((n ? 3 * n : 1) * sizeof *target);
    int rc = idx && target ? 0 : -ENOMEM;
    if (rc == 0)
        m = select_usable(s, n, idx, target);
    if (rc == 0 && m < 3)
        rc = -GONIO_EFIT;
    struct outcome oc = {0};
    if (rc == 0 && cold)
        rc = fit_usable(s, NULL, idx, m, target, &oc);
    if (rc == 0 && !cold) {
        struct problem p = {s, NULL, idx, m, target};
        rc = solve(&p, x, &oc.iters, &oc.converged, &oc.cost, NULL);
        fit_aniso_ggx_to_params(x, &oc.a);
        canonical(&oc.a);
    }
    if (rc == 0) {
        for (int k = 0; k < 3; k++) {
            x[k] = log(oc.a.rho[k]);
            x[3 + k] = log(oc.a.f0[k]);
        }
        x[6] = log(oc.a.ax);
        x[7] = log(oc.a.ay);
        x[8] = oc.a.phi_deg * BRDF_DEG;
        *rms = sqrt(2 * oc.cost / (3.0 * (double)m));
    }
    free(idx);
    free(target);
    return rc;
}

brdf_material *fit_aniso_ggx_model_open(const struct fit_model_file *f, const char *name,
                                        struct gonio_err *err)
{
    const char *path = name && !strncmp(name, "model:", 6) ? name + 6 : name ? name : "(model)";
    struct brdf_aniso_ggx a;
    if (fit_aniso_ggx_params(f, path, &a, err))
        return NULL;
    brdf_material *m = brdf_aniso_ggx_material(&a, name);
    if (!m)
        gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    return m;
}
