/* The ABC least-squares problem: parametrisation, log-space residuals and
 * their analytic Jacobian. */
#include "fit/abc_problem.h"

#include "fit/abc_vmath.h"

#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define ABC_PI 3.14159265358979323846
/* GCC's ivdep (see its loops); clang knows no such pragma and warns, an
 * error under -Werror (make fuzz), and its assume_safety fails as an error
 * in the sanitized fuzz build: nothing there, speed is not its point. */
#ifdef __clang__
#define ABC_IVDEP
#else
#define ABC_IVDEP _Pragma("GCC ivdep")
#endif

/* The distinct values of v[n] into *u, in order of first appearance, and
 * each sample's index into idx; returns the count, 0 on no memory. An
 * open-addressing hash table on the bit patterns (-0 taken as +0, which ==
 * treats alike): sorting the values was a tenth of a DS1 fit's set-up.
 * (v is read only; not const because GCC 12 then warns that the freshly
 * filled malloc'ed array may be uninitialised.) */
static size_t distinct(double *v, size_t n, double **u, unsigned *idx)
{
    size_t cap = 4;
    while (cap < 2 * n)
        cap *= 2;
    double *out = malloc((n ? n : 1) * sizeof *out);
    unsigned *slot = malloc(cap * sizeof *slot);
    *u = out;
    if (!out || !slot) {
        free(slot);
        return 0;
    }
    memset(slot, 0xff, cap * sizeof *slot); /* UINT_MAX: empty */
    size_t m = 0;
    for (size_t i = 0; i < n; i++) {
        double x = v[i] == 0 ? 0.0 : v[i];
        uint64_t b;
        memcpy(&b, &x, sizeof b);
        b *= 0x9E3779B97F4A7C15u;
        size_t h = (size_t)(b ^ (b >> 29)) & (cap - 1);
        while (slot[h] != UINT_MAX && !(out[slot[h]] == x))
            h = (h + 1) & (cap - 1);
        if (slot[h] == UINT_MAX) {
            slot[h] = (unsigned)m;
            out[m++] = x;
        }
        idx[i] = slot[h];
    }
    free(slot);
    return m;
}

static int problem_alloc(struct abc_problem *pb, size_t n)
{
    memset(pb, 0, sizeof *pb);
    pb->n = n;
    pb->x = malloc(n * sizeof *pb->x);
    pb->vh = malloc(n * sizeof *pb->vh);
    pb->gterm = malloc(n * sizeof *pb->gterm);
    pb->cosi = malloc(n * sizeof *pb->cosi);
    pb->f = malloc(3 * n * sizeof *pb->f);
    pb->y = malloc(3 * n * sizeof *pb->y);
    pb->iy = malloc(3 * n * sizeof *pb->iy);
    pb->xi = malloc((n ? n : 1) * sizeof *pb->xi);
    pb->vi = malloc((n ? n : 1) * sizeof *pb->vi);
    if (!pb->x || !pb->vh || !pb->gterm || !pb->cosi || !pb->f || !pb->y || !pb->iy || !pb->xi ||
        !pb->vi) {
        abc_problem_free(pb);
        return -1;
    }
    return 0;
}

/* The distinct values of x and v.h, once the samples are in. */
static int problem_index(struct abc_problem *pb)
{
    pb->nux = distinct(pb->x, pb->n, &pb->ux, pb->xi);
    pb->nuv = distinct(pb->vh, pb->n, &pb->uvh, pb->vi);
    if (pb->n && (!pb->nux || !pb->nuv)) {
        abc_problem_free(pb);
        return -1;
    }
    return 0;
}

int abc_problem_init(struct abc_problem *pb, const struct fit_sample *s, const size_t *idx,
                     size_t n)
{
    if (problem_alloc(pb, n) < 0)
        return -1;
    for (size_t k = 0; k < n; k++) {
        const struct fit_sample *sk = &s[idx ? idx[k] : k];
        struct brdf_abc_geom geo;
        brdf_abc_geometry(&sk->g, &geo);
        pb->x[k] = geo.x;
        pb->vh[k] = geo.vh;
        pb->gterm[k] = geo.gterm;
        pb->cosi[k] = sk->g.wi[2];
        for (int c = 0; c < 3; c++) {
            pb->f[3 * k + c] = sk->rgb[c];
            pb->y[3 * k + c] = log1p(sk->rgb[c] * pb->cosi[k]);
            pb->iy[(size_t)c * n + k] = 1.0 / (1.0 + sk->rgb[c] * pb->cosi[k]);
        }
    }
    return problem_index(pb);
}

int abc_problem_subset(struct abc_problem *pb, const struct abc_problem *src, const size_t *rows,
                       size_t n)
{
    if (problem_alloc(pb, n) < 0)
        return -1;
    for (size_t k = 0; k < n; k++) {
        size_t r = rows[k];
        pb->x[k] = src->x[r];
        pb->vh[k] = src->vh[r];
        pb->gterm[k] = src->gterm[r];
        pb->cosi[k] = src->cosi[r];
        for (size_t c = 0; c < 3; c++) {
            pb->f[3 * k + c] = src->f[3 * r + c];
            pb->y[3 * k + c] = src->y[3 * r + c];
            pb->iy[c * n + k] = src->iy[c * src->n + r];
        }
    }
    /* src's distinct values in their order of first appearance among the
     * rows: what distinct() would find, without hashing them again */
    unsigned *map = malloc((src->nux > src->nuv ? src->nux : src->nuv) * sizeof *map + 1);
    pb->ux = malloc((n ? n : 1) * sizeof *pb->ux);
    pb->uvh = malloc((n ? n : 1) * sizeof *pb->uvh);
    if (!map || !pb->ux || !pb->uvh) {
        free(map);
        abc_problem_free(pb);
        return -1;
    }
    memset(map, 0xff, src->nux * sizeof *map);
    for (size_t k = 0; k < n; k++) {
        unsigned u = src->xi[rows[k]];
        if (map[u] == UINT_MAX) {
            map[u] = (unsigned)pb->nux;
            pb->ux[pb->nux++] = src->ux[u];
        }
        pb->xi[k] = map[u];
    }
    memset(map, 0xff, src->nuv * sizeof *map);
    for (size_t k = 0; k < n; k++) {
        unsigned u = src->vi[rows[k]];
        if (map[u] == UINT_MAX) {
            map[u] = (unsigned)pb->nuv;
            pb->uvh[pb->nuv++] = src->uvh[u];
        }
        pb->vi[k] = map[u];
    }
    free(map);
    return 0;
}

void abc_problem_free(struct abc_problem *pb)
{
    free(pb->x);
    free(pb->vh);
    free(pb->gterm);
    free(pb->cosi);
    free(pb->f);
    free(pb->y);
    free(pb->iy);
    free(pb->ux);
    free(pb->uvh);
    free(pb->xi);
    free(pb->vi);
    free(pb->s);
    free(pb->sw);
    free(pb->mw);
    free(pb->lower);
    memset(pb, 0, sizeof *pb);
}

int abc_problem_set_lower(struct abc_problem *pb, const unsigned char *flags, const size_t *idx)
{
    for (size_t k = 0; flags && k < pb->n; k++) {
        if (!flags[idx ? idx[k] : k])
            continue;
        if (!pb->lower && !(pb->lower = calloc(pb->n, 1)))
            return -1;
        pb->lower[k] = 1;
    }
    return 0;
}

int abc_problem_set_weights(struct abc_problem *pb, const double *w, const size_t *idx)
{
    if (!w)
        return 0;
    if (!pb->sw && !(pb->sw = malloc((pb->n ? pb->n : 1) * sizeof *pb->sw)))
        return -1;
    for (size_t k = 0; k < pb->n; k++)
        pb->sw[k] = sqrt(w[idx ? idx[k] : k]);
    return 0;
}

int abc_problem_set_sigma(struct abc_problem *pb, const double *u, const size_t *idx)
{
    if (!u)
        return 0;
    if (!pb->mw && !(pb->mw = malloc((pb->n ? 3 * pb->n : 1) * sizeof *pb->mw)))
        return -1;
    for (size_t k = 0; k < pb->n; k++)
        for (size_t c = 0; c < 3; c++) {
            size_t row = 3 * k + c;
            double ci = pb->cosi[k];
            double slope = pb->loss == FIT_LOSS_LOG ? ci / (1.0 + pb->f[row] * ci)
                                                    : fabs(pb->s[row]);
            pb->mw[row] = 1.0 / (u[3 * (idx ? idx[k] : k) + c] * slope);
        }
    return 0;
}

int abc_problem_set_loss(struct abc_problem *pb, enum fit_loss loss)
{
    if (loss != FIT_LOSS_LOG && loss != FIT_LOSS_RELATIVE && loss != FIT_LOSS_COS_L2)
        return -1;
    pb->loss = loss;
    if (loss == FIT_LOSS_LOG)
        return 0;
    if (!pb->s && !(pb->s = malloc((pb->n ? 3 * pb->n : 1) * sizeof *pb->s)))
        return -1;
    for (size_t row = 0; row < 3 * pb->n; row++)
        pb->s[row] = loss == FIT_LOSS_RELATIVE ? 1.0 / (fabs(pb->f[row]) + FIT_REL_FLOOR)
                                               : pb->cosi[row / 3];
    return 0;
}

size_t abc_problem_nres(const struct abc_problem *pb)
{
    return 3 * pb->n + (pb->prior ? ABC_NPAR : 0);
}

/* exp of a clamped log; *d receives d value / d t (0 beyond the clamp). */
static double clamped_exp(double t, double lo, double hi, double *d)
{
    int inside = 1;
    if (!(t >= lo)) { /* also catches NaN */
        t = lo;
        inside = 0;
    } else if (t > hi) {
        t = hi;
        inside = 0;
    }
    double v = exp(t);
    if (d)
        *d = inside ? v : 0.0;
    return v;
}

static double eta_of(double e, double *d)
{
    int inside = 1;
    if (!(e >= ABC_E_MIN)) {
        e = ABC_E_MIN;
        inside = 0;
    } else if (e > ABC_E_MAX) {
        e = ABC_E_MAX;
        inside = 0;
    }
    double s = 1.0 / (1.0 + exp(-e));
    if (d)
        *d = inside ? (ABC_ETA_MAX - 1.0) * s * (1.0 - s) : 0.0;
    return 1.0 + (ABC_ETA_MAX - 1.0) * s;
}

void abc_theta_to_params(const double th[ABC_NPAR], struct brdf_abc *p)
{
    for (int c = 0; c < 3; c++) {
        p->kd[c] = clamped_exp(th[c], ABC_LOGKD_MIN, ABC_LOGKD_MAX, NULL);
        p->A[c] = clamped_exp(th[3 + c], ABC_LOGA_MIN, ABC_LOGA_MAX, NULL);
    }
    p->B = clamped_exp(th[6] - th[7], ABC_LOGB_MIN, ABC_LOGB_MAX, NULL);
    p->C = clamped_exp(th[7], ABC_LOGC_MIN, ABC_LOGC_MAX, NULL);
    p->eta = eta_of(th[8], NULL);
}

static double clamp(double v, double lo, double hi)
{
    return v < lo ? lo : v > hi ? hi : v;
}

static double safe_log(double v, double lo, double hi)
{
    return v > 0 ? clamp(log(v), lo, hi) : lo;
}

void abc_params_to_theta(const struct brdf_abc *p, double th[ABC_NPAR])
{
    for (int c = 0; c < 3; c++) {
        th[c] = safe_log(p->kd[c], ABC_LOGKD_MIN, ABC_LOGKD_MAX);
        th[3 + c] = safe_log(p->A[c], ABC_LOGA_MIN, ABC_LOGA_MAX);
    }
    th[7] = safe_log(p->C, ABC_LOGC_MIN, ABC_LOGC_MAX);
    th[6] = safe_log(p->B, ABC_LOGB_MIN, ABC_LOGB_MAX) + th[7];
    /* invert the sigmoid; an eta outside (1, ETA_MAX) lands on the clamp */
    double s = (p->eta - 1.0) / (ABC_ETA_MAX - 1.0);
    if (!(s > 1e-13))
        s = 1e-13;
    if (s > 1.0 - 1e-13)
        s = 1.0 - 1e-13;
    th[8] = clamp(log(s / (1.0 - s)), ABC_E_MIN, ABC_E_MAX);
}

void abc_problem_eval(const struct abc_problem *pb, const double th[ABC_NPAR], double *r,
                      double *J)
{
    double kd[3], dkd[3], A[3], dA[3], dBt, dCt, detat;
    for (int c = 0; c < 3; c++) {
        kd[c] = clamped_exp(th[c], ABC_LOGKD_MIN, ABC_LOGKD_MAX, &dkd[c]);
        A[c] = clamped_exp(th[3 + c], ABC_LOGA_MIN, ABC_LOGA_MAX, &dA[c]);
    }
    /* theta[6] = log(B C), theta[7] = log C: see abc_problem.h */
    double B = clamped_exp(th[6] - th[7], ABC_LOGB_MIN, ABC_LOGB_MAX, &dBt);
    double C = clamped_exp(th[7], ABC_LOGC_MIN, ABC_LOGC_MAX, &dCt);
    double eta = eta_of(th[8], &detat);

    for (size_t k = 0; k < pb->n; k++) {
        double dF, dDB, dDC;
        double F = brdf_abc_fresnel(eta, pb->vh[k], J ? &dF : NULL);
        double D = brdf_abc_distribution(B, C, pb->x[k], J ? &dDB : NULL, J ? &dDC : NULL);
        double gt = pb->gterm[k], ci = pb->cosi[k];
        double S = F * gt * D; /* specular shape shared by the channels */
        for (int c = 0; c < 3; c++) {
            double fhat = kd[c] / ABC_PI + A[c] * S;
            size_t row = 3 * k + (size_t)c;
            int lin = pb->loss != FIT_LOSS_LOG;
            double rv = lin ? (fhat - pb->f[row]) * pb->s[row] : log1p(fhat * ci) - pb->y[row];
            /* a lower bound the model is above: no residual, no slope */
            int met = pb->lower && pb->lower[k] && rv > 0;
            double sw = abc_row_weight(pb, k, c);
            if (r)
                r[row] = met ? 0.0 : sw * rv;
            if (!J)
                continue;
            /* w = dr/dfhat: d log(1 + fhat cos) = cos / (1 + fhat cos) d fhat */
            double w = met ? 0.0 : sw * (lin ? pb->s[row] : ci / (1.0 + fhat * ci));
            double *jr = J + row * ABC_NPAR;
            memset(jr, 0, ABC_NPAR * sizeof *jr);
            jr[c] = w * dkd[c] / ABC_PI;
            jr[3 + c] = w * dA[c] * S;
            double ag = w * A[c] * gt;
            jr[6] = ag * F * dDB * dBt;
            jr[7] = ag * F * (dDC * dCt - dDB * dBt);
            jr[8] = ag * D * dF * detat;
        }
    }
    if (pb->prior) {
        /* Linear in theta (unclamped): the prior keeps pulling a parameter
         * that sits beyond a clamp, where the data no longer move it. */
        const struct abc_prior_term *pt = pb->prior;
        for (int i = 0; i < ABC_NPAR; i++) {
            size_t row = 3 * pb->n + (size_t)i;
            if (r) {
                double v = 0;
                for (int j = 0; j < ABC_NPAR; j++)
                    v += pt->W[i * ABC_NPAR + j] * (th[j] - pt->mean[j]);
                r[row] = v;
            }
            if (J)
                memcpy(J + row * ABC_NPAR, pt->W + i * ABC_NPAR, ABC_NPAR * sizeof *J);
        }
    }
}

double abc_problem_cost(const struct abc_problem *pb, const double th[ABC_NPAR])
{
    size_t m = abc_problem_nres(pb);
    double *r = malloc(m * sizeof *r);
    if (!r)
        return INFINITY;
    abc_problem_eval(pb, th, r, NULL);
    double s = 0;
    for (size_t i = 0; i < m; i++)
        s += r[i] * r[i];
    free(r);
    return 0.5 * s;
}

int abc_cache_init(struct abc_cache *c, const struct abc_problem *pb)
{
    size_t n = pb->n;
    memset(c, 0, sizeof *c);
    c->spec = malloc((n ? 4 * n : 1) * sizeof *c->spec);
    c->w = malloc((n ? 3 * n : 1) * sizeof *c->w);
    c->q = malloc((3 * n + ABC_NPAR) * sizeof *c->q);
    c->lobe = malloc((pb->nux ? 3 * pb->nux : 1) * sizeof *c->lobe);
    c->fres = malloc((pb->nuv ? 2 * pb->nuv : 1) * sizeof *c->fres);
    if (!c->spec || !c->w || !c->q || !c->lobe || !c->fres) {
        abc_cache_free(c);
        return -1;
    }
    return 0;
}

void abc_cache_free(struct abc_cache *c)
{
    free(c->spec);
    free(c->w);
    free(c->q);
    free(c->lobe);
    free(c->fres);
    memset(c, 0, sizeof *c);
}

/* The parameters in natural units and d value / d theta (0 beyond a clamp). */
struct abc_nat {
    double kd[3], dkd[3], A[3], dA[3], B, dBt, C, dCt, eta, detat;
};

static void natural(const double th[ABC_NPAR], struct abc_nat *p)
{
    for (int c = 0; c < 3; c++) {
        p->kd[c] = clamped_exp(th[c], ABC_LOGKD_MIN, ABC_LOGKD_MAX, &p->dkd[c]);
        p->A[c] = clamped_exp(th[3 + c], ABC_LOGA_MIN, ABC_LOGA_MAX, &p->dA[c]);
    }
    p->B = clamped_exp(th[6] - th[7], ABC_LOGB_MIN, ABC_LOGB_MAX, &p->dBt);
    p->C = clamped_exp(th[7], ABC_LOGC_MIN, ABC_LOGC_MAX, &p->dCt);
    p->eta = eta_of(th[8], &p->detat);
}

/* The log loss's per-sample pass: the specular shape and its derivatives
 * (SoA), and per channel 1 + fhat cos over 1 + f cos (to be logged) and
 * dr/dfhat = cos / (1 + fhat cos). Channel-major and contiguous in k, so
 * that it vectorises (an AVX2 clone: 4-wide divisions, gathers of the
 * lobe and Fresnel terms). */
ABC_VCLONES
static void resid_log_pass(const struct abc_problem *pb, const struct abc_nat *p,
                           struct abc_cache *c)
{
    size_t n = pb->n;
    const double kdp[3] = {p->kd[0] / ABC_PI, p->kd[1] / ABC_PI, p->kd[2] / ABC_PI};
    const double A0 = p->A[0], A1 = p->A[1], A2 = p->A[2], dBt = p->dBt, dCt = p->dCt,
                 det = p->detat;
    const unsigned *restrict xi = pb->xi, *restrict vi = pb->vi;
    size_t nux = pb->nux, nuv = pb->nuv;
    const double *restrict lobe = c->lobe, *restrict fres = c->fres, *restrict gtm = pb->gterm,
                 *restrict cos_i = pb->cosi;
    const double *restrict iy0 = pb->iy, *restrict iy1 = pb->iy + n, *restrict iy2 = pb->iy + 2 * n;
    double *restrict s0 = c->spec, *restrict s1 = c->spec + n, *restrict s2 = c->spec + 2 * n,
           *restrict s3 = c->spec + 3 * n;
    double *restrict q0 = c->q, *restrict q1 = c->q + n, *restrict q2 = c->q + 2 * n;
    double *restrict w0 = c->w, *restrict w1 = c->w + n, *restrict w2 = c->w + 2 * n;
    /* ivdep: the arrays do not overlap (GCC gives up on the alias checks of
     * this many arrays, and restrict on locals is not used) */
    ABC_IVDEP
    for (size_t k = 0; k < n; k++) {
        int ix = (int)xi[k], iv = (int)vi[k];
        double F = fres[iv], dF = fres[nuv + iv], D = lobe[ix], dDB = lobe[nux + ix],
               dDC = lobe[2 * nux + ix];
        double gt = gtm[k], gF = gt * F;
        s0[k] = gF * D;
        s1[k] = gF * dDB * dBt;               /* dS/dtheta6 */
        s2[k] = gF * (dDC * dCt - dDB * dBt); /* dS/dtheta7 */
        s3[k] = gt * D * dF * det;            /* dS/dtheta8 */
    }
    ABC_IVDEP
    for (size_t k = 0; k < n; k++) {
        double S = s0[k], ci = cos_i[k];
        /* log(1 + fhat cos) - log(1 + f cos) as one log (abc_vlog, after):
         * its absolute error is a rounding of 1, as the log1p pair's */
        double qa = 1.0 + (kdp[0] + A0 * S) * ci;
        double qb = 1.0 + (kdp[1] + A1 * S) * ci;
        double qc = 1.0 + (kdp[2] + A2 * S) * ci;
        q0[k] = qa * iy0[k];
        q1[k] = qb * iy1[k];
        q2[k] = qc * iy2[k];
        w0[k] = ci / qa;
        w1[k] = ci / qb;
        w2[k] = ci / qc;
    }
}

double abc_problem_resid(const struct abc_problem *pb, const double th[ABC_NPAR], double *r,
                         struct abc_cache *c)
{
    struct abc_nat p;
    natural(th, &p);
    size_t n = pb->n;
    double ss = 0, *out = c->q;
    abc_vlobe(p.B, p.C, pb->ux, pb->nux, c->lobe);
    abc_vfresnel(p.eta, pb->uvh, pb->nuv, c->fres);
    if (pb->loss == FIT_LOSS_LOG) {
        resid_log_pass(pb, &p, c);
        abc_vlog(out, 3 * n);
    } else {
        double kdp[3] = {p.kd[0] / ABC_PI, p.kd[1] / ABC_PI, p.kd[2] / ABC_PI};
        for (size_t k = 0; k < n; k++) {
            size_t ix = pb->xi[k], iv = pb->vi[k], nux = pb->nux, nuv = pb->nuv;
            double F = c->fres[iv], dF = c->fres[nuv + iv], D = c->lobe[ix],
                   dDB = c->lobe[nux + ix], dDC = c->lobe[2 * nux + ix];
            double gt = pb->gterm[k], gF = gt * F;
            double S = gF * D;
            c->spec[k] = S;
            c->spec[n + k] = gF * dDB * p.dBt;
            c->spec[2 * n + k] = gF * (dDC * p.dCt - dDB * p.dBt);
            c->spec[3 * n + k] = gt * D * dF * p.detat;
            for (int ch = 0; ch < 3; ch++) {
                size_t row = 3 * k + (size_t)ch, cm = (size_t)ch * n + k;
                double fhat = kdp[ch] + p.A[ch] * S;
                out[cm] = (fhat - pb->f[row]) * pb->s[row];
                c->w[cm] = pb->s[row];
            }
        }
    }
    if (pb->lower) /* lower bounds the model is above: no residual, no slope */
        for (size_t ch = 0; ch < 3; ch++)
            for (size_t k = 0; k < n; k++)
                if (pb->lower[k] && out[ch * n + k] > 0)
                    out[ch * n + k] = c->w[ch * n + k] = 0.0;
    if (pb->sw || pb->mw)
        for (size_t ch = 0; ch < 3; ch++)
            for (size_t k = 0; k < n; k++) {
                double sw = abc_row_weight(pb, k, (int)ch);
                out[ch * n + k] *= sw;
                c->w[ch * n + k] *= sw;
            }
    for (size_t row = 0; row < 3 * n; row++)
        ss += out[row] * out[row];
    if (pb->prior) {
        const struct abc_prior_term *pt = pb->prior;
        for (int i = 0; i < ABC_NPAR; i++) {
            double v = 0;
            for (int j = 0; j < ABC_NPAR; j++)
                v += pt->W[i * ABC_NPAR + j] * (th[j] - pt->mean[j]);
            ss += v * v;
            out[3 * n + (size_t)i] = v;
        }
    }
    if (r) { /* rows in the public order: sample-major */
        for (size_t k = 0; k < n; k++)
            for (size_t ch = 0; ch < 3; ch++)
                r[3 * k + ch] = out[ch * n + k];
        memcpy(r + 3 * n, out + 3 * n, (abc_problem_nres(pb) - 3 * n) * sizeof *r);
    }
    memcpy(c->theta, th, sizeof c->theta);
    c->valid = 1;
    return 0.5 * ss;
}

/* The per-channel sums of the normal equations over the data rows of one
 * channel (w its dr/dfhat, s0..s3 the specular shape S and dS/dtheta6..8,
 * all contiguous): out[0..8] = sums of w^2 times 1, S, S^2, s1, s2, s3,
 * S s1, S s2, S s3. An AVX2 clone. */
ABC_VCLONES
static void channel_sums(const double *w, const double *s0, const double *s1, const double *s2,
                         const double *s3, size_t n, double out[9])
{
    double q1 = 0, qs = 0, qss = 0, q6 = 0, q7 = 0, q8 = 0, qs6 = 0, qs7 = 0, qs8 = 0;
    for (size_t k = 0; k < n; k++) {
        double w2 = w[k] * w[k], w2s = w2 * s0[k];
        q1 += w2;
        qs += w2s;
        qss += w2s * s0[k];
        q6 += w2 * s1[k];
        q7 += w2 * s2[k];
        q8 += w2 * s3[k];
        qs6 += w2s * s1[k];
        qs7 += w2s * s2[k];
        qs8 += w2s * s3[k];
    }
    out[0] = q1, out[1] = qs, out[2] = qss, out[3] = q6, out[4] = q7, out[5] = q8;
    out[6] = qs6, out[7] = qs7, out[8] = qs8;
}

/* Over all data rows: sums of W s_i s_j, i, j in 1..3, with W = sum over
 * channels of A_c^2 w_c^2: out = {11, 12, 13, 22, 23, 33}. */
ABC_VCLONES
static void shape_sums(const double *w, const double A2[3], const double *s1, const double *s2,
                       const double *s3, size_t n, double out[6])
{
    const double *w0 = w, *w1 = w + n, *w2 = w + 2 * n;
    double q66 = 0, q67 = 0, q68 = 0, q77 = 0, q78 = 0, q88 = 0;
    for (size_t k = 0; k < n; k++) {
        double W = A2[0] * w0[k] * w0[k] + A2[1] * w1[k] * w1[k] + A2[2] * w2[k] * w2[k];
        double wu6 = W * s1[k], wu7 = W * s2[k];
        q66 += wu6 * s1[k];
        q67 += wu6 * s2[k];
        q68 += wu6 * s3[k];
        q77 += wu7 * s2[k];
        q78 += wu7 * s3[k];
        q88 += W * s3[k] * s3[k];
    }
    out[0] = q66, out[1] = q67, out[2] = q68, out[3] = q77, out[4] = q78, out[5] = q88;
}

/* Sums over one channel's rows of w u times 1, S, s1, s2, s3 (u of stride us). */
ABC_VCLONES
static void grad_sums(const double *w, const double *u, size_t us, const double *s0,
                      const double *s1, const double *s2, const double *s3, size_t n,
                      double out[5])
{
    double g0 = 0, g1 = 0, g2 = 0, g3 = 0, g4 = 0;
    if (us == 1) {
        for (size_t k = 0; k < n; k++) {
            double wu = w[k] * u[k];
            g0 += wu;
            g1 += wu * s0[k];
            g2 += wu * s1[k];
            g3 += wu * s2[k];
            g4 += wu * s3[k];
        }
    } else {
        for (size_t k = 0; k < n; k++) {
            double wu = w[k] * u[k * us];
            g0 += wu;
            g1 += wu * s0[k];
            g2 += wu * s1[k];
            g3 += wu * s2[k];
            g4 += wu * s3[k];
        }
    }
    out[0] = g0, out[1] = g1, out[2] = g2, out[3] = g3, out[4] = g4;
}

void abc_problem_normal(const struct abc_problem *pb, const double th[ABC_NPAR], int trans,
                        const double *u, double *v, double *JTJ, struct abc_cache *c)
{
    if (!c->valid || memcmp(c->theta, th, sizeof c->theta) != 0)
        abc_problem_resid(pb, th, NULL, c);
    /* u NULL: the residuals at th, channel-major in the cache; a caller's u
     * is in row order (sample-major) */
    int own = !u;
    if (own)
        u = c->q;
    struct abc_nat p;
    natural(th, &p);
    double a[3][ABC_NPAR]; /* per channel: dfhat/dtheta factors of kd, A, and A for 6..8 */
    for (int ch = 0; ch < 3; ch++) {
        a[ch][0] = p.dkd[ch] / ABC_PI;
        a[ch][1] = p.dA[ch];
        a[ch][2] = p.A[ch];
    }
    size_t n = pb->n;
    const double *s0 = c->spec, *s1 = c->spec + n, *s2 = c->spec + 2 * n, *s3 = c->spec + 3 * n;
    if (v) {
        if (trans) {
            double g[ABC_NPAR] = {0};
            for (int ch = 0; ch < 3; ch++) {
                double gs[5];
                grad_sums(c->w + (size_t)ch * n, own ? u + (size_t)ch * n : u + ch, own ? 1 : 3,
                          s0, s1, s2, s3, n, gs);
                g[ch] = a[ch][0] * gs[0];
                g[3 + ch] = a[ch][1] * gs[1];
                g[6] += a[ch][2] * gs[2];
                g[7] += a[ch][2] * gs[3];
                g[8] += a[ch][2] * gs[4];
            }
            if (pb->prior)
                for (int i = 0; i < ABC_NPAR; i++)
                    for (int j = 0; j < ABC_NPAR; j++)
                        g[j] += pb->prior->W[i * ABC_NPAR + j] * u[3 * n + (size_t)i];
            memcpy(v, g, sizeof g);
        } else {
            for (size_t k = 0; k < n; k++) {
                for (int ch = 0; ch < 3; ch++) {
                    size_t row = 3 * k + (size_t)ch;
                    v[row] = c->w[(size_t)ch * n + k] *
                             (a[ch][0] * u[ch] + a[ch][1] * s0[k] * u[3 + ch] +
                              a[ch][2] * (s1[k] * u[6] + s2[k] * u[7] + s3[k] * u[8]));
                }
            }
            if (pb->prior)
                for (int i = 0; i < ABC_NPAR; i++) {
                    double s = 0;
                    for (int j = 0; j < ABC_NPAR; j++)
                        s += pb->prior->W[i * ABC_NPAR + j] * u[j];
                    v[3 * n + (size_t)i] = s;
                }
        }
    }
    if (!JTJ)
        return;
    /* Per channel, sums over its rows of w^2 times 1, S, S^2, u_i, S u_i
     * (u = dS/dtheta6..8); then over all rows of A^2 w^2 u_i u_j. Each pass
     * keeps its few sums in registers. */
    double M[ABC_NPAR][ABC_NPAR] = {{0}};
    for (int ch = 0; ch < 3; ch++) {
        double q[9];
        channel_sums(c->w + (size_t)ch * n, s0, s1, s2, s3, n, q);
        double ak = a[ch][0], aa = a[ch][1], am = a[ch][2];
        M[ch][ch] = ak * ak * q[0];
        M[3 + ch][ch] = ak * aa * q[1];
        M[3 + ch][3 + ch] = aa * aa * q[2];
        M[6][ch] = ak * am * q[3];
        M[7][ch] = ak * am * q[4];
        M[8][ch] = ak * am * q[5];
        M[6][3 + ch] = aa * am * q[6];
        M[7][3 + ch] = aa * am * q[7];
        M[8][3 + ch] = aa * am * q[8];
    }
    double A2[3] = {p.A[0] * p.A[0], p.A[1] * p.A[1], p.A[2] * p.A[2]}, q[6];
    shape_sums(c->w, A2, s1, s2, s3, n, q);
    M[6][6] = q[0];
    M[7][6] = q[1];
    M[8][6] = q[2];
    M[7][7] = q[3];
    M[8][7] = q[4];
    M[8][8] = q[5];
    if (pb->prior) {
        const double *W = pb->prior->W;
        for (int i = 0; i < ABC_NPAR; i++)
            for (int j = 0; j <= i; j++)
                for (int r = 0; r < ABC_NPAR; r++)
                    M[i][j] += W[r * ABC_NPAR + i] * W[r * ABC_NPAR + j];
    }
    for (int i = 0; i < ABC_NPAR; i++)
        for (int j = 0; j <= i; j++)
            JTJ[i * ABC_NPAR + j] = JTJ[j * ABC_NPAR + i] = M[i][j];
}

void abc_problem_jblock(const struct abc_problem *pb, const double th[ABC_NPAR],
                        const struct abc_cache *c, int ch, double *Jc)
{
    struct abc_nat p;
    natural(th, &p);
    size_t n = pb->n;
    double a0 = p.dkd[ch] / ABC_PI, a1 = p.dA[ch], am = p.A[ch];
    const double *w = c->w + (size_t)ch * n, *s0 = c->spec, *s1 = c->spec + n,
                 *s2 = c->spec + 2 * n, *s3 = c->spec + 3 * n;
    for (size_t k = 0; k < n; k++) {
        double *row = Jc + 5 * k;
        row[0] = w[k] * a0;
        row[1] = w[k] * a1 * s0[k];
        row[2] = w[k] * am * s1[k];
        row[3] = w[k] * am * s2[k];
        row[4] = w[k] * am * s3[k];
    }
}
