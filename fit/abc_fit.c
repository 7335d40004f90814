/* fit_abc: validation, start search, local trust-region solves with GSL. */
#include <float.h>
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_blas.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_linalg.h>
#include <gsl/gsl_math.h>
#include <gsl/gsl_multifit_nlinear.h>
#include <gsl/gsl_permutation.h>
#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>

#include "fit/abc_problem.h"
#include "fit/domain_weights.h"
#include "fit/fit.h"
#include "fit/sample_order.h"

/* Above this many samples the start search and the multi-start solves run
 * on a seeded random subset; only the winner is refined on all samples.
 * The grid scores on a smaller subset still: it only ranks basins. */
#define ABC_LOCAL_MAX 8000
#define ABC_GRID_MAX 4000
#define ABC_MAX_STARTS 32

/* Cost-stall test: iterations over which the relative decrease is taken. */
#define ABC_STALL_WINDOW 8
/* Small-decrease test, MINPACK's ftol (the one SciPy's least_squares
 * applies): a step whose actual and predicted decrease are both at most
 * this much (relative to the cost) ends the solve. The starts are solved to
 * ABC_COARSE_FTOL, enough to tell their basins apart (the distinct minima
 * of the 10 study materials differ by 1e-4 relative or more); the winner
 * is then polished to ABC_POLISH_FTOL. */
#define ABC_COARSE_FTOL 1e-6
#define ABC_POLISH_FTOL 1e-10

struct fit_options fit_default_options(void)
{
    struct fit_options o = {
        .loss = FIT_LOSS_LOG,
        .max_iter = 200,
        .n_starts = 5,
        .seed = 1,
        .xtol = 1e-8,
        .gtol = 1e-8,
        .ftol = 1e-5,
        .warm_start = NULL,
        .global = FIT_GLOBAL_GRID,
        .heldout = 1,
    };
    return o;
}

struct solve_result {
    double theta[ABC_NPAR];
    double cost;
    int iterations;
    int converged;
    const char *reason;
    /* the trust region where the solve stopped, to resume it (the polish) */
    double D[ABC_NPAR], delta, par;
};

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

/* One Levenberg-Marquardt solve from theta0: MINPACK's lmder (the solver
 * of SciPy's least_squares(method="lm")), trust region and stopping tests
 * included, on the 9 x 9 normal equations. J is never formed: the residual
 * pass leaves in a cache what J^T J and J^T f need (abc_problem_normal), and
 * the trust region's subproblem (lm_par) is a few 9 x 9 Cholesky solves with
 * GSL. With GSL's multilarge trust region (Nielsen's damping update) the
 * same starts took up to three times MINPACK's evaluations: rejected steps,
 * and 48 failed trials before it would stop at a minimum. */
static int local_solve(const struct abc_problem *pb, const double theta0[ABC_NPAR],
                       const struct fit_options *opt, double step_ftol,
                       const struct solve_result *resume, struct solve_result *res)
{
    struct abc_cache cache;
    if (abc_cache_init(&cache, pb) < 0)
        return -1;
    double x[ABC_NPAR], xt[ABC_NPAR], dx[ABC_NPAR], D[ABC_NPAR], JTJ[ABC_NPAR * ABC_NPAR],
        g[ABC_NPAR];
    memcpy(x, resume ? resume->theta : theta0, sizeof x);
    double cost = abc_problem_resid(pb, x, NULL, &cache);
    long nf = 1, max_nf = 10L * opt->max_iter;
    double fnorm = sqrt(2.0 * cost), delta = 0, xnorm = 0, par = 0;
    if (resume) {
        memcpy(D, resume->D, sizeof D);
        delta = resume->delta;
        par = resume->par;
        xnorm = scaled_norm(D, x);
    }
    double hist[ABC_STALL_WINDOW];
    for (int i = 0; i < ABC_STALL_WINDOW; i++)
        hist[i] = INFINITY;
    const char *reason = "solver error";
    int iter = 0, converged = 0, done = !isfinite(cost);
    /* the polish (resumed) is past the crawl: its stall test follows its ftol */
    double stall_ftol = resume ? opt->ftol * fmin(1.0, step_ftol / ABC_COARSE_FTOL) : opt->ftol;
    while (!done) {
        if (iter >= opt->max_iter) {
            reason = "iteration limit reached";
            break;
        }
        abc_problem_normal(pb, x, 1, NULL, g, JTJ, &cache);
        double cn[ABC_NPAR];
        for (int j = 0; j < ABC_NPAR; j++)
            cn[j] = sqrt(JTJ[j * ABC_NPAR + j]);
        if (iter == 0 && !resume) { /* MINPACK's mode 1: scale by J's column norms; factor 100 */
            for (int j = 0; j < ABC_NPAR; j++)
                D[j] = cn[j] > 0 ? cn[j] : 1.0;
            xnorm = scaled_norm(D, x);
            delta = xnorm > 0 ? 100.0 * xnorm : 100.0;
        }
        /* gradient test: the largest cosine between f and a column of J */
        double gnorm = 0;
        for (int j = 0; j < ABC_NPAR; j++)
            if (cn[j] > 0 && fnorm > 0)
                gnorm = fmax(gnorm, fabs(g[j]) / (cn[j] * fnorm));
        if (gnorm <= opt->gtol || fnorm == 0) {
            converged = 1;
            reason = "small gradient (gtol)";
            break;
        }
        for (int j = 0; j < ABC_NPAR; j++)
            D[j] = fmax(D[j], cn[j]);
        double ratio = 0;
        do { /* trial steps until one lowers the cost enough */
            lm_par(JTJ, g, D, delta, &par, dx);
            double pnorm = scaled_norm(D, dx);
            if (!isfinite(pnorm)) {
                done = 1;
                break;
            }
            if (iter == 0 && !resume)
                delta = fmin(delta, pnorm);
            for (int j = 0; j < ABC_NPAR; j++)
                xt[j] = x[j] + dx[j];
            double cost1 = abc_problem_resid(pb, xt, NULL, &cache);
            nf++;
            double fnorm1 = sqrt(2.0 * cost1);
            double actred = 0.1 * fnorm1 < fnorm ? 1.0 - (fnorm1 / fnorm) * (fnorm1 / fnorm) : -1.0;
            double jdx = 0; /* |J dx|^2 = dx^T J^T J dx */
            for (int i = 0; i < ABC_NPAR; i++) {
                double r = 0;
                for (int j = 0; j < ABC_NPAR; j++)
                    r += JTJ[i * ABC_NPAR + j] * dx[j];
                jdx += dx[i] * r;
            }
            double t1 = sqrt(fmax(jdx, 0.0)) / fnorm, t2 = sqrt(par) * pnorm / fnorm;
            double prered = t1 * t1 + t2 * t2 / 0.5, dirder = -(t1 * t1 + t2 * t2);
            ratio = prered != 0 ? actred / prered : 0;
            if (ratio <= 0.25) {
                double t = actred >= 0 ? 0.5 : 0.5 * dirder / (dirder + 0.5 * actred);
                if (0.1 * fnorm1 >= fnorm || t < 0.1 || !(t == t))
                    t = 0.1;
                delta = t * fmin(delta, pnorm / 0.1);
                par /= t;
            } else if (par == 0 || ratio >= 0.75) {
                delta = pnorm / 0.5;
                par *= 0.5;
            }
            if (ratio >= 1e-4) { /* accepted */
                memcpy(x, xt, sizeof x);
                xnorm = scaled_norm(D, x);
                fnorm = fnorm1;
                cost = cost1;
                iter++;
            }
            if (fabs(actred) <= step_ftol && prered <= step_ftol && 0.5 * ratio <= 1) {
                converged = done = 1;
                reason = "small decrease (ftol)";
            } else if (delta <= opt->xtol * xnorm) {
                converged = done = 1;
                reason = "small step (xtol)";
            } else if (fabs(actred) <= DBL_EPSILON && prered <= DBL_EPSILON && 0.5 * ratio <= 1) {
                converged = done = 1;
                reason = "no reducing step found (at a minimum to working precision)";
            } else if (delta <= DBL_EPSILON * xnorm) {
                converged = done = 1;
                reason = "no reducing step found (at a minimum to working precision)";
            } else if (nf >= max_nf) {
                done = 1;
                reason = "evaluation limit reached";
            }
        } while (!done && ratio < 1e-4);
        if (done || ratio < 1e-4)
            break;
        /* Along the flat valleys of this model (eta large, or C large at
         * fixed B C) the step and decrease tests are met only after hundreds
         * of crawling steps that change nothing (gold-metallic-paint: MINPACK
         * takes 980 evaluations to polish it). So also stop when the cost
         * fell by less than ftol (relative) over the last
         * ABC_STALL_WINDOW steps. */
        if (iter >= ABC_STALL_WINDOW && hist[iter % ABC_STALL_WINDOW] - cost <= stall_ftol * cost) {
            converged = 1;
            reason = "cost stalled (ftol over the last iterations)";
            break;
        }
        hist[iter % ABC_STALL_WINDOW] = cost;
    }
    memcpy(res->theta, x, sizeof x);
    res->cost = cost;
    res->iterations = iter;
    res->converged = converged;
    res->reason = reason;
    memcpy(res->D, D, sizeof D);
    res->delta = delta;
    res->par = par;
    abc_cache_free(&cache);
    if (!isfinite(res->cost))
        return -1;
    return 0;
}

/* Finite, above the horizon, and 1 + f cos > 0 for the values divided by
 * scale (the log loss's domain, on the data the fit sees). */
static int sample_usable(const struct fit_sample *s, double scale)
{
    const struct brdf_pair *g = &s->g;
    for (int k = 0; k < 3; k++)
        if (!isfinite(g->wi[k]) || !isfinite(g->wo[k]))
            return 0;
    if (!(g->wi[2] > 0) || !(g->wo[2] > 0))
        return 0;
    for (int c = 0; c < 3; c++)
        if (!isfinite(s->rgb[c]) || !(1.0 + s->rgb[c] / scale * g->wi[2] > 0))
            return 0;
    return 1;
}

/* The in-plane grid of predictive_sd (theta_i 0..80 step 10, theta_r
 * -80..80 step 4, blind zone 5 degrees; its first 153 pairs), built once
 * per process: the same for every fit. */
#define PRED_GRID_MAX (17 * 9)
static struct fit_sample pred_grid[PRED_GRID_MAX];
static size_t pred_grid_n;
static pthread_once_t pred_grid_once = PTHREAD_ONCE_INIT;

static void pred_grid_build(void)
{
    size_t n = 0;
    for (int i = 0; i <= 8; i++)
        for (int r = -20; r <= 20; r++) {
            double ti = 10.0 * i, tr = 4.0 * r;
            if (fabs(ti + tr) < 5 || n >= PRED_GRID_MAX)
                continue;
            brdf_pair_inplane(ti, tr, &pred_grid[n].g);
            pred_grid[n].rgb[0] = pred_grid[n].rgb[1] = pred_grid[n].rgb[2] = 0;
            n++;
        }
    pred_grid_n = n;
}

/* Mean over the in-plane grid (pred_grid) and the channels of the standard
 * deviation of the predicted log(1 + f cos theta_i): g^T cov g with g its
 * gradient in theta. Parameters GSL found undetermined have zero
 * covariance and add nothing: they do not move the prediction. */
static double predictive_sd(const double th[ABC_NPAR], double c[ABC_NPAR][ABC_NPAR])
{
    pthread_once(&pred_grid_once, pred_grid_build);
    size_t n = pred_grid_n;
    struct abc_problem pb;
    double *J = malloc(3 * n * ABC_NPAR * sizeof *J);
    if (!J || abc_problem_init(&pb, pred_grid, NULL, n) < 0) {
        free(J);
        return NAN;
    }
    abc_problem_eval(&pb, th, NULL, J);
    double sum = 0;
    for (size_t row = 0; row < 3 * n; row++) {
        const double *g = J + row * ABC_NPAR;
        /* a row has 5 non-zeros; the zero terms add nothing (c is finite) */
        int nz[ABC_NPAR], m = 0;
        for (int a = 0; a < ABC_NPAR; a++)
            if (g[a] != 0)
                nz[m++] = a;
        double v = 0;
        for (int i = 0; i < m; i++)
            for (int j = 0; j < m; j++)
                v += g[nz[i]] * c[nz[i]][nz[j]] * g[nz[j]];
        sum += sqrt(fmax(v, 0.0));
    }
    abc_problem_free(&pb);
    free(J);
    return sum / (double)(3 * n);
}

/* The residual variance of a fit of cost (half the sum of squared, weighted
 * residuals) over pb's rows: their mean square with ABC_NPAR degrees of
 * freedom spent. Weighted rows count as Kish's effective number,
 * (sum w)^2 / sum w^2, all of them when the weights are equal: samples of
 * weight 0 add nothing to what the residuals can tell. NAN for no more
 * (effective) rows than parameters. */
static double residual_variance(const struct abc_problem *pb, double cost)
{
    double rows = 3.0 * (double)pb->n;
    if (!pb->sw)
        return rows > ABC_NPAR ? 2.0 * cost / (rows - ABC_NPAR) : NAN;
    double sw = 0, sw2 = 0;
    for (size_t k = 0; k < pb->n; k++) {
        double w = pb->sw[k] * pb->sw[k];
        sw += w;
        sw2 += w * w;
    }
    double eff = sw2 > 0 ? 3.0 * sw * sw / sw2 : 0;
    return eff > ABC_NPAR ? 2.0 * cost / (3.0 * sw) * eff / (eff - ABC_NPAR) : NAN;
}

/* A weighted fit's covariance, up to s2: the sandwich H^-1 (J^T W^2 J)
 * H^-1 with hinv = H^-1 = (J^T W J)^-1, into hinv. J^T W^2 J (with the
 * prior's rows, as in H) is the Gram matrix of pb's Jacobian with its rows
 * scaled by the weights themselves instead of their square roots. Returns
 * 0, -1 on no memory. */
static int sandwich(const struct abc_problem *pb, const double th[ABC_NPAR], gsl_matrix *hinv)
{
    struct abc_problem sq = *pb;
    double K[(15 + ABC_NPAR) * ABC_NPAR], cn[ABC_NPAR];
    double *w = malloc((pb->n ? pb->n : 1) * sizeof *w);
    if (!w)
        return -1;
    for (size_t k = 0; k < pb->n; k++)
        w[k] = pb->sw[k] * pb->sw[k];
    sq.sw = w;
    size_t nk = abc_jacobian_root(&sq, th, K, cn);
    free(w);
    gsl_matrix *meat = gsl_matrix_alloc(ABC_NPAR, ABC_NPAR);
    gsl_matrix *half = gsl_matrix_alloc(ABC_NPAR, ABC_NPAR);
    int rc = nk && meat && half ? 0 : -1;
    if (rc == 0) {
        gsl_matrix_const_view Kv = gsl_matrix_const_view_array(K, nk, ABC_NPAR);
        gsl_blas_dgemm(CblasTrans, CblasNoTrans, 1.0, &Kv.matrix, &Kv.matrix, 0.0, meat);
        gsl_blas_dgemm(CblasNoTrans, CblasNoTrans, 1.0, hinv, meat, 0.0, half);
        gsl_blas_dgemm(CblasNoTrans, CblasNoTrans, 1.0, half, hinv, 0.0, meat);
        gsl_matrix_memcpy(hinv, meat);
    }
    gsl_matrix_free(meat);
    gsl_matrix_free(half);
    return rc;
}

/* Parameter standard deviations at theta: covariance s2 (J^T J)^-1 from
 * GSL, mapped to natural units. Weighted samples (pb->sw) are not weighted
 * by their precision but by the share of the domain they stand for, and a
 * sample standing for more of it is no less noisy: their covariance is the
 * sandwich s2 H^-1 (J^T W^2 J) H^-1, H = J^T W J, which the equal weights
 * of an unweighted fit reduce to s2 (J^T J)^-1 (importance weights
 * inflate the variance by about mean(w^2), Kish's design effect). A
 * parameter whose column of J is zero (clamped, or without influence) is
 * undetermined: INFINITY. K (nk rows) and cn: the root of J^T J at theta
 * (abc_jacobian_root). */
static void uncertainty(const struct abc_problem *pb, const double th[ABC_NPAR], double s2,
                        const double *K, size_t nk, const double cn[ABC_NPAR],
                        struct fit_uncertainty *u)
{
    double *sd = (double *)u; /* 10 doubles in the order of the struct */
    for (int i = 0; i < 10; i++)
        sd[i] = NAN;
    if (!isfinite(s2))
        return;
    gsl_matrix *cov = gsl_matrix_alloc(ABC_NPAR, ABC_NPAR);
    if (!cov || nk < ABC_NPAR)
        goto done;
    gsl_matrix_const_view Kv = gsl_matrix_const_view_array(K, nk, ABC_NPAR);
    if (gsl_multifit_nlinear_covar(&Kv.matrix, 1e-12, cov) != GSL_SUCCESS)
        goto done;
    /* GSL zeroes the rows and columns of the parameters it found dependent */
    double c[ABC_NPAR][ABC_NPAR];
    int undet[ABC_NPAR];
    for (int i = 0; i < ABC_NPAR; i++)
        undet[i] = !(cn[i] > 0) || !(gsl_matrix_get(cov, (size_t)i, (size_t)i) > 0);
    if (pb->sw && sandwich(pb, th, cov) < 0)
        goto done;
    for (int i = 0; i < ABC_NPAR; i++)
        for (int j = 0; j < ABC_NPAR; j++)
            c[i][j] = s2 * gsl_matrix_get(cov, (size_t)i, (size_t)j);
    for (int k = 0; k < 3; k++) {
        u->log_kd[k] = undet[k] ? INFINITY : sqrt(c[k][k]);
        u->log_A[k] = undet[3 + k] ? INFINITY : sqrt(c[3 + k][3 + k]);
    }
    /* log B = theta6 - theta7 */
    u->log_B = undet[6] || undet[7] ? INFINITY : sqrt(fmax(0.0, c[6][6] + c[7][7] - 2 * c[6][7]));
    /* C beyond its clamp moves nothing, but theta7 still moves B (log B =
     * theta6 - theta7): columns 6 and 7 are then exactly opposite, and
     * which of the two the pivoted QR drops is a tie decided by rounding.
     * C itself is undetermined either way. */
    int c_clamped = !(th[7] >= ABC_LOGC_MIN && th[7] <= ABC_LOGC_MAX);
    u->log_C = undet[7] || c_clamped ? INFINITY : sqrt(c[7][7]);
    double sg = 1.0 / (1.0 + exp(-th[8]));
    double deta = (ABC_ETA_MAX - 1.0) * sg * (1.0 - sg); /* d eta / d theta8 */
    u->eta = undet[8] ? INFINITY : deta * sqrt(c[8][8]);
    u->pred_log = predictive_sd(th, c);
done:
    gsl_matrix_free(cov);
}

/* The population's lobe shapes as starts: real materials cluster in (B, C,
 * eta), and a few samples that cannot locate the lobe alone can still
 * tell which known shape fits them best. Writes up to
 * ABC_PRIOR_SHAPE_STARTS starts, best MAP cost first; returns the count. */
static int shape_starts(const struct abc_problem *pb, const struct abc_prior_term *pt,
                        double *starts)
{
    if (!pt->n_shapes)
        return 0;
    double *spec = malloc((pb->n ? pb->n : 1) * sizeof *spec);
    if (!spec)
        return 0;
    double best_cost[ABC_PRIOR_SHAPE_STARTS];
    int got = 0;
    for (size_t i = 0; i < pt->n_shapes; i++) {
        struct brdf_abc p;
        p.B = pt->shapes[i][0];
        p.C = pt->shapes[i][1];
        p.eta = pt->shapes[i][2];
        abc_linear_score(pb, p.B, p.C, p.eta, p.kd, p.A, spec);
        for (int c = 0; c < 3; c++) {
            p.kd[c] = fmax(p.kd[c], 1e-6);
            p.A[c] = fmax(p.A[c], 1e-6);
        }
        double th[ABC_NPAR];
        abc_params_to_theta(&p, th);
        double cost = abc_problem_cost(pb, th);
        if (!isfinite(cost))
            continue;
        /* insertion into the short sorted list */
        int at = got < ABC_PRIOR_SHAPE_STARTS ? got : ABC_PRIOR_SHAPE_STARTS - 1;
        if (got == ABC_PRIOR_SHAPE_STARTS && cost >= best_cost[at])
            continue;
        while (at > 0 && best_cost[at - 1] > cost) {
            best_cost[at] = best_cost[at - 1];
            memcpy(starts + (size_t)at * ABC_NPAR, starts + (size_t)(at - 1) * ABC_NPAR,
                   sizeof th);
            at--;
        }
        best_cost[at] = cost;
        memcpy(starts + (size_t)at * ABC_NPAR, th, sizeof th);
        if (got < ABC_PRIOR_SHAPE_STARTS)
            got++;
    }
    free(spec);
    return got;
}

static int same_sample(const struct fit_sample *x, const struct fit_sample *y)
{
    for (int i = 0; i < 3; i++)
        if (x->g.wi[i] != y->g.wi[i] || x->g.wo[i] != y->g.wo[i] || x->rgb[i] != y->rgb[i])
            return 0;
    return 1;
}

/* A hash of what same_sample compares: the bit patterns, with -0 taken as
 * +0 (== treats them alike; the samples here are finite). */
static uint64_t sample_hash(const struct fit_sample *s)
{
    const double v[9] = {s->g.wi[0], s->g.wi[1], s->g.wi[2], s->g.wo[0], s->g.wo[1],
                         s->g.wo[2], s->rgb[0],  s->rgb[1],  s->rgb[2]};
    uint64_t h = 0x9E3779B97F4A7C15u;
    for (int i = 0; i < 9; i++) {
        double x = v[i] == 0 ? 0.0 : v[i];
        uint64_t b;
        memcpy(&b, &x, sizeof b);
        h = (h ^ b) * 0xFF51AFD7ED558CCDu;
        h ^= h >> 32;
    }
    return h;
}

/* Drop exact duplicates (same directions and value: a journal replayed
 * twice, a sample pasted twice) from idx[0..nv), keeping the first and
 * the original order; returns the new count. A repeated measurement with
 * another value is data and stays. An open-addressing hash table: one pass
 * in input order (a sort with a nine-key comparator was a tenth of a DS1
 * fit). */
static size_t drop_duplicates(const struct fit_sample *s, size_t *idx, size_t nv)
{
    if (nv < 2)
        return nv;
    size_t cap = 4;
    while (cap < 2 * nv)
        cap *= 2;
    size_t *slot = calloc(cap, sizeof *slot); /* sample index + 1; 0: empty */
    if (!slot) /* keep everything rather than fail */
        return nv;
    size_t m = 0;
    for (size_t i = 0; i < nv; i++) {
        const struct fit_sample *si = &s[idx[i]];
        size_t h = (size_t)sample_hash(si) & (cap - 1);
        int dup = 0;
        while (slot[h] && !(dup = same_sample(&s[slot[h] - 1], si)))
            h = (h + 1) & (cap - 1);
        if (dup)
            continue;
        slot[h] = idx[i] + 1;
        idx[m++] = idx[i];
    }
    free(slot);
    return m;
}

/* abc_problem_cost through the solver's vectorised residual pass (equal
 * to rounding: a log of the ratio for the log loss's log1p pair). */
static double fast_cost(const struct abc_problem *pb, const double th[ABC_NPAR])
{
    struct abc_cache c;
    if (abc_cache_init(&c, pb) < 0)
        return abc_problem_cost(pb, th);
    double cost = abc_problem_resid(pb, th, NULL, &c);
    abc_cache_free(&c);
    return cost;
}

/* RMS log residual of the data rows at theta (the prior's rows and the
 * fit's loss aside): residuals comparable across losses and models. */
static double rms_log(const struct abc_problem *pb, const double th[ABC_NPAR])
{
    struct abc_problem v = *pb;
    v.loss = FIT_LOSS_LOG;
    v.prior = NULL;
    return pb->n ? sqrt(2.0 * fast_cost(&v, th) / (3.0 * (double)pb->n)) : NAN;
}

/* peak-unbounded (fit/fit_status.h): the largest of the n readings idx
 * names is a lower bound, and the model p exceeds a lower bound by more
 * than FIT_STATUS_PEAK_FACTOR. */
static int peak_unbounded(const struct fit_sample *s, const size_t *idx, size_t n,
                          const unsigned char *lower, const struct brdf_abc *p)
{
    size_t top = 0;
    double largest = -INFINITY, ratio = 0;
    for (size_t k = 0; lower && k < n; k++)
        for (int c = 0; c < 3; c++)
            if (s[idx[k]].rgb[c] > largest) {
                largest = s[idx[k]].rgb[c];
                top = idx[k];
            }
    if (!lower || !lower[top])
        return 0;
    for (size_t k = 0; k < n; k++) {
        if (!lower[idx[k]])
            continue;
        double f[3];
        brdf_abc_eval(p, &s[idx[k]].g, f);
        for (int c = 0; c < 3; c++)
            if (s[idx[k]].rgb[c] > 0)
                ratio = fmax(ratio, f[c] / s[idx[k]].rgb[c]);
    }
    return ratio > FIT_STATUS_PEAK_FACTOR;
}

/* Folds of the held-out residual: each sample is held out once, by a fit
 * of the others started from the fit of all. */
#define ABC_FOLDS 5

/* The RMS log residual of samples held out, ABC_FOLDS folds (sample k in
 * fold k mod ABC_FOLDS) of the samples of pb (s[idx[k]], k < pb->n), each
 * fold predicted by a fit of the rest resumed from theta. NAN when a
 * fold's rest is too small to fit. */
static double heldout_rms(const struct abc_problem *pb, const size_t *idx,
                          const struct fit_options *opt, const double *weight,
                          const double theta[ABC_NPAR])
{
    size_t n = pb->n, folds = n < ABC_FOLDS ? n : ABC_FOLDS, need = pb->prior ? 1 : 3;
    if (!folds || n - (n + folds - 1) / folds < need)
        return NAN;
    /* positions in pb, and the samples they are (for the per-sample flags) */
    size_t *train = malloc(2 * n * sizeof *train), *test = malloc(2 * n * sizeof *test);
    double sum = 0, tested = 0; /* residual rows tested, each counted by its weight */
    for (size_t f = 0; train && test && f < folds; f++) {
        size_t nt = 0, nh = 0;
        for (size_t k = 0; k < n; k++) {
            if (k % folds == f)
                test[nh++] = k;
            else
                train[nt++] = k;
        }
        size_t *train_s = train + n, *test_s = test + n;
        for (size_t k = 0; k < nt; k++)
            train_s[k] = idx[train[k]];
        for (size_t k = 0; k < nh; k++)
            test_s[k] = idx[test[k]];
        struct abc_problem tp = {0}, hp = {0};
        struct solve_result r;
        if (abc_problem_subset(&tp, pb, train, nt) == 0 &&
            abc_problem_set_loss(&tp, opt->loss) == 0 &&
            abc_problem_set_lower(&tp, opt->lower_bound, train_s) == 0 &&
            abc_problem_set_weights(&tp, weight, train_s) == 0 &&
            abc_problem_subset(&hp, pb, test, nh) == 0 &&
            abc_problem_set_lower(&hp, opt->lower_bound, test_s) == 0 &&
            abc_problem_set_weights(&hp, weight, test_s) == 0) {
            tp.prior = pb->prior;
            if (local_solve(&tp, theta, opt, ABC_COARSE_FTOL, NULL, &r) == 0) {
                sum += 2.0 * fast_cost(&hp, r.theta);
                for (size_t k = 0; k < nh; k++)
                    tested += 3 * (weight ? weight[test_s[k]] : 1.0);
            }
        }
        abc_problem_free(&tp);
        abc_problem_free(&hp);
    }
    free(train);
    free(test);
    return tested > 0 ? sqrt(sum / tested) : NAN;
}

static int gsl_handler_off_done;

int fit_abc(const struct fit_sample *samples, size_t n, const struct fit_options *opt,
            struct brdf_abc *out, struct fit_info *info, struct gonio_err *err)
{
    return abc_fit_run(samples, n, opt, NULL, 0.0, out, info, err);
}

/* abc_fit_run on samples in canonical order (fit/sample_order.h). */
static int fit_sorted(const struct fit_sample *samples, size_t n, struct fit_options opt,
                      const struct abc_prior_term *prior, double prior_sigma,
                      struct brdf_abc *out, struct fit_info *info, struct gonio_err *err)
{
    if (opt.max_iter <= 0 || opt.n_starts <= 0)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "fit_abc: max_iter %d, n_starts %d: both must be >= 1",
                             opt.max_iter, opt.n_starts);
    if (opt.n_starts > ABC_MAX_STARTS)
        opt.n_starts = ABC_MAX_STARTS;
    if (opt.loss != FIT_LOSS_LOG && opt.loss != FIT_LOSS_RELATIVE && opt.loss != FIT_LOSS_COS_L2)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "fit_abc: loss %d: use FIT_LOSS_LOG, _RELATIVE or _COS_L2",
                             (int)opt.loss);
    if (opt.global != FIT_GLOBAL_GRID && opt.global != FIT_GLOBAL_DE)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "fit_abc: global %d: use FIT_GLOBAL_GRID or FIT_GLOBAL_DE",
                             (int)opt.global);
    /* Once per process, not per call: the handler is global state. */
    if (!gsl_handler_off_done) {
        gsl_set_error_handler_off();
        gsl_handler_off_done = 1;
    }

    size_t *idx = malloc((n ? n : 1) * sizeof *idx);
    if (!idx)
        return gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory for %zu samples", n);
    /* The data's scale, from the finite samples above the horizon (any
     * value is finite divided by infinity), is divided out of the data
     * before anything else looks at them: multiplied back into kd and A at
     * the end (fit_data_scale); a warm start moves with it. A prior stays:
     * the data it meets are in 1/sr again. */
    size_t nv = 0;
    for (size_t i = 0; i < n; i++)
        if (sample_usable(&samples[i], INFINITY))
            idx[nv++] = i;
    double scale = fit_data_scale(samples, idx, nv);
    size_t kept = 0;
    for (size_t k = 0; k < nv; k++)
        if (sample_usable(&samples[idx[k]], scale))
            idx[kept++] = idx[k];
    nv = drop_duplicates(samples, idx, kept);
    if (nv < (prior ? 1u : 3u)) {
        free(idx);
        return gonio_err_set(err, GONIO_EFIT,
                             "fit_abc: %zu usable samples of %zu (the rest have a NaN/inf value or "
                             "geometry, lie below the horizon, have 1 + f cos <= 0 or repeat one); need at "
                             "least 3 for 9 parameters",
                             nv, n);
    }

    /* weight[i] for sample i (indexed as the samples, for the subsets) */
    double *weight = NULL, *share = NULL;
    if (opt.domain_weights && nv >= FIT_DOMAIN_WEIGHTS_MIN_SAMPLES &&
        (!(weight = malloc(n * sizeof *weight)) || !(share = malloc(nv * sizeof *share)) ||
         fit_domain_weights(samples, idx, nv, share) < 0)) {
        free(weight);
        free(share);
        free(idx);
        return gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory for %zu samples", n);
    }
    for (size_t k = 0; weight && k < nv; k++)
        weight[idx[k]] = share[k];
    free(share);

    struct fit_sample *scaled = NULL;
    struct brdf_abc warm_scaled;
    if (scale != 1.0) {
        if (!(scaled = malloc(n * sizeof *scaled))) {
            free(idx);
            free(weight);
            return gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory for %zu samples", n);
        }
        for (size_t k = 0; k < nv; k++) {
            scaled[idx[k]] = samples[idx[k]];
            for (int c = 0; c < 3; c++)
                scaled[idx[k]].rgb[c] /= scale;
        }
        samples = scaled;
        if (opt.warm_start) {
            warm_scaled = *opt.warm_start;
            for (int c = 0; c < 3; c++) {
                warm_scaled.kd[c] /= scale;
                warm_scaled.A[c] /= scale;
            }
            opt.warm_start = &warm_scaled;
        }
    }

    /* Large inputs: the starts are searched and solved on a seeded subset. */
    if (nv > ABC_LOCAL_MAX) {
        gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
        if (!rng) {
            free(idx);
            free(weight);
            free(scaled);
            return gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory");
        }
        gsl_rng_set(rng, opt.seed);
        gsl_ran_shuffle(rng, idx, nv, sizeof *idx);
        gsl_rng_free(rng);
    }
    size_t n_local = nv > ABC_LOCAL_MAX ? ABC_LOCAL_MAX : nv;
    size_t n_grid = nv > ABC_LOCAL_MAX ? ABC_GRID_MAX : nv;

    struct abc_problem full = {0}, local = {0}, grid = {0};
    int rc = 0;
    double starts[(ABC_MAX_STARTS + 1 + ABC_PRIOR_SHAPE_STARTS) * ABC_NPAR];
    int nstarts = 0;
    struct solve_result best = {.cost = INFINITY, .reason = "no start"};
    int ran = 0;

    if (abc_problem_init(&local, samples, idx, n_local) < 0 ||
        abc_problem_set_loss(&local, opt.loss) < 0 ||
        abc_problem_set_lower(&local, opt.lower_bound, idx) < 0 ||
        abc_problem_set_weights(&local, weight, idx) < 0) {
        rc = gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory for %zu samples", n_local);
        goto done;
    }
    local.prior = prior;
    if (opt.warm_start) {
        abc_params_to_theta(opt.warm_start, starts);
        nstarts = 1;
    } else {
        const struct abc_problem *gp = &local;
        /* The start search scores exact values: lower bounds (clipped
         * peaks) would point it at a lobe as low as the clip. It runs on
         * the other samples when at least 3 are left. */
        size_t ng = n_grid, *gidx = opt.lower_bound ? malloc(n_grid * sizeof *gidx) : NULL;
        if (gidx) { /* (without memory: all samples) */
            ng = 0;
            for (size_t k = 0; k < n_grid; k++)
                if (!opt.lower_bound[idx[k]])
                    gidx[ng++] = idx[k];
            if (ng < 3)
                ng = n_grid;
        }
        if (ng < n_local) {
            const size_t *gi = ng < n_grid ? gidx : idx;
            int ok = abc_problem_init(&grid, samples, gi, ng) == 0 &&
                     abc_problem_set_weights(&grid, weight, gi) == 0;
            free(gidx);
            if (!ok) {
                rc = gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory");
                goto done;
            }
            gp = &grid;
        } else {
            free(gidx);
        }
        nstarts = opt.global == FIT_GLOBAL_DE ? abc_de_starts(gp, opt.seed, opt.n_starts, starts)
                                              : abc_grid_starts(gp, opt.n_starts, starts);
        /* With a prior its mean is one more start: the population's typical
         * material, a basin the few samples alone may not point to. */
        if (prior && nstarts >= 0) {
            memcpy(starts + (size_t)nstarts * ABC_NPAR, prior->mean, sizeof prior->mean);
            nstarts++;
            nstarts += shape_starts(gp, prior, starts + (size_t)nstarts * ABC_NPAR);
        }
        if (nstarts <= 0) {
            rc = gonio_err_set(err, GONIO_EFIT, "fit_abc: start search found no finite start "
                                                "among %zu samples", n_grid);
            goto done;
        }
    }

    double start_ftol = nstarts > 1 ? ABC_COARSE_FTOL : ABC_POLISH_FTOL;
    for (int s = 0; s < nstarts; s++) {
        struct solve_result r;
        if (local_solve(&local, starts + (size_t)s * ABC_NPAR, &opt, start_ftol, NULL, &r) < 0)
            continue;
        ran++;
        if (r.cost < best.cost)
            best = r;
    }
    if (n_local == nv && start_ftol > ABC_POLISH_FTOL && isfinite(best.cost)) {
        struct solve_result r;
        /* the winner's solve resumed (its scaling and trust region) to the
         * finer tolerance: restarted, MINPACK's scaling by the column norms at
         * the winner lets a parameter at its clamp (kd -> 0, a column near 0)
         * take steps the clamp then ignores, and no step is accepted */
        if (local_solve(&local, best.theta, &opt, ABC_POLISH_FTOL, &best, &r) == 0 &&
            r.cost <= best.cost) {
            r.iterations += best.iterations;
            best = r;
        }
    }
    if (n_local < nv && isfinite(best.cost)) {
        if (abc_problem_init(&full, samples, idx, nv) < 0 ||
            abc_problem_set_loss(&full, opt.loss) < 0 ||
            abc_problem_set_lower(&full, opt.lower_bound, idx) < 0 ||
            abc_problem_set_weights(&full, weight, idx) < 0) {
            rc = gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory for %zu samples", nv);
            goto done;
        }
        full.prior = prior;
        struct solve_result r;
        if (local_solve(&full, best.theta, &opt, ABC_POLISH_FTOL, NULL, &r) == 0) {
            r.iterations += best.iterations;
            best = r;
        } else {
            best.cost = abc_problem_cost(&full, best.theta);
        }
    }
    if (!isfinite(best.cost)) {
        rc = gonio_err_set(err, GONIO_EFIT, "fit_abc: no local solve ended with a finite cost "
                                            "(%d starts on %zu samples)",
                           nstarts, nv);
        goto done;
    }
    abc_theta_to_params(best.theta, out);
    for (int c = 0; c < 3; c++) {
        out->kd[c] *= scale;
        out->A[c] *= scale;
    }
    if (info) {
        info->starts = ran + (n_local < nv ? 1 : 0);
        info->iterations = best.iterations;
        info->cost = best.cost;
        info->converged = best.converged;
        info->reason = best.reason;
        info->dropped = n - nv;
        const struct abc_problem *fp = full.n ? &full : &local;
        /* Residual variance from the fit's own residuals; for a prior fit at
         * least the prior's noise level (the MAP problem's posterior). */
        double s2 = residual_variance(fp, best.cost);
        if (prior) /* the prior's noise level, or the misfit when it is larger */
            s2 = isfinite(s2) && s2 > prior_sigma * prior_sigma ? s2 : prior_sigma * prior_sigma;
        /* the root of J^T J at the optimum, for the covariance and the
         * status's rank (which leaves the prior's rows out) */
        double K[(15 + ABC_NPAR) * ABC_NPAR], cn[ABC_NPAR];
        size_t nk = abc_jacobian_root(fp, best.theta, K, cn);
        uncertainty(fp, best.theta, s2, K, nk, cn, &info->sd);
        info->scale = scale;
        info->domain_weights = weight != NULL;
        struct fit_status *st = &info->status;
        *st = fit_status_init();
        st->geometries = fit_status_geometries(samples, idx, nv);
        abc_status_figures(best.theta, K, nk && prior ? nk - ABC_NPAR : nk, st);
        st->insample = rms_log(fp, best.theta);
        st->heldout = opt.heldout ? heldout_rms(&local, idx, &opt, weight, best.theta) : NAN;
        if (!best.converged)
            st->findings |= 1u << FIT_STATUS_NOT_CONVERGED;
        if (peak_unbounded(samples, idx, nv, opt.lower_bound, out))
            st->findings |= 1u << FIT_STATUS_PEAK_UNBOUNDED;
        fit_status_decide(st);
    }

done:
    abc_problem_free(&full);
    abc_problem_free(&local);
    abc_problem_free(&grid);
    free(idx);
    free(scaled);
    free(weight);
    return rc;
}

int abc_fit_run(const struct fit_sample *samples, size_t n, const struct fit_options *opt,
                const struct abc_prior_term *prior, double prior_sigma, struct brdf_abc *out,
                struct fit_info *info, struct gonio_err *err)
{
    struct fit_options o = opt ? *opt : fit_default_options();
    struct fit_sample *sorted;
    unsigned char *lower;
    if (fit_samples_canonical(samples, o.lower_bound, n, &sorted, &lower) < 0)
        return gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory for %zu samples", n);
    o.lower_bound = lower;
    int rc = fit_sorted(sorted, n, o, prior, prior_sigma, out, info, err);
    free(sorted);
    free(lower);
    return rc;
}
