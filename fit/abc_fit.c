/* fit_abc: validation, start search, local trust-region solves with GSL. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_blas.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_math.h>
#include <gsl/gsl_multifit_nlinear.h>
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
#define ABC_QR_MAX 5000

/* Cost-stall test: iterations over which the relative decrease is taken. */
#define ABC_STALL_WINDOW 8
/* Consecutive iterations without a reducing step before giving up. */
#define ABC_NOPROG_MAX 3

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
    };
    return o;
}

static int gsl_f(const gsl_vector *x, void *params, gsl_vector *f)
{
    const struct abc_problem *pb = params;
    if (x->stride != 1 || f->stride != 1)
        return GSL_EBADLEN;
    abc_problem_eval(pb, x->data, f->data, NULL);
    return GSL_SUCCESS;
}

static int gsl_df(const gsl_vector *x, void *params, gsl_matrix *J)
{
    const struct abc_problem *pb = params;
    if (x->stride != 1 || J->tda != ABC_NPAR)
        return GSL_EBADLEN;
    abc_problem_eval(pb, x->data, NULL, J->data);
    return GSL_SUCCESS;
}

struct solve_result {
    double theta[ABC_NPAR];
    double cost;
    int iterations;
    int converged;
    const char *reason;
};

/* One trust-region Levenberg-Marquardt solve from theta0. */
static int local_solve(const struct abc_problem *pb, const double theta0[ABC_NPAR],
                       const struct fit_options *opt, struct solve_result *res)
{
    gsl_multifit_nlinear_parameters fp = gsl_multifit_nlinear_default_parameters();
    fp.trs = gsl_multifit_nlinear_trs_lm;
    fp.scale = gsl_multifit_nlinear_scale_more;
    /* QR copes with the rank-deficient Jacobian of a degenerate fit (A -> 0
     * leaves B, C and eta without influence) where Cholesky would fail. */
    fp.solver = gsl_multifit_nlinear_solver_qr;
    /* On large problems a QR of the 3n x 9 Jacobian per iteration dominates
     * (about 0.3 s at 200k samples); the normal equations cost a fraction.
     * The modified Cholesky still factors a singular J^T J. */
    if (pb->n > ABC_QR_MAX)
        fp.solver = gsl_multifit_nlinear_solver_mcholesky;
    gsl_multifit_nlinear_workspace *w =
        gsl_multifit_nlinear_alloc(gsl_multifit_nlinear_trust, &fp, 3 * pb->n, ABC_NPAR);
    if (!w)
        return -1;
    gsl_multifit_nlinear_fdf fdf = {
        .f = gsl_f, .df = gsl_df, .fvv = NULL, .n = 3 * pb->n, .p = ABC_NPAR,
        .params = (void *)pb,
    };
    double x0[ABC_NPAR];
    memcpy(x0, theta0, sizeof x0);
    gsl_vector_view xv = gsl_vector_view_array(x0, ABC_NPAR);
    int status = gsl_multifit_nlinear_init(&xv.vector, &fdf, w);
    int info = 0, iter = 0, noprog = 0;
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
        status = gsl_multifit_nlinear_iterate(w);
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
        double cost = 0.5 * gsl_pow_2(gsl_blas_dnrm2(gsl_multifit_nlinear_residual(w)));
        if (gsl_multifit_nlinear_test(opt->xtol, opt->gtol, opt->ftol, &info, w) ==
            GSL_SUCCESS) {
            res->converged = 1;
            reason = info == 1 ? "small step (xtol)" : "small gradient (gtol)";
            iter++;
            break;
        }
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
    const gsl_vector *x = gsl_multifit_nlinear_position(w);
    for (int i = 0; i < ABC_NPAR; i++)
        res->theta[i] = gsl_vector_get(x, (size_t)i);
    res->iterations = iter;
    res->reason = reason;
    gsl_multifit_nlinear_free(w);
    res->cost = abc_problem_cost(pb, res->theta);
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

static int gsl_handler_off_done;

int fit_abc(const struct fit_sample *samples, size_t n, const struct fit_options *opt_in,
            struct brdf_abc *out, struct fit_info *info, struct gonio_err *err)
{
    struct fit_options opt = opt_in ? *opt_in : fit_default_options();
    if (opt.max_iter <= 0 || opt.n_starts <= 0)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "fit_abc: max_iter %d, n_starts %d: both must be >= 1",
                             opt.max_iter, opt.n_starts);
    if (opt.n_starts > ABC_MAX_STARTS)
        opt.n_starts = ABC_MAX_STARTS;
    if (opt.loss != FIT_LOSS_LOG)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "fit_abc: loss %d: only FIT_LOSS_LOG is implemented", (int)opt.loss);
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
    if (nv < 3) {
        free(idx);
        return gonio_err_set(err, GONIO_EFIT,
                             "fit_abc: %zu usable samples of %zu (the rest have a NaN/inf value or "
                             "geometry, lie below the horizon or have 1 + f cos <= 0); need at "
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
    double starts[ABC_MAX_STARTS * ABC_NPAR];
    int nstarts = 0;
    struct solve_result best = {.cost = INFINITY, .reason = "no start"};
    int ran = 0;

    if (abc_problem_init(&local, samples, idx, n_local) < 0) {
        rc = gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory for %zu samples", n_local);
        goto done;
    }
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
        nstarts = abc_grid_starts(gp, opt.n_starts, starts);
        if (nstarts <= 0) {
            rc = gonio_err_set(err, GONIO_EFIT, "fit_abc: start search found no finite start "
                                                "among %zu samples", n_grid);
            goto done;
        }
    }

    for (int s = 0; s < nstarts; s++) {
        struct solve_result r;
        if (local_solve(&local, starts + (size_t)s * ABC_NPAR, &opt, &r) < 0)
            continue;
        ran++;
        if (r.cost < best.cost)
            best = r;
    }
    if (n_local < nv && isfinite(best.cost)) {
        if (abc_problem_init(&full, samples, idx, nv) < 0) {
            rc = gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory for %zu samples", nv);
            goto done;
        }
        struct solve_result r;
        if (local_solve(&full, best.theta, &opt, &r) == 0) {
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
    }

done:
    abc_problem_free(&full);
    abc_problem_free(&local);
    abc_problem_free(&grid);
    free(idx);
    return rc;
}
