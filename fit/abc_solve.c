/* One local solve of the ABC problem (fit/abc_solve.h): MINPACK's lmder
 * (Moré 1978; the solver of SciPy's least_squares(method="lm")), trust
 * region and stopping tests included, on the 9 x 9 normal equations. J is
 * never formed: the residual pass leaves in a cache what J^T J and J^T f
 * need (abc_problem_normal), and the trust region's subproblem (lm_par) is
 * a few 9 x 9 Cholesky solves with GSL. With GSL's multilarge trust region
 * (Nielsen's damping update) the same starts took up to three times
 * MINPACK's evaluations: rejected steps, and 48 failed trials before it
 * would stop at a minimum. */
#include "fit/abc_solve.h"

#include <float.h>
#include <math.h>
#include <string.h>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_linalg.h>
#include <gsl/gsl_permutation.h>

/* Solves (J^T J + par D^2) dx = -g. L (row-major 9 x 9) receives the
 * Cholesky factor (lower triangle) of that matrix; returns 1 when it is
 * positive definite. Otherwise (a singular J^T J at par 0: a parameter
 * without influence, such as B, C and eta of an all-diffuse fit) dx comes
 * from GSL's modified Cholesky, which factors a nearby positive definite
 * matrix, and 0 is returned (L unusable). */
static int damped_solve(const double *JTJ, const double *g, const double *D, double par,
                        double *dx, double *L)
{
    gsl_matrix_view Lv = gsl_matrix_view_array(L, ABC_NPAR, ABC_NPAR);
    gsl_vector_const_view gv = gsl_vector_const_view_array(g, ABC_NPAR);
    gsl_vector_view xv = gsl_vector_view_array(dx, ABC_NPAR);
    memcpy(L, JTJ, ABC_NPAR * ABC_NPAR * sizeof *L);
    for (int j = 0; j < ABC_NPAR; j++)
        L[j * ABC_NPAR + j] += par * D[j] * D[j];
    int pd = gsl_linalg_cholesky_decomp1(&Lv.matrix) == GSL_SUCCESS;
    if (pd) {
        gsl_linalg_cholesky_solve(&Lv.matrix, &gv.vector, &xv.vector);
    } else {
        double m[ABC_NPAR * ABC_NPAR];
        size_t pdata[ABC_NPAR];
        gsl_permutation perm = {ABC_NPAR, pdata};
        gsl_matrix_view mv = gsl_matrix_view_array(m, ABC_NPAR, ABC_NPAR);
        memcpy(m, JTJ, sizeof m);
        for (int j = 0; j < ABC_NPAR; j++)
            m[j * ABC_NPAR + j] += par * D[j] * D[j];
        if (gsl_linalg_mcholesky_decomp(&mv.matrix, &perm, NULL) != GSL_SUCCESS ||
            gsl_linalg_mcholesky_solve(&mv.matrix, &perm, &gv.vector, &xv.vector) != GSL_SUCCESS)
            for (int j = 0; j < ABC_NPAR; j++)
                dx[j] = NAN;
    }
    for (int j = 0; j < ABC_NPAR; j++)
        dx[j] = -dx[j];
    return pd;
}

static double scaled_norm(const double *D, const double *v)
{
    double s = 0;
    for (int j = 0; j < ABC_NPAR; j++)
        s += (D[j] * v[j]) * (D[j] * v[j]);
    return sqrt(s);
}

/* |y|^2 for L y = D (D dx) / |D dx| (the Newton correction of lmpar). */
static double newton_denominator(const double *L, const double *D, const double *dx,
                                 double dxnorm)
{
    double y[ABC_NPAR], s = 0;
    for (int i = 0; i < ABC_NPAR; i++) {
        double v = D[i] * (D[i] * dx[i] / dxnorm);
        for (int j = 0; j < i; j++)
            v -= L[i * ABC_NPAR + j] * y[j];
        y[i] = v / L[i * ABC_NPAR + i];
        s += y[i] * y[i];
    }
    return s;
}

/* MINPACK's lmpar (Moré 1978) on the normal equations: the step dx of
 * (J^T J + par D^2) dx = -g whose scaled length |D dx| is within 10% of
 * delta, or the Gauss-Newton step when that is shorter. *par is the
 * previous value on entry (a warm start), the one used on return. */
static void lm_par(const double *JTJ, const double *g, const double *D, double delta,
                   double *par, double *dx)
{
    double L[ABC_NPAR * ABC_NPAR];
    int full = damped_solve(JTJ, g, D, 0.0, dx, L);
    double dxnorm = scaled_norm(D, dx), fp = dxnorm - delta;
    if (!(fp > 0.1 * delta)) { /* the Gauss-Newton step is inside (or not finite) */
        *par = 0;
        return;
    }
    double parl = 0, paru, gn = 0;
    if (full)
        parl = (fp / delta) / newton_denominator(L, D, dx, dxnorm);
    for (int j = 0; j < ABC_NPAR; j++)
        gn += (g[j] / D[j]) * (g[j] / D[j]);
    gn = sqrt(gn);
    paru = gn / delta;
    if (paru == 0)
        paru = DBL_MIN / fmin(delta, 0.1);
    double p = fmin(fmax(*par, parl), paru);
    if (p == 0)
        p = gn / dxnorm;
    for (int it = 1;; it++) {
        if (p == 0)
            p = fmax(DBL_MIN, 0.001 * paru);
        int pd = damped_solve(JTJ, g, D, p, dx, L);
        dxnorm = scaled_norm(D, dx);
        double prev = fp;
        fp = dxnorm - delta;
        if (!pd || !isfinite(dxnorm) || fabs(fp) <= 0.1 * delta ||
            (parl == 0 && fp <= prev && prev < 0) || it == 10)
            break;
        double parc = (fp / delta) / newton_denominator(L, D, dx, dxnorm);
        if (fp > 0)
            parl = fmax(parl, p);
        if (fp < 0)
            paru = fmin(paru, p);
        p = fmax(parl, p + parc);
    }
    *par = p;
}

/* A solve's state between its steps. */
struct lm_state {
    double x[ABC_NPAR], D[ABC_NPAR], JTJ[ABC_NPAR * ABC_NPAR], g[ABC_NPAR];
    double cost, fnorm, delta, xnorm, par;
    long nf, max_nf;
    int iter, converged, done;
    const char *reason;
};

/* One trial step of the trust region from s->x: accepted (s->x moves) when
 * the cost fell enough, the region and damping updated either way, and
 * MINPACK's stopping tests applied (s->done). first: the first iteration
 * of a fresh solve, whose region shrinks to the first step. Returns the
 * ratio of actual to predicted decrease. */
static double lm_trial(const struct abc_problem *pb, const struct fit_options *opt,
                       double step_ftol, int first, struct lm_state *s, struct abc_cache *cache)
{
    double dx[ABC_NPAR], xt[ABC_NPAR];
    lm_par(s->JTJ, s->g, s->D, s->delta, &s->par, dx);
    double pnorm = scaled_norm(s->D, dx);
    if (!isfinite(pnorm)) {
        s->done = 1;
        return 0;
    }
    if (first)
        s->delta = fmin(s->delta, pnorm);
    for (int j = 0; j < ABC_NPAR; j++)
        xt[j] = s->x[j] + dx[j];
    double cost1 = abc_problem_resid(pb, xt, NULL, cache);
    s->nf++;
    double fnorm = s->fnorm, fnorm1 = sqrt(2.0 * cost1);
    double actred = 0.1 * fnorm1 < fnorm ? 1.0 - (fnorm1 / fnorm) * (fnorm1 / fnorm) : -1.0;
    double jdx = 0; /* |J dx|^2 = dx^T J^T J dx */
    for (int i = 0; i < ABC_NPAR; i++) {
        double r = 0;
        for (int j = 0; j < ABC_NPAR; j++)
            r += s->JTJ[i * ABC_NPAR + j] * dx[j];
        jdx += dx[i] * r;
    }
    double t1 = sqrt(fmax(jdx, 0.0)) / fnorm, t2 = sqrt(s->par) * pnorm / fnorm;
    double prered = t1 * t1 + t2 * t2 / 0.5, dirder = -(t1 * t1 + t2 * t2);
    double ratio = prered != 0 ? actred / prered : 0;
    if (ratio <= 0.25) {
        double t = actred >= 0 ? 0.5 : 0.5 * dirder / (dirder + 0.5 * actred);
        if (0.1 * fnorm1 >= fnorm || t < 0.1 || !(t == t))
            t = 0.1;
        s->delta = t * fmin(s->delta, pnorm / 0.1);
        s->par /= t;
    } else if (s->par == 0 || ratio >= 0.75) {
        s->delta = pnorm / 0.5;
        s->par *= 0.5;
    }
    if (ratio >= 1e-4) { /* accepted */
        memcpy(s->x, xt, sizeof s->x);
        s->xnorm = scaled_norm(s->D, s->x);
        s->fnorm = fnorm1;
        s->cost = cost1;
        s->iter++;
    }
    if (fabs(actred) <= step_ftol && prered <= step_ftol && 0.5 * ratio <= 1) {
        s->converged = s->done = 1;
        s->reason = "small decrease (ftol)";
    } else if (s->delta <= opt->xtol * s->xnorm) {
        s->converged = s->done = 1;
        s->reason = "small step (xtol)";
    } else if (fabs(actred) <= DBL_EPSILON && prered <= DBL_EPSILON && 0.5 * ratio <= 1) {
        s->converged = s->done = 1;
        s->reason = "no reducing step found (at a minimum to working precision)";
    } else if (s->delta <= DBL_EPSILON * s->xnorm) {
        s->converged = s->done = 1;
        s->reason = "no reducing step found (at a minimum to working precision)";
    } else if (s->nf >= s->max_nf) {
        s->done = 1;
        s->reason = "evaluation limit reached";
    }
    return ratio;
}

int abc_local_solve(const struct abc_problem *pb, const double theta0[ABC_NPAR],
                    const struct fit_options *opt, double step_ftol,
                    const struct abc_solve_result *resume, struct abc_solve_result *res)
{
    struct abc_cache cache;
    if (abc_cache_init(&cache, pb) < 0)
        return -1;
    struct lm_state s = {.reason = "solver error", .max_nf = 10L * opt->max_iter, .nf = 1};
    memcpy(s.x, resume ? resume->theta : theta0, sizeof s.x);
    s.cost = abc_problem_resid(pb, s.x, NULL, &cache);
    s.fnorm = sqrt(2.0 * s.cost);
    if (resume) {
        memcpy(s.D, resume->D, sizeof s.D);
        s.delta = resume->delta;
        s.par = resume->par;
        s.xnorm = scaled_norm(s.D, s.x);
    }
    double hist[ABC_STALL_WINDOW];
    for (int i = 0; i < ABC_STALL_WINDOW; i++)
        hist[i] = INFINITY;
    s.done = !isfinite(s.cost);
    /* the polish (resumed) is past the crawl: its stall test follows its ftol */
    double stall_ftol = resume ? opt->ftol * fmin(1.0, step_ftol / ABC_COARSE_FTOL) : opt->ftol;
    while (!s.done) {
        if (s.iter >= opt->max_iter) {
            s.reason = "iteration limit reached";
            break;
        }
        abc_problem_normal(pb, s.x, 1, NULL, s.g, s.JTJ, &cache);
        double cn[ABC_NPAR];
        for (int j = 0; j < ABC_NPAR; j++)
            cn[j] = sqrt(s.JTJ[j * ABC_NPAR + j]);
        int first = s.iter == 0 && !resume;
        if (first) { /* MINPACK's mode 1: scale by J's column norms; factor 100 */
            for (int j = 0; j < ABC_NPAR; j++)
                s.D[j] = cn[j] > 0 ? cn[j] : 1.0;
            s.xnorm = scaled_norm(s.D, s.x);
            s.delta = s.xnorm > 0 ? 100.0 * s.xnorm : 100.0;
        }
        /* gradient test: the largest cosine between f and a column of J */
        double gnorm = 0;
        for (int j = 0; j < ABC_NPAR; j++)
            if (cn[j] > 0 && s.fnorm > 0)
                gnorm = fmax(gnorm, fabs(s.g[j]) / (cn[j] * s.fnorm));
        if (gnorm <= opt->gtol || s.fnorm == 0) {
            s.converged = 1;
            s.reason = "small gradient (gtol)";
            break;
        }
        for (int j = 0; j < ABC_NPAR; j++)
            s.D[j] = fmax(s.D[j], cn[j]);
        double ratio = 0;
        do /* trial steps until one lowers the cost enough */
            ratio = lm_trial(pb, opt, step_ftol, first, &s, &cache);
        while (!s.done && ratio < 1e-4);
        if (s.done || ratio < 1e-4)
            break;
        /* Along the flat valleys of this model (eta large, or C large at
         * fixed B C) the step and decrease tests are met only after hundreds
         * of crawling steps that change nothing (gold-metallic-paint: MINPACK
         * takes 980 evaluations to polish it). So also stop when the cost
         * fell by less than ftol (relative) over the last
         * ABC_STALL_WINDOW steps. */
        if (s.iter >= ABC_STALL_WINDOW &&
            hist[s.iter % ABC_STALL_WINDOW] - s.cost <= stall_ftol * s.cost) {
            s.converged = 1;
            s.reason = "cost stalled (ftol over the last iterations)";
            break;
        }
        hist[s.iter % ABC_STALL_WINDOW] = s.cost;
    }
    memcpy(res->theta, s.x, sizeof s.x);
    res->cost = s.cost;
    res->iterations = s.iter;
    res->converged = s.converged;
    res->reason = s.reason;
    memcpy(res->D, s.D, sizeof s.D);
    res->delta = s.delta;
    res->par = s.par;
    abc_cache_free(&cache);
    if (!isfinite(res->cost))
        return -1;
    return 0;
}
