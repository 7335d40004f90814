/* fit_abc: validation, start search, local trust-region solves with GSL. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_blas.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_linalg.h>
#include <gsl/gsl_math.h>
#include <gsl/gsl_multifit_nlinear.h>
#include <gsl/gsl_multilarge_nlinear.h>
#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>

#include "fit/abc_problem.h"
#include "fit/fit.h"

/* Above this many samples the start search and the multi-start solves run
 * on a seeded random subset; only the winner is refined on all samples.
 * The grid scores on a smaller subset still: it only ranks basins. */
#define ABC_LOCAL_MAX 8000
#define ABC_GRID_MAX 4000
#define ABC_MAX_STARTS 32

/* Cost-stall test: iterations over which the relative decrease is taken. */
#define ABC_STALL_WINDOW 8
/* Consecutive iterations without a reducing step before giving up. */
#define ABC_NOPROG_MAX 3
/* Small-decrease test (as MINPACK's ftol, the one SciPy's least_squares
 * applies, both the actual and the predicted decrease): an iteration whose
 * first trial step was accepted, lowered the cost by at most this much
 * (relative), and after which a full Gauss-Newton step would lower it by at
 * most this much again, ends the solve. The starts are solved to
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
    };
    return o;
}

/* What the GSL callbacks see: the problem and the fused path's cache. */
struct solve_ctx {
    const struct abc_problem *pb;
    struct abc_cache cache;
    long nf; /* residual evaluations so far */
};

/* GSL sees the residual vector as its norm followed by zeros (GSL wants
 * n >= p rows). The trust region
 * of gsl_multilarge_nlinear with trs_lm uses the residuals only through
 * ||f||, J^T f and J^T J, and the last two come from gsl_df below, which
 * takes the full residuals from the cache: the same iteration, without
 * GSL's three passes (dnrm2, copies) over the 3n residuals per trial step,
 * a sixth of a DS1 fit's time. */
#define ABC_GSL_NRES ABC_NPAR

static int gsl_f(const gsl_vector *x, void *params, gsl_vector *f)
{
    struct solve_ctx *ctx = params;
    if (x->stride != 1 || f->size != ABC_GSL_NRES)
        return GSL_EBADLEN;
    f->data[0] = sqrt(2.0 * abc_problem_resid(ctx->pb, x->data, NULL, &ctx->cache));
    for (size_t i = 1; i < ABC_GSL_NRES; i++)
        f->data[i] = 0.0;
    ctx->nf++;
    return GSL_SUCCESS;
}

/* multilarge's Jacobian callback: J^T f and J^T J at x, never J itself.
 * Only the gradient (u = f) is asked for by trs_lm. */
static int gsl_df(CBLAS_TRANSPOSE_t trans, const gsl_vector *x, const gsl_vector *u,
                  void *params, gsl_vector *v, gsl_matrix *JTJ)
{
    struct solve_ctx *ctx = params;
    if (x->stride != 1 || (v && (trans != CblasTrans || v->stride != 1)) ||
        (u && u->size != ABC_GSL_NRES) || (JTJ && JTJ->tda != ABC_NPAR))
        return GSL_EBADLEN;
    abc_problem_normal(ctx->pb, x->data, 1, NULL, v ? v->data : NULL, JTJ ? JTJ->data : NULL,
                       &ctx->cache);
    return GSL_SUCCESS;
}

struct solve_result {
    double theta[ABC_NPAR];
    double cost;
    int iterations;
    int converged;
    const char *reason;
};

/* The decrease a full Gauss-Newton step predicts from here, g^T (J^T J)^-1
 * g / 2 (with a 1e-12 relative ridge); INFINITY when J^T J cannot be
 * factored. */
static double gn_decrement(const gsl_multilarge_nlinear_workspace *w)
{
    double a[ABC_NPAR * ABC_NPAR], d[ABC_NPAR];
    for (size_t i = 0; i < ABC_NPAR; i++)
        for (size_t j = 0; j < ABC_NPAR; j++)
            a[i * ABC_NPAR + j] = gsl_matrix_get(w->JTJ, i, j);
    for (size_t i = 0; i < ABC_NPAR; i++)
        a[i * ABC_NPAR + i] *= 1.0 + 1e-12;
    gsl_matrix_view av = gsl_matrix_view_array(a, ABC_NPAR, ABC_NPAR);
    gsl_vector_view dv = gsl_vector_view_array(d, ABC_NPAR);
    if (gsl_linalg_cholesky_decomp1(&av.matrix) != GSL_SUCCESS ||
        gsl_linalg_cholesky_solve(&av.matrix, w->g, &dv.vector) != GSL_SUCCESS)
        return INFINITY;
    double dec = 0;
    for (size_t i = 0; i < ABC_NPAR; i++)
        dec += gsl_vector_get(w->g, i) * d[i];
    return isfinite(dec) ? 0.5 * dec : INFINITY;
}

static double half_sumsq(const gsl_vector *f)
{
    double s = 0;
    for (size_t i = 0; i < f->size; i++)
        s += f->data[i] * f->data[i];
    return 0.5 * s;
}

/* One trust-region Levenberg-Marquardt solve from theta0. */
static int local_solve(const struct abc_problem *pb, const double theta0[ABC_NPAR],
                       const struct fit_options *opt, double step_ftol, struct solve_result *res)
{
    /* gsl_multilarge_nlinear: the same trust-region LM (Moré scaling) as
     * gsl_multifit_nlinear, but fed J^T J and J^T f by the callback instead
     * of the 3n x 9 Jacobian. The model's Jacobian is sparse (5 non-zeros
     * per row) and shares its terms with the residuals, so J^T J costs a
     * pass of multiply-adds; multifit formed it with a dense dsyrk and J*dx
     * with a dgemv every iteration, most of a DS1 solve's time. The normal
     * equations are solved with GSL's modified Cholesky, which still factors
     * the singular J^T J of a degenerate fit (A -> 0 leaves B, C and eta
     * without influence; tests/unit/fit/test_hard_cases.c). */
    gsl_multilarge_nlinear_parameters fp = gsl_multilarge_nlinear_default_parameters();
    fp.trs = gsl_multilarge_nlinear_trs_lm;
    fp.scale = gsl_multilarge_nlinear_scale_more;
    fp.solver = gsl_multilarge_nlinear_solver_mcholesky;
    struct solve_ctx ctx = {.pb = pb};
    if (abc_cache_init(&ctx.cache, pb) < 0)
        return -1;
    gsl_multilarge_nlinear_workspace *w =
        gsl_multilarge_nlinear_alloc(gsl_multilarge_nlinear_trust, &fp, ABC_GSL_NRES, ABC_NPAR);
    if (!w) {
        abc_cache_free(&ctx.cache);
        return -1;
    }
    gsl_multilarge_nlinear_fdf fdf = {
        .f = gsl_f, .df = gsl_df, .fvv = NULL, .n = ABC_GSL_NRES, .p = ABC_NPAR, .params = &ctx,
    };
    double x0[ABC_NPAR];
    memcpy(x0, theta0, sizeof x0);
    gsl_vector_view xv = gsl_vector_view_array(x0, ABC_NPAR);
    int status = gsl_multilarge_nlinear_init(&xv.vector, &fdf, w);
    int info = 0, iter = 0, noprog = 0;
    double prev = half_sumsq(gsl_multilarge_nlinear_residual(w));
    long nf_prev = ctx.nf;
    const char *reason = "solver error";
    double hist[ABC_STALL_WINDOW];
    for (int i = 0; i < ABC_STALL_WINDOW; i++)
        hist[i] = INFINITY;
    res->converged = 0;
    /* Along the flat valleys of this model (eta large, or C large at fixed
     * B C) GSL's step (xtol) and gradient (gtol) tests are met only after
     * hundreds of crawling steps that change nothing (gold-metallic-paint
     * ran into the 200-iteration limit on every start). So iterate here and
     * also stop when the cost fell by less than ftol (relative) over the
     * last ABC_STALL_WINDOW steps. */
    while (status == GSL_SUCCESS) {
        if (iter >= opt->max_iter) {
            reason = "iteration limit reached";
            break;
        }
        status = gsl_multilarge_nlinear_iterate(w);
        if (status == GSL_ENOPROG) {
            /* As GSL's driver: no reducing step on the first iteration ends
             * the solve; later, the solver has reset its damping, so try
             * again, but a repeated refusal means no trust region, however
             * small, lowers the cost: a minimum to working precision. */
            if (iter == 0 || ++noprog >= ABC_NOPROG_MAX) {
                res->converged = iter > 0;
                reason = "no reducing step found (at a minimum to working precision)";
                break;
            }
            status = GSL_SUCCESS;
            iter++;
            continue;
        }
        noprog = 0;
        if (status != GSL_SUCCESS)
            break;
        double cost = half_sumsq(gsl_multilarge_nlinear_residual(w));
        int first_trial = ctx.nf - nf_prev == 1;
        nf_prev = ctx.nf;
        if (gsl_multilarge_nlinear_test(opt->xtol, opt->gtol, opt->ftol, &info, w) ==
            GSL_SUCCESS) {
            res->converged = 1;
            reason = info == 1 ? "small step (xtol)" : "small gradient (gtol)";
            iter++;
            break;
        }
        /* One LM step that hardly lowered the cost, and none left to take:
         * at the minimum (the iterations converge linearly here, by a
         * factor ~30 per step, so xtol 1e-8 alone would take five more that
         * change nothing). A step cut short by the trust region after
         * rejected trials says nothing and is not taken as convergence. */
        if (first_trial && prev - cost <= step_ftol * cost &&
            gn_decrement(w) <= step_ftol * cost) {
            res->converged = 1;
            reason = "small decrease (ftol of one step)";
            iter++;
            break;
        }
        prev = cost;
        if (iter >= ABC_STALL_WINDOW &&
            hist[iter % ABC_STALL_WINDOW] - cost <= opt->ftol * cost) {
            res->converged = 1;
            reason = "cost stalled (ftol over the last iterations)";
            iter++;
            break;
        }
        hist[iter % ABC_STALL_WINDOW] = cost;
        iter++;
    }
    const gsl_vector *x = gsl_multilarge_nlinear_position(w);
    for (int i = 0; i < ABC_NPAR; i++)
        res->theta[i] = gsl_vector_get(x, (size_t)i);
    res->iterations = iter;
    res->reason = reason;
    res->cost = half_sumsq(gsl_multilarge_nlinear_residual(w));
    gsl_multilarge_nlinear_free(w);
    abc_cache_free(&ctx.cache);
    if (!isfinite(res->cost))
        return -1;
    return 0;
}

static int sample_usable(const struct fit_sample *s)
{
    const struct brdf_pair *g = &s->g;
    for (int k = 0; k < 3; k++)
        if (!isfinite(g->wi[k]) || !isfinite(g->wo[k]))
            return 0;
    if (!(g->wi[2] > 0) || !(g->wo[2] > 0))
        return 0;
    for (int c = 0; c < 3; c++)
        if (!isfinite(s->rgb[c]) || !(1.0 + s->rgb[c] * g->wi[2] > 0))
            return 0;
    return 1;
}

/* Mean over an in-plane grid (theta_i 0..80 step 10, theta_r -80..80 step
 * 4, blind zone 5 degrees) and the channels of the standard deviation of
 * the predicted log(1 + f cos theta_i): g^T cov g with g its gradient in
 * theta. Parameters GSL found undetermined have zero covariance and add
 * nothing: they do not move the prediction. */
static double predictive_sd(const double th[ABC_NPAR], double c[ABC_NPAR][ABC_NPAR])
{
    struct fit_sample s[17 * 9];
    size_t n = 0;
    for (int i = 0; i <= 8; i++)
        for (int r = -20; r <= 20; r++) {
            double ti = 10.0 * i, tr = 4.0 * r;
            if (fabs(ti + tr) < 5 || n >= sizeof s / sizeof s[0])
                continue;
            brdf_pair_inplane(ti, tr, &s[n].g);
            s[n].rgb[0] = s[n].rgb[1] = s[n].rgb[2] = 0;
            n++;
        }
    struct abc_problem pb;
    double *J = malloc(3 * n * ABC_NPAR * sizeof *J);
    if (!J || abc_problem_init(&pb, s, NULL, n) < 0) {
        free(J);
        return NAN;
    }
    abc_problem_eval(&pb, th, NULL, J);
    double sum = 0;
    for (size_t row = 0; row < 3 * n; row++) {
        const double *g = J + row * ABC_NPAR;
        double v = 0;
        for (int a = 0; a < ABC_NPAR; a++)
            for (int b = 0; b < ABC_NPAR; b++)
                v += g[a] * c[a][b] * g[b];
        sum += sqrt(fmax(v, 0.0));
    }
    abc_problem_free(&pb);
    free(J);
    return sum / (double)(3 * n);
}

/* A square root of J^T J at theta: rows K (nk x 9, row-major) with
 * K^T K = J^T J, and cn[j] > 0 exactly when J's column j is not zero. The
 * data rows of channel c have non-zeros only in columns c, 3 + c, 6, 7, 8
 * (an n x 5 block J_c, abc_problem_jblock), so K stacks the R of each
 * block's QR (J^T J = sum_c R_c^T R_c; below 5 samples the block itself)
 * and the prior rows. QR is backward stable, so the pivoted QR of K
 * decides the rank as J's own would, for a fraction of the work (J's
 * 3n x 9 pivoted QR and its scalar evaluation were a tenth of a DS1 fit).
 * Returns nk (>= 9), 0 on no memory. */
static size_t jacobian_root(const struct abc_problem *pb, const double th[ABC_NPAR], double *K,
                            double cn[ABC_NPAR])
{
    static const int col[5] = {0, 3, 6, 7, 8}; /* + c for the first two */
    size_t n = pb->n, rows = n >= 5 ? 5 : n, nk = 0;
    struct abc_cache c;
    gsl_matrix *Jc = gsl_matrix_alloc(n, 5);
    gsl_vector *tau = gsl_vector_alloc(5);
    int ok = Jc && tau && abc_cache_init(&c, pb) == 0;
    if (ok) {
        abc_problem_resid(pb, th, NULL, &c);
        for (int j = 0; j < ABC_NPAR; j++)
            cn[j] = 0.0;
        for (int ch = 0; ch < 3 && ok; ch++) {
            abc_problem_jblock(pb, th, &c, ch, Jc->data);
            for (size_t j = 0; j < 5; j++) {
                gsl_vector_view cv = gsl_matrix_column(Jc, j);
                int at = col[j] + (j < 2 ? ch : 0);
                cn[at] = fmax(cn[at], gsl_blas_dnrm2(&cv.vector));
            }
            if (n >= 5 && gsl_linalg_QR_decomp(Jc, tau) != GSL_SUCCESS) {
                ok = 0;
                break;
            }
            for (size_t i = 0; i < rows; i++, nk++) {
                double *out = K + nk * ABC_NPAR;
                for (int j = 0; j < ABC_NPAR; j++)
                    out[j] = 0.0;
                for (size_t j = n >= 5 ? i : 0; j < 5; j++) /* R: the upper triangle */
                    out[col[j] + (j < 2 ? ch : 0)] = gsl_matrix_get(Jc, i, j);
            }
        }
        abc_cache_free(&c);
    }
    if (ok && pb->prior) /* the prior rows: W */
        for (int i = 0; i < ABC_NPAR; i++, nk++)
            memcpy(K + nk * ABC_NPAR, pb->prior->W + i * ABC_NPAR, ABC_NPAR * sizeof *K);
    gsl_matrix_free(Jc);
    gsl_vector_free(tau);
    return ok ? nk : 0;
}

/* Parameter standard deviations at theta: covariance s2 (J^T J)^-1 from
 * GSL, mapped to natural units. A parameter whose column of J is zero
 * (clamped, or without influence) is undetermined: INFINITY. */
static void uncertainty(const struct abc_problem *pb, const double th[ABC_NPAR], double s2,
                        struct fit_uncertainty *u)
{
    double *sd = (double *)u; /* 10 doubles in the order of the struct */
    for (int i = 0; i < 10; i++)
        sd[i] = NAN;
    if (!isfinite(s2))
        return;
    double K[(15 + ABC_NPAR) * ABC_NPAR], cn[ABC_NPAR];
    gsl_matrix *cov = gsl_matrix_alloc(ABC_NPAR, ABC_NPAR);
    size_t nk = cov ? jacobian_root(pb, th, K, cn) : 0;
    if (nk < ABC_NPAR)
        goto done;
    gsl_matrix_view Kv = gsl_matrix_view_array(K, nk, ABC_NPAR);
    if (gsl_multifit_nlinear_covar(&Kv.matrix, 1e-12, cov) != GSL_SUCCESS)
        goto done;
    /* GSL zeroes the rows and columns of the parameters it found dependent */
    double c[ABC_NPAR][ABC_NPAR];
    int undet[ABC_NPAR];
    for (int i = 0; i < ABC_NPAR; i++) {
        undet[i] = !(cn[i] > 0) || !(gsl_matrix_get(cov, (size_t)i, (size_t)i) > 0);
        for (int j = 0; j < ABC_NPAR; j++)
            c[i][j] = s2 * gsl_matrix_get(cov, (size_t)i, (size_t)j);
    }
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

static int gsl_handler_off_done;

int fit_abc(const struct fit_sample *samples, size_t n, const struct fit_options *opt,
            struct brdf_abc *out, struct fit_info *info, struct gonio_err *err)
{
    return abc_fit_run(samples, n, opt, NULL, 0.0, out, info, err);
}

int abc_fit_run(const struct fit_sample *samples, size_t n, const struct fit_options *opt_in,
                const struct abc_prior_term *prior, double prior_sigma, struct brdf_abc *out,
                struct fit_info *info, struct gonio_err *err)
{
    struct fit_options opt = opt_in ? *opt_in : fit_default_options();
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
    size_t nv = 0;
    for (size_t i = 0; i < n; i++)
        if (sample_usable(&samples[i]))
            idx[nv++] = i;
    nv = drop_duplicates(samples, idx, nv);
    if (nv < (prior ? 1u : 3u)) {
        free(idx);
        return gonio_err_set(err, GONIO_EFIT,
                             "fit_abc: %zu usable samples of %zu (the rest have a NaN/inf value or "
                             "geometry, lie below the horizon, have 1 + f cos <= 0 or repeat one); need at "
                             "least 3 for 9 parameters",
                             nv, n);
    }

    /* Large inputs: the starts are searched and solved on a seeded subset. */
    if (nv > ABC_LOCAL_MAX) {
        gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
        if (!rng) {
            free(idx);
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
        abc_problem_set_loss(&local, opt.loss) < 0) {
        rc = gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory for %zu samples", n_local);
        goto done;
    }
    local.prior = prior;
    if (opt.warm_start) {
        abc_params_to_theta(opt.warm_start, starts);
        nstarts = 1;
    } else {
        const struct abc_problem *gp = &local;
        if (n_grid < n_local) {
            if (abc_problem_init(&grid, samples, idx, n_grid) < 0) {
                rc = gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory");
                goto done;
            }
            gp = &grid;
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
        if (local_solve(&local, starts + (size_t)s * ABC_NPAR, &opt, start_ftol, &r) < 0)
            continue;
        ran++;
        if (r.cost < best.cost)
            best = r;
    }
    if (n_local == nv && start_ftol > ABC_POLISH_FTOL && isfinite(best.cost)) {
        struct solve_result r;
        if (local_solve(&local, best.theta, &opt, ABC_POLISH_FTOL, &r) == 0 && r.cost <= best.cost) {
            r.iterations += best.iterations;
            best = r;
        }
    }
    if (n_local < nv && isfinite(best.cost)) {
        if (abc_problem_init(&full, samples, idx, nv) < 0 ||
            abc_problem_set_loss(&full, opt.loss) < 0) {
            rc = gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory for %zu samples", nv);
            goto done;
        }
        full.prior = prior;
        struct solve_result r;
        if (local_solve(&full, best.theta, &opt, ABC_POLISH_FTOL, &r) == 0) {
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
    if (info) {
        info->starts = ran + (n_local < nv ? 1 : 0);
        info->iterations = best.iterations;
        info->cost = best.cost;
        info->converged = best.converged;
        info->reason = best.reason;
        info->dropped = n - nv;
        const struct abc_problem *fp = full.n ? &full : &local;
        size_t m = 3 * fp->n;
        /* Residual variance from the fit's own residuals; for a prior fit at
         * least the prior's noise level (the MAP problem's posterior). */
        double s2 = m > ABC_NPAR ? 2.0 * best.cost / (double)(m - ABC_NPAR) : NAN;
        if (prior) /* the prior's noise level, or the misfit when it is larger */
            s2 = isfinite(s2) && s2 > prior_sigma * prior_sigma ? s2 : prior_sigma * prior_sigma;
        uncertainty(fp, best.theta, s2, &info->sd);
    }

done:
    abc_problem_free(&full);
    abc_problem_free(&local);
    abc_problem_free(&grid);
    free(idx);
    return rc;
}
