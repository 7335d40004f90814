/* fit_abc: validation of the samples, start search, the local solves from
 * the starts (fit/abc_solve.c), and what the fit can tell of itself: its
 * uncertainties (fit/abc_covariance.c) and status. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>

#include "fit/abc_covariance.h"
#include "fit/abc_problem.h"
#include "fit/abc_solve.h"
#include "fit/domain_weights.h"
#include "fit/fit.h"
#include "fit/sample_order.h"

/* Above this many samples the start search and the multi-start solves run
 * on a seeded random subset; only the winner is refined on all samples.
 * The grid scores on a smaller subset still: it only ranks basins. */
#define ABC_LOCAL_MAX 8000
#define ABC_GRID_MAX 4000
#define ABC_MAX_STARTS 32

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
    v.mw = NULL; /* in log units, whatever the values' uncertainties */
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
                          const double *sigma, const double theta[ABC_NPAR])
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
        struct abc_solve_result r;
        if (abc_problem_subset(&tp, pb, train, nt) == 0 &&
            abc_problem_set_loss(&tp, opt->loss) == 0 &&
            abc_problem_set_lower(&tp, opt->lower_bound, train_s) == 0 &&
            abc_problem_set_weights(&tp, weight, train_s) == 0 &&
            abc_problem_set_sigma(&tp, sigma, train_s) == 0 &&
            abc_problem_subset(&hp, pb, test, nh) == 0 &&
            abc_problem_set_lower(&hp, opt->lower_bound, test_s) == 0 &&
            abc_problem_set_weights(&hp, weight, test_s) == 0) {
            tp.prior = pb->prior;
            if (abc_local_solve(&tp, theta, opt, ABC_COARSE_FTOL, NULL, &r) == 0) {
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

/* One fit's state, from the samples it keeps to its best solve. */
struct abc_run {
    struct fit_options opt;
    const struct abc_prior_term *prior;
    double prior_sigma;
    const struct fit_sample *samples; /* the caller's, or divided by scale */
    size_t n;                         /* samples given */
    size_t *idx;                      /* the usable ones, s[idx[k]], k < nv */
    size_t nv, n_local, n_grid;
    double scale;
    double *weight; /* weight[i] for sample i (domain weights), or NULL */
    double *sigma;  /* sigma[3 i + c]: sample i's u divided by the scale (measurement
                       weights), or NULL */
    struct fit_sample *scaled;
    struct brdf_abc warm_scaled;
    struct abc_problem full, local, grid;
    double starts[(ABC_MAX_STARTS + 1 + ABC_PRIOR_SHAPE_STARTS) * ABC_NPAR];
    int nstarts, ran;
    struct abc_solve_result best;
};

static int check_options(struct fit_options *opt, struct gonio_err *err)
{
    if (opt->max_iter <= 0 || opt->n_starts <= 0)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "fit_abc: max_iter %d, n_starts %d: both must be >= 1",
                             opt->max_iter, opt->n_starts);
    if (opt->n_starts > ABC_MAX_STARTS)
        opt->n_starts = ABC_MAX_STARTS;
    if (opt->loss != FIT_LOSS_LOG && opt->loss != FIT_LOSS_RELATIVE &&
        opt->loss != FIT_LOSS_COS_L2)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "fit_abc: loss %d: use FIT_LOSS_LOG, _RELATIVE or _COS_L2",
                             (int)opt->loss);
    if (opt->global != FIT_GLOBAL_GRID && opt->global != FIT_GLOBAL_DE)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "fit_abc: global %d: use FIT_GLOBAL_GRID or FIT_GLOBAL_DE",
                             (int)opt->global);
    return 0;
}

/* The usable samples into r->idx, r->nv, and the data's scale. The scale,
 * from the finite samples above the horizon (any value is finite divided
 * by infinity), is divided out of the data before anything else looks at
 * them: multiplied back into kd and A at the end (fit_data_scale); a warm
 * start moves with it. A prior stays: the data it meets are in 1/sr again. */
static int select_samples(struct abc_run *r, struct gonio_err *err)
{
    const struct fit_sample *s = r->samples;
    if (!(r->idx = malloc((r->n ? r->n : 1) * sizeof *r->idx)))
        return gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory for %zu samples", r->n);
    size_t nv = 0;
    for (size_t i = 0; i < r->n; i++)
        if (sample_usable(&s[i], INFINITY))
            r->idx[nv++] = i;
    r->scale = fit_data_scale(s, r->idx, nv);
    size_t kept = 0;
    for (size_t k = 0; k < nv; k++)
        if (sample_usable(&s[r->idx[k]], r->scale))
            r->idx[kept++] = r->idx[k];
    r->nv = drop_duplicates(s, r->idx, kept);
    if (r->nv < (r->prior ? 1u : 3u))
        return gonio_err_set(err, GONIO_EFIT,
                             "fit_abc: %zu usable samples of %zu (the rest have a NaN/inf value "
                             "or geometry, lie below the horizon, have 1 + f cos <= 0 or repeat "
                             "one); need at least 3 for 9 parameters",
                             r->nv, r->n);
    return 0;
}

/* Sample s's value c's uncertainty without the shared systematic part
 * (relative usys): sqrt(u^2 - (usys f)^2), what scatters from sample to
 * sample; 0 when nothing is left or u is absent. */
static double per_sample_u(const struct fit_sample *s, int c, double usys)
{
    double u = s->u[c], us = usys * s->rgb[c];
    if (!(isfinite(u) && u > 0))
        return 0;
    double v = u * u - us * us;
    return v > 0 ? sqrt(v) : 0;
}

/* The samples' per-sample uncertainties in the data's units into r->sigma
 * when every usable sample has all three: the fit is then weighted by them.
 * A capture's values carry them all or none; a mix (some samples without)
 * is fitted as before, unweighted, and so is a fit with a prior (abc-prior),
 * whose rows are scaled for log residuals. Returns 0, -1 on no memory. */
static int measurement_sigma(struct abc_run *r)
{
    const double *usys = r->opt.u_systematic;
    if (r->prior) /* its rows assume the data residuals' noise level: log units */
        return 0;
    for (size_t k = 0; k < r->nv; k++)
        for (int c = 0; c < 3; c++)
            if (!(per_sample_u(&r->samples[r->idx[k]], c, usys[c]) > 0))
                return 0;
    if (!(r->sigma = malloc(3 * r->n * sizeof *r->sigma)))
        return -1;
    for (size_t k = 0; k < r->nv; k++)
        for (int c = 0; c < 3; c++)
            r->sigma[3 * r->idx[k] + (size_t)c] =
                per_sample_u(&r->samples[r->idx[k]], c, usys[c]) / r->scale;
    return 0;
}

/* The domain weights (when asked for), the data divided by their scale
 * (r->samples then points to the copy), and above ABC_LOCAL_MAX samples
 * the seeded shuffle whose first n_local samples the starts are solved on. */
static int weigh_and_scale(struct abc_run *r, struct gonio_err *err)
{
    size_t n = r->n, nv = r->nv;
    double *share = NULL;
    if (r->opt.domain_weights && nv >= FIT_DOMAIN_WEIGHTS_MIN_SAMPLES &&
        (!(r->weight = malloc(n * sizeof *r->weight)) || !(share = malloc(nv * sizeof *share)) ||
         fit_domain_weights(r->samples, r->idx, nv, share) < 0)) {
        free(share);
        return gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory for %zu samples", n);
    }
    for (size_t k = 0; share && k < nv; k++)
        r->weight[r->idx[k]] = share[k];
    free(share);
    if (r->scale != 1.0) {
        if (!(r->scaled = malloc(n * sizeof *r->scaled)))
            return gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory for %zu samples", n);
        for (size_t k = 0; k < nv; k++) {
            r->scaled[r->idx[k]] = r->samples[r->idx[k]];
            for (int c = 0; c < 3; c++)
                r->scaled[r->idx[k]].rgb[c] /= r->scale;
        }
        r->samples = r->scaled;
        if (r->opt.warm_start) {
            r->warm_scaled = *r->opt.warm_start;
            for (int c = 0; c < 3; c++) {
                r->warm_scaled.kd[c] /= r->scale;
                r->warm_scaled.A[c] /= r->scale;
            }
            r->opt.warm_start = &r->warm_scaled;
        }
    }
    if (measurement_sigma(r) < 0)
        return gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory for %zu samples", n);
    if (nv > ABC_LOCAL_MAX) {
        gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
        if (!rng)
            return gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory");
        gsl_rng_set(rng, r->opt.seed);
        gsl_ran_shuffle(rng, r->idx, nv, sizeof *r->idx);
        gsl_rng_free(rng);
    }
    r->n_local = nv > ABC_LOCAL_MAX ? ABC_LOCAL_MAX : nv;
    r->n_grid = nv > ABC_LOCAL_MAX ? ABC_GRID_MAX : nv;
    return 0;
}

/* pb over the first m samples of idx, with the fit's loss, bounds and weights. */
static int problem_of(const struct abc_run *r, struct abc_problem *pb, size_t m)
{
    if (abc_problem_init(pb, r->samples, r->idx, m) < 0 ||
        abc_problem_set_loss(pb, r->opt.loss) < 0 ||
        abc_problem_set_lower(pb, r->opt.lower_bound, r->idx) < 0 ||
        abc_problem_set_weights(pb, r->weight, r->idx) < 0 ||
        abc_problem_set_sigma(pb, r->sigma, r->idx) < 0)
        return -1;
    pb->prior = r->prior;
    return 0;
}

/* The starts: the warm start, or the grid's (or DE's) best distinct nodes
 * and, with a prior, its mean and best lobe shapes. */
static int find_starts(struct abc_run *r, struct gonio_err *err)
{
    if (r->opt.warm_start) {
        abc_params_to_theta(r->opt.warm_start, r->starts);
        r->nstarts = 1;
        return 0;
    }
    const struct abc_problem *gp = &r->local;
    /* The start search scores exact values: lower bounds (clipped peaks)
     * would point it at a lobe as low as the clip. It runs on the other
     * samples when at least 3 are left. */
    const unsigned char *lower = r->opt.lower_bound;
    size_t ng = r->n_grid, *gidx = lower ? malloc(r->n_grid * sizeof *gidx) : NULL;
    if (gidx) { /* (without memory: all samples) */
        ng = 0;
        for (size_t k = 0; k < r->n_grid; k++)
            if (!lower[r->idx[k]])
                gidx[ng++] = r->idx[k];
        if (ng < 3)
            ng = r->n_grid;
    }
    if (ng < r->n_local) {
        const size_t *gi = ng < r->n_grid ? gidx : r->idx;
        int ok = abc_problem_init(&r->grid, r->samples, gi, ng) == 0 &&
                 abc_problem_set_weights(&r->grid, r->weight, gi) == 0 &&
                 abc_problem_set_sigma(&r->grid, r->sigma, gi) == 0;
        free(gidx);
        if (!ok)
            return gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory");
        gp = &r->grid;
    } else {
        free(gidx);
    }
    int ns = r->opt.global == FIT_GLOBAL_DE
                 ? abc_de_starts(gp, r->opt.seed, r->opt.n_starts, r->starts)
                 : abc_grid_starts(gp, r->opt.n_starts, r->starts);
    /* With a prior its mean is one more start: the population's typical
     * material, a basin the few samples alone may not point to. */
    if (r->prior && ns >= 0) {
        memcpy(r->starts + (size_t)ns * ABC_NPAR, r->prior->mean, sizeof r->prior->mean);
        ns++;
        ns += shape_starts(gp, r->prior, r->starts + (size_t)ns * ABC_NPAR);
    }
    r->nstarts = ns;
    if (ns <= 0)
        return gonio_err_set(err, GONIO_EFIT,
                             "fit_abc: start search found no finite start among %zu samples",
                             r->n_grid);
    return 0;
}

/* A local solve from every start, the best polished, and above
 * ABC_LOCAL_MAX samples refined on all of them: into r->best. */
static int solve_starts(struct abc_run *r, struct gonio_err *err)
{
    struct abc_solve_result *best = &r->best;
    *best = (struct abc_solve_result){.cost = INFINITY, .reason = "no start"};
    double start_ftol = r->nstarts > 1 ? ABC_COARSE_FTOL : ABC_POLISH_FTOL;
    for (int s = 0; s < r->nstarts; s++) {
        struct abc_solve_result res;
        if (abc_local_solve(&r->local, r->starts + (size_t)s * ABC_NPAR, &r->opt, start_ftol,
                            NULL, &res) < 0)
            continue;
        r->ran++;
        if (res.cost < best->cost)
            *best = res;
    }
    if (r->n_local == r->nv && start_ftol > ABC_POLISH_FTOL && isfinite(best->cost)) {
        struct abc_solve_result res;
        /* the winner's solve resumed (its scaling and trust region) to the
         * finer tolerance: restarted, MINPACK's scaling by the column norms at
         * the winner lets a parameter at its clamp (kd -> 0, a column near 0)
         * take steps the clamp then ignores, and no step is accepted */
        if (abc_local_solve(&r->local, best->theta, &r->opt, ABC_POLISH_FTOL, best, &res) == 0 &&
            res.cost <= best->cost) {
            res.iterations += best->iterations;
            *best = res;
        }
    }
    if (r->n_local < r->nv && isfinite(best->cost)) {
        if (problem_of(r, &r->full, r->nv) < 0)
            return gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory for %zu samples",
                                 r->nv);
        struct abc_solve_result res;
        if (abc_local_solve(&r->full, best->theta, &r->opt, ABC_POLISH_FTOL, NULL, &res) == 0) {
            res.iterations += best->iterations;
            *best = res;
        } else {
            best->cost = abc_problem_cost(&r->full, best->theta);
        }
    }
    if (!isfinite(best->cost))
        return gonio_err_set(err, GONIO_EFIT,
                             "fit_abc: no local solve ended with a finite cost (%d starts on "
                             "%zu samples)",
                             r->nstarts, r->nv);
    return 0;
}

/* What the fit can tell of itself (fit/fit.h struct fit_info) at r->best,
 * whose parameters in the caller's units are out. */
static void report(const struct abc_run *r, const struct brdf_abc *out, struct fit_info *info)
{
    const struct abc_solve_result *best = &r->best;
    info->starts = r->ran + (r->n_local < r->nv ? 1 : 0);
    info->iterations = best->iterations;
    info->cost = best->cost;
    info->converged = best->converged;
    info->reason = best->reason;
    info->dropped = r->n - r->nv;
    const struct abc_problem *fp = r->full.n ? &r->full : &r->local;
    /* Residual variance from the fit's own residuals; for a prior fit at
     * least the prior's noise level (the MAP problem's posterior). */
    double s2 = abc_residual_variance(fp, best->cost), ps2 = r->prior_sigma * r->prior_sigma;
    if (r->prior) /* the prior's noise level, or the misfit when it is larger */
        s2 = isfinite(s2) && s2 > ps2 ? s2 : ps2;
    if (r->sigma) /* weights of known variances: absolute */
        s2 = 1.0;
    /* the root of J^T J at the optimum, for the covariance and the
     * status's rank (which leaves the prior's rows out) */
    double K[(15 + ABC_NPAR) * ABC_NPAR], cn[ABC_NPAR];
    size_t nk = abc_jacobian_root(fp, best->theta, K, cn);
    abc_uncertainty(fp, best->theta, s2, r->sigma ? r->opt.u_systematic : NULL, K, nk, cn,
                    &info->sd);
    info->scale = r->scale;
    info->domain_weights = r->weight != NULL;
    info->measurement_weights = r->sigma != NULL;
    struct fit_status *st = &info->status;
    *st = fit_status_init();
    st->geometries = fit_status_geometries(r->samples, r->idx, r->nv);
    abc_status_figures(best->theta, K, nk && r->prior ? nk - ABC_NPAR : nk, st);
    st->insample = rms_log(fp, best->theta);
    st->heldout = r->opt.heldout ? heldout_rms(&r->local, r->idx, &r->opt, r->weight, r->sigma,
                                               best->theta)
                                 : NAN;
    if (!best->converged)
        st->findings |= 1u << FIT_STATUS_NOT_CONVERGED;
    if (peak_unbounded(r->samples, r->idx, r->nv, r->opt.lower_bound, out))
        st->findings |= 1u << FIT_STATUS_PEAK_UNBOUNDED;
    fit_status_decide(st);
}

/* abc_fit_run on samples in canonical order (fit/sample_order.h). */
static int fit_abc_canonical(const struct fit_sample *samples, size_t n, struct fit_options opt,
                             const struct abc_prior_term *prior, double prior_sigma,
                             struct brdf_abc *out, struct fit_info *info, struct gonio_err *err)
{
    int rc = check_options(&opt, err);
    if (rc < 0)
        return rc;
    /* Once per process, not per call: the handler is global state. */
    if (!gsl_handler_off_done) {
        gsl_set_error_handler_off();
        gsl_handler_off_done = 1;
    }
    struct abc_run *r = calloc(1, sizeof *r);
    if (!r)
        return gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory");
    r->opt = opt;
    r->prior = prior;
    r->prior_sigma = prior_sigma;
    r->samples = samples;
    r->n = n;
    rc = select_samples(r, err);
    if (rc == 0)
        rc = weigh_and_scale(r, err);
    if (rc == 0 && problem_of(r, &r->local, r->n_local) < 0)
        rc = gonio_err_set(err, GONIO_EFIT, "fit_abc: out of memory for %zu samples",
                           r->n_local);
    if (rc == 0)
        rc = find_starts(r, err);
    if (rc == 0)
        rc = solve_starts(r, err);
    if (rc == 0) {
        abc_theta_to_params(r->best.theta, out);
        for (int c = 0; c < 3; c++) {
            out->kd[c] *= r->scale;
            out->A[c] *= r->scale;
        }
        if (info)
            report(r, out, info);
    }
    abc_problem_free(&r->full);
    abc_problem_free(&r->local);
    abc_problem_free(&r->grid);
    free(r->idx);
    free(r->scaled);
    free(r->weight);
    free(r->sigma);
    free(r);
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
    int rc = fit_abc_canonical(sorted, n, o, prior, prior_sigma, out, info, err);
    free(sorted);
    free(lower);
    return rc;
}
