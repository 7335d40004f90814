/* Adaptive acquisition policy (adaptive/adaptive.h, docs/adaptive.md). */
#include "adaptive/adaptive.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "adaptive/adaptive_private.h"
#include "adaptive/aniso_info.h"
#include "adaptive/ensemble.h"
#include "adaptive/track.h"
#include "brdf/domain.h"
#include "fit/models.h"
#include "planner/meter.h"

/* The first pairs: DS4's six (configs/plans/ds4.yaml), spread over
 * back-scatter, the mirror neighbourhood and the forward lobe at
 * theta_i = 30, each taken as the nearest pool point; listed in DS4's
 * order (its travel order from home: the arm sweeps once from back-scatter
 * to the forward lobe), which next_seed's search finds when DS4's rig time
 * is the budget.
 * Six samples are what the six-pair latent fit already does well with,
 * and they give the ensemble its first fit. */
static const double seed_pairs[][2] = {
    {30, -60}, {30, -20}, {30, 20}, {30, 28}, {30, 36}, {30, 60},
};
#define N_SEEDS (sizeof seed_pairs / sizeof seed_pairs[0])

/* Full-domain nodes over which the ensemble's spread is averaged for the
 * error prediction: a seeded subset, as the study's errors are over the
 * full domain. */
#define PREDICT_NODES 2000

/* docs/adaptive.md, "Stopping": the default gain tolerance (log error
 * per minute), the shortest window the gain is measured over (rig
 * seconds), and the samples before which neither the target nor the
 * convergence stop may fire: below about 80 samples the prediction is
 * too often far below the truth (the ensemble agrees on a wrong optimum). */
#define DEFAULT_GAIN_TOL 0.002
#define GAIN_WINDOW_S 60.0
#define MIN_STOP_SAMPLES 80

/* The noise term of the expected variance reduction, in units of the
 * ensemble's squared cross-validated error; the width of the ALC's
 * repulsion from measured points and the weight of coverage for the
 * latent model, both in units of the spacing n samples would have spread
 * evenly over the domain (docs/notes/adaptive.md, "Tried and dropped"). */
#define ALC_NOISE 0.1
#define REPULSION_WIDTH 0.3
#define COVER_WEIGHT 30.0

/* The latent prediction's calibration: the geometric mean of true over
 * predicted error past 40 samples on the calibration materials (every
 * sixth of the decoder's training set, never a held-out one). */
#define LATENT_PRED_FACTOR 1.13

/* predicted_next: the extrapolated minute of gain takes at most this
 * fraction of the prediction. A straight line through the predictions
 * fitted while they fall fast reaches zero within the minute; the error
 * of a model fitted to more samples never does. */
#define MAX_NEXT_DROP 0.5

/* The budget's margin (docs/adaptive.md, "Holding the budget"): every
 * cost checked against it is multiplied by the largest ratio of a point's
 * rig time to its cost over the latest MARGIN_WINDOW points (long enough
 * to hold the day's pace, short enough that one slow stretch does not
 * cost the rest of the budget), never by less than 1, and by at least
 * MIN_MARGIN for a move longer than any the rig has made (the lab scene's
 * moves took up to 3 % more than the planner's estimate, and a short
 * move's pace does not vouch for a longer one's); the largest excess of a
 * point's rig time over its cost seen in the whole capture is kept in
 * reserve once (a fault's retries or a stall's recovery: seconds, on any
 * point). BUDGET_SLACK_S absorbs the rounding of a sum of costs that
 * meets the budget exactly. */
#define MARGIN_WINDOW 16
#define MIN_MARGIN 1.05
#define BUDGET_SLACK_S 1e-9

struct adaptive {
    const struct plan *pool;
    const struct rig_profile *rig;
    struct adaptive_options opt;
    char model[32];
    size_t n_pool;
    struct brdf_pair *pairs;  /* pool point i's pair */
    /* What the rig did (adaptive_observe): the integration each pool
     * point will take, from the host's expectation and the integration
     * measured nearest (planner/meter.h), the point observed last (-1:
     * none, the axes at home), and the ratios of the latest points' rig
     * times to what the policy costed them at (a ring of MARGIN_WINDOW,
     * n_obs observed in all). */
    plan_meter *meter;
    long last_obs;
    double ratio[MARGIN_WINDOW];
    size_t n_obs;
    double reserve;           /* the largest excess of rig time over cost, s */
    double longest_move;      /* the longest move observed, s (-1: none) */
    long *seed_point;         /* the pool point nearest each seed pair */
    unsigned char *measured;
    struct fit_sample *samples; /* in arrival order */
    size_t n;
    struct ens ens;
    struct ens check;         /* unweighted, for the prior's check while ens is weighted */
    size_t fitted;            /* samples in the ensemble's latest fit */
    struct brdf_domain dom;   /* the prediction's full-domain subset */
    double predicted;
    double spread;            /* the ensemble's mean sd over dom */
    double mapped;            /* held-out residuals mapped onto dom */
    double latent_abc_in_sample; /* the ABC fit's in-sample error when the latent was fitted */
    double dom_cov[ENS_GROUPS][ENS_GROUPS]; /* mean over dom of dev dev^T */
    int latent;               /* model latent or auto: the latent fit is tracked */
    int cover;                /* picks weigh coverage (the latent model's own picks) */
    struct track track;
    double *gap;              /* pool point i's domain distance to the nearest measured point */
    double max_alc;           /* the largest candidate ALC of this decision */
    double *hist_t, *hist_e;  /* (rig time, predicted error) at each refit */
    size_t n_hist;
    /* Model aniso-ggx: its posterior scores the candidates and predicts
     * the error instead of the ABC ensemble (adaptive/aniso_info.h), and
     * the sample's turn (plan_point.rotation) is a dimension of the pool
     * whose moves cost rig time: from_turn is where the sample stands for
     * the cost being taken. */
    int aniso;
    struct aniso_info info;
    double from_turn;
};

struct adaptive_options adaptive_default_options(void)
{
    return (struct adaptive_options){
        .model = "abc", .budget_s = 0, .target = 0, .converge = 0,
        .gain_tol = DEFAULT_GAIN_TOL, .seed = 1,
    };
}

static int check_options(const struct adaptive_options *o, struct gonio_err *err)
{
    if (!o->model)
        return gonio_err_set(err, GONIO_EUSAGE, "adaptive model: none given");
    if (strcmp(o->model, "auto") != 0 && !fit_model_find_rgb(o->model, "adaptive model", err))
        return -GONIO_EUSAGE;
    if (!(o->budget_s >= 0) || !isfinite(o->budget_s))
        return gonio_err_set(err, GONIO_EUSAGE,
                             "adaptive budget %g s: must be a finite number >= 0 (0: none)",
                             o->budget_s);
    if (!(o->target >= 0) || !isfinite(o->target))
        return gonio_err_set(err, GONIO_EUSAGE,
                             "adaptive stop target %g: must be a finite log error >= 0 (0: none)",
                             o->target);
    if (o->converge && (!(o->gain_tol > 0) || !isfinite(o->gain_tol)))
        return gonio_err_set(err, GONIO_EUSAGE,
                             "adaptive gain tolerance %g per minute: must be > 0 to stop on "
                             "convergence", o->gain_tol);
    return 0;
}

/* The pair as the sample sees it: turned by the point's rotation, which
 * an isotropic model's value and the domain distance do not see. */
static void point_pair(const struct plan_point *pt, struct brdf_pair *p)
{
    if (pt->out_of_plane)
        brdf_pair_spherical(pt->theta_i, pt->phi_i, pt->theta_o, pt->phi_o, p);
    else
        brdf_pair_inplane(pt->theta_i, pt->theta_r, p);
    if (pt->rotation != 0)
        brdf_pair_rotate(p, pt->rotation);
}

/* Chordal distance of two pairs: cheap, and as good as the angle for
 * nearest neighbours. */
static double chord(const struct brdf_pair *a, const struct brdf_pair *b)
{
    double s = 0;
    for (int k = 0; k < 3; k++)
        s += (a->wi[k] - b->wi[k]) * (a->wi[k] - b->wi[k]) +
             (a->wo[k] - b->wo[k]) * (a->wo[k] - b->wo[k]);
    return sqrt(s);
}

/* Distance of two pairs in the full domain's own coordinates
 * (brdf_domain_hd_place; the MERL nodes are also uniform in phi_d), so
 * coverage in these units is coverage of the nodes the error is averaged
 * over, whatever the pool's spacing. */
static double dom_dist(const struct brdf_pair *a, const struct brdf_pair *b)
{
    double ua, va, ub, vb;
    brdf_domain_hd_place(a, &ua, &va);
    brdf_domain_hd_place(b, &ub, &vb);
    return sqrt((ua - ub) * (ua - ub) + (va - vb) * (va - vb));
}

adaptive *adaptive_new(const struct plan *pool, const struct rig_profile *rig,
                       const double *integration_s, const struct adaptive_options *opt,
                       struct gonio_err *err)
{
    struct adaptive_options o = opt ? *opt : adaptive_default_options();
    if (check_options(&o, err) < 0)
        return NULL;
    size_t n = pool ? plan_count(pool) : 0;
    if (n == 0) {
        gonio_err_set(err, GONIO_EUSAGE, "adaptive pool %s: no points to choose from",
                      pool ? plan_name(pool) : "(none)");
        return NULL;
    }
    for (size_t i = 0; integration_s && i < n; i++)
        if (!(integration_s[i] >= 0) || !isfinite(integration_s[i])) {
            gonio_err_set(err, GONIO_EUSAGE,
                          "adaptive pool %s: integration of point %zu is %g s, not a finite "
                          "time >= 0", plan_name(pool), i, integration_s[i]);
            return NULL;
        }
    adaptive *a = calloc(1, sizeof *a);
    if (!a) {
        gonio_err_set(err, ENOMEM, "adaptive policy: out of memory");
        return NULL;
    }
    a->pool = pool;
    a->rig = rig;
    a->opt = o;
    snprintf(a->model, sizeof a->model, "%s", o.model);
    a->opt.model = a->model;
    a->n_pool = n;
    a->predicted = NAN;
    a->latent = strcmp(o.model, "latent") == 0 || strcmp(o.model, "auto") == 0;
    a->cover = a->latent;
    a->aniso = strcmp(o.model, "aniso-ggx") == 0;
    aniso_info_init(&a->info);
    ens_init(&a->ens);
    ens_init(&a->check);
    a->pairs = malloc(n * sizeof *a->pairs);
    a->meter = plan_meter_new(pool, rig, integration_s, err);
    a->measured = calloc(n, 1);
    a->samples = malloc(n * sizeof *a->samples);
    a->hist_t = malloc(n * sizeof *a->hist_t);
    a->hist_e = malloc(n * sizeof *a->hist_e);
    a->seed_point = malloc(N_SEEDS * sizeof *a->seed_point);
    a->gap = malloc(n * sizeof *a->gap);
    if (!a->gap || !a->pairs || !a->meter || !a->measured || !a->samples || !a->hist_t ||
        !a->hist_e || !a->seed_point) {
        gonio_err_set(err, ENOMEM, "adaptive policy: out of memory");
        adaptive_free(a);
        return NULL;
    }
    for (size_t i = 0; i < n; i++)
        point_pair(plan_point(pool, i), &a->pairs[i]);
    a->last_obs = -1;
    a->longest_move = -1;
    for (size_t i = 0; i < n; i++)
        a->gap[i] = INFINITY;
    for (size_t k = 0; k < N_SEEDS; k++) {
        struct brdf_pair sp;
        brdf_pair_inplane(seed_pairs[k][0], seed_pairs[k][1], &sp);
        double best = INFINITY;
        a->seed_point[k] = -1;
        for (size_t i = 0; i < n; i++) {
            double d = chord(&sp, &a->pairs[i]);
            if (d < best) {
                best = d;
                a->seed_point[k] = (long)i;
            }
        }
    }
    if (brdf_domain_oop_random(&a->dom, PREDICT_NODES, o.seed, err) < 0 ||
        (a->latent && track_init(&a->track, err) < 0)) {
        adaptive_free(a);
        return NULL;
    }
    if (a->aniso) /* the full-domain error of an anisotropic model: every azimuth */
        brdf_domain_turn(&a->dom);
    return a;
}

void adaptive_free(adaptive *a)
{
    if (!a)
        return;
    free(a->pairs);
    plan_meter_free(a->meter);
    free(a->measured);
    free(a->samples);
    free(a->hist_t);
    free(a->hist_e);
    free(a->seed_point);
    free(a->gap);
    ens_free(&a->ens);
    ens_free(&a->check);
    track_free(&a->track);
    brdf_domain_free(&a->dom);
    free(a);
}

int adaptive_add(adaptive *a, size_t point, const struct fit_sample *s, int saturated,
                 struct gonio_err *err)
{
    (void)saturated; /* the ABC family fits saturated readings clipped (fit/models.h) */
    if (point >= a->n_pool)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "adaptive: sample of point %zu, but the pool %s has %zu points",
                             point, plan_name(a->pool), a->n_pool);
    if (a->measured[point])
        return gonio_err_set(err, GONIO_EUSAGE, "adaptive: point %zu of pool %s given twice",
                             point, plan_name(a->pool));
    a->measured[point] = 1;
    for (size_t i = 0; i < a->n_pool; i++)
        a->gap[i] = fmin(a->gap[i], dom_dist(&a->pairs[i], &a->pairs[point]));
    a->samples[a->n++] = *s;
    return 0;
}

/* The move to point i: the axes' and, on a rig that turns the sample, the
 * turn from a->from_turn, at once (as planner/estimate.c counts it). */
static double move_time(const adaptive *a, const struct rig_axes *from, size_t i)
{
    const struct plan_point *pt = plan_point(a->pool, i);
    double t = rig_move_time_backlash(a->rig, from, &pt->ax);
    if (a->rig->has_rotation && pt->rotation != a->from_turn)
        t = fmax(t, rig_axis_time(pt->rotation - a->from_turn, a->rig->rotation.speed,
                                  a->rig->rotation.accel));
    return t;
}

static double turn_of(const adaptive *a, long point)
{
    return point >= 0 ? plan_point(a->pool, (size_t)point)->rotation : 0;
}

/* Point i's cost once its move to it takes move_s. */
static double cost_after(const adaptive *a, double move_s, size_t i)
{
    return move_s + a->rig->settle_s + plan_meter_integration(a->meter, i);
}

double adaptive_point_cost(const adaptive *a, const struct rig_axes *from, size_t i)
{
    return cost_after(a, move_time(a, from, i), i);
}

int adaptive_observe(adaptive *a, size_t point, double integration_s, double point_rig_s,
                     struct gonio_err *err)
{
    if (point >= a->n_pool)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "adaptive: observed point %zu, but the pool %s has %zu points",
                             point, plan_name(a->pool), a->n_pool);
    if (!(integration_s >= 0) || !isfinite(integration_s) || !(point_rig_s >= 0) ||
        !isfinite(point_rig_s))
        return gonio_err_set(err, GONIO_EUSAGE,
                             "adaptive: point %zu observed with integration %g s in %g s of rig "
                             "time, not finite times >= 0",
                             point, integration_s, point_rig_s);
    /* The cost as a decision would have put it, before this point's own
     * integration is known. */
    static const struct rig_axes home = {0, 0, 0};
    const struct rig_axes *from = a->last_obs >= 0 ? &plan_point(a->pool, (size_t)a->last_obs)->ax
                                                    : &home;
    a->from_turn = turn_of(a, a->last_obs);
    double cost = adaptive_point_cost(a, from, point);
    a->ratio[a->n_obs++ % MARGIN_WINDOW] = cost > 0 ? point_rig_s / cost : 1;
    a->reserve = fmax(a->reserve, point_rig_s - cost);
    a->longest_move = fmax(a->longest_move, move_time(a, from, point));
    plan_meter_observe(a->meter, point, integration_s);
    a->last_obs = (long)point;
    a->from_turn = turn_of(a, a->last_obs);
    return 0;
}

/* What a cost checked against the budget is multiplied by: the largest
 * ratio of rig time to cost over the latest points, at least 1, and at
 * least MIN_MARGIN for a move of move_s longer than any observed. */
static double margin(const adaptive *a, double move_s)
{
    double m = 1;
    for (size_t k = 0; k < a->n_obs && k < MARGIN_WINDOW; k++)
        m = fmax(m, a->ratio[k]);
    return move_s > a->longest_move ? fmax(m, MIN_MARGIN) : m;
}

/* Point i's cost from the axes at from (*cost), and that cost as the
 * budget counts it: times the margin for its move. */
static double budget_cost(const adaptive *a, const struct rig_axes *from, size_t i,
                          double *cost)
{
    double move = move_time(a, from, i);
    *cost = cost_after(a, move, i);
    return margin(a, move) * *cost;
}

/* Point i's cost from the axes at from (*cost), and whether it fits the
 * budget when the rig clock, with what is pending, stands at clock. */
static int affordable(const adaptive *a, const struct rig_axes *from, size_t i, double clock,
                      double *cost)
{
    double counted = budget_cost(a, from, i, cost);
    return !(a->opt.budget_s > 0) || clock + counted <= a->opt.budget_s + BUDGET_SLACK_S;
}

/* The predicted full-domain log error of the model fitted now
 * (docs/adaptive.md, "Predicting the error"). ABC: each node of the
 * full-domain subset takes the held-out residual of the sample nearest it
 * in (theta_h, theta_d), so the samples' errors count by the share of the
 * domain they stand for, not by where the policy chose to look; never
 * below the ensemble's spread over the subset, which is what the samples
 * leave open. Latent: the mapped residual times the ratio of the tracked
 * latent fit's in-sample error to the ABC fit's, calibrated. */
static double predict_error(adaptive *a)
{
    double spread = 0, mapped = 0;
    for (size_t i = 0; i < a->dom.n; i++) {
        const struct brdf_pair *p = &a->dom.pairs[i];
        spread += sqrt(ens_variance(&a->ens, p));
        double best = INFINITY, r = 0;
        for (size_t k = 0; k < a->n; k++) {
            double dh = p->theta_h - a->samples[k].g.theta_h;
            double dd = p->theta_d - a->samples[k].g.theta_d;
            if (dh * dh + dd * dd < best) {
                best = dh * dh + dd * dd;
                r = a->ens.cv_resid[k];
            }
        }
        mapped += r;
    }
    a->spread = spread / (double)a->dom.n;
    a->mapped = mapped / (double)a->dom.n;
    if (!a->latent || (strcmp(a->model, "auto") == 0 && !a->cover))
        return fmax(a->mapped, a->spread);
    if (!(a->track.fitted > 0) || !(a->latent_abc_in_sample > 0))
        return NAN;
    return LATENT_PRED_FACTOR * a->mapped * a->track.in_sample / a->latent_abc_in_sample;
}

void adaptive_evidence(const adaptive *a, struct adaptive_evidence *ev)
{
    int ok = a->ens.ok && isfinite(a->predicted);
    *ev = (struct adaptive_evidence){
        .samples = a->fitted,
        .fit_error = ok ? a->ens.fit_error : NAN,
        .cv_error = ok ? a->ens.cv_error : NAN,
        .spread = ok ? a->spread : NAN,
        .mapped = ok ? a->mapped : NAN,
    };
}

/* Predicted error reduction per minute of rig time: minus the
 * least-squares slope of the predictions against rig time over the
 * latest GAIN_WINDOW_S or third of the rig time, whichever is longer
 * (a shorter window follows the noise of single refits). Negative while
 * the prediction rises: the samples are still finding error the model
 * did not show. NAN with fewer than 8 predictions in the window. */
static double gain_per_min(const adaptive *a)
{
    if (a->n_hist == 0)
        return NAN;
    double t_end = a->hist_t[a->n_hist - 1];
    double window = fmax(GAIN_WINDOW_S, t_end / 3);
    size_t lo = a->n_hist;
    while (lo > 0 && a->hist_t[lo - 1] >= t_end - window)
        lo--;
    size_t m = a->n_hist - lo;
    if (m < 8)
        return NAN;
    double st = 0, se = 0;
    for (size_t k = lo; k < a->n_hist; k++) {
        st += a->hist_t[k];
        se += a->hist_e[k];
    }
    st /= (double)m;
    se /= (double)m;
    double stt = 0, ste = 0;
    for (size_t k = lo; k < a->n_hist; k++) {
        stt += (a->hist_t[k] - st) * (a->hist_t[k] - st);
        ste += (a->hist_t[k] - st) * (a->hist_e[k] - se);
    }
    if (!(stt > 0))
        return NAN;
    return -ste / stt * 60;
}

double adaptive_predicted_next(double predicted, double gain_per_min)
{
    if (!isfinite(predicted) || !(predicted > 0) || !isfinite(gain_per_min) ||
        !(gain_per_min > 0))
        return NAN;
    return predicted - fmin(gain_per_min, MAX_NEXT_DROP * predicted);
}

static void compute_dom_cov(adaptive *a)
{
    memset(a->dom_cov, 0, sizeof a->dom_cov);
    for (size_t i = 0; i < a->dom.n; i++) {
        double d[ENS_GROUPS];
        ens_deviations(&a->ens, &a->dom.pairs[i], d);
        for (int g = 0; g < ENS_GROUPS; g++)
            for (int h = 0; h < ENS_GROUPS; h++)
                a->dom_cov[g][h] += d[g] * d[h];
    }
    for (int g = 0; g < ENS_GROUPS; g++)
        for (int h = 0; h < ENS_GROUPS; h++)
            a->dom_cov[g][h] /= (double)a->dom.n;
}

/* Model aniso-ggx: the posterior's predicted error, the mean over the
 * turned full-domain subset of the expected |error| of v, sd * sqrt(2/pi)
 * (what the parameters leave open; the model is taken as the material's
 * form). */
static double aniso_predict(adaptive *a)
{
    if (a->n < N_SEEDS || aniso_info_update(&a->info, a->samples, a->n) < 0)
        return NAN;
    return aniso_info_domain(&a->info, a->dom.pairs, a->dom.n) *
           0.7978845608028654; /* sqrt(2 / pi) */
}

static void refit(adaptive *a, double rig_time_s)
{
    if (a->fitted == a->n)
        return;
    a->fitted = a->n;
    if (a->aniso) {
        a->predicted = aniso_predict(a);
        if (isfinite(a->predicted)) {
            a->hist_t[a->n_hist] = rig_time_s;
            a->hist_e[a->n_hist++] = a->predicted;
        }
        return;
    }
    /* While the policy follows ABC its picks and prediction come from fits
     * weighted as the capture's final ABC fit (docs/adaptive.md, the
     * policy, step 2); while it follows the latent model the ensemble
     * serves the coverage term and the prior's check, and weighted fits
     * there moved the latent policy's lab errors from 1.08x to 1.24x DS1's
     * in the study. */
    if (a->n < N_SEEDS || ens_fit(&a->ens, a->samples, a->n, !a->cover) < 0) {
        a->predicted = NAN;
        return;
    }
    compute_dom_cov(a);
    if (a->latent && track_update(&a->track, a->samples, a->n, a->opt.seed) == 1) {
        /* The decoder's prior must fit the material before its picks are
         * trusted: a latent fit no better on its own samples than ABC is
         * on samples it did not see follows a material the decoder does
         * not know. Like with like: the ABC figure is
         * always that of unweighted fits, as the latent fit is. Weighted
         * fits (the policy's while it follows ABC) miss the crowded
         * samples more, and the check then swung back and forth. */
        const struct ens *abc = &a->ens;
        if (!a->cover)
            abc = ens_fit(&a->check, a->samples, a->n, 0) == 0 ? &a->check : NULL;
        if (abc) {
            a->latent_abc_in_sample = abc->fit_error; /* the prediction's ratio: alike too */
            a->cover = a->track.in_sample < abc->cv_error;
        }
    }
    a->predicted = predict_error(a);
    if (isfinite(a->predicted)) {
        a->hist_t[a->n_hist] = rig_time_s;
        a->hist_e[a->n_hist++] = a->predicted;
    }
}

/* The expected reduction of the ensemble's variance over the full-domain
 * subset if candidate i were measured (Cohn's ALC): with d_i the members'
 * deviations at i and C the subset's mean of d d^T, sum over nodes of
 * cov(i, x)^2 / (noise + var(i)) = d_i^T C d_i / (noise + |d_i|^2). The
 * noise is the model's own misfit: a model that cannot follow the
 * material there gains less from a sample than its variance says. */
static double alc(const adaptive *a, size_t i)
{
    double d[ENS_GROUPS], v = 0, q = 0;
    ens_deviations(&a->ens, &a->pairs[i], d);
    for (int g = 0; g < ENS_GROUPS; g++) {
        v += d[g] * d[g];
        for (int h = 0; h < ENS_GROUPS; h++)
            q += d[g] * a->dom_cov[g][h] * d[h];
    }
    return q / (ALC_NOISE * a->ens.cv_error * a->ens.cv_error + v + 1e-300);
}

/* What measuring candidate i is worth, before its cost: without an
 * ensemble, the domain distance to the nearest point measured or pending.
 * Then for ABC the ALC, damped near what is measured or pending: the
 * jackknife spread of a misspecified model hardly falls where a neighbour
 * was just measured, and without the damping a fine pool's cheap 1-degree
 * steps pile samples into one region. For the latent model (whose fit the
 * ensemble does not describe) the ALC relative to the best one plus that
 * distance: coverage of the domain. */
static double worth(const adaptive *a, size_t i, long pending)
{
    double gap = a->gap[i];
    if (pending >= 0)
        gap = fmin(gap, dom_dist(&a->pairs[i], &a->pairs[pending]));
    if (a->aniso && a->info.ok)
        return aniso_info_alc(&a->info, &a->pairs[i]);
    if (!a->ens.ok)
        return isfinite(gap) ? gap : 1;
    /* gap in units of the even spacing of n + 1 points over the unit
     * square of dom_dist's coordinates */
    double g = gap * sqrt((double)(a->n + 1));
    if (!a->cover)
        return alc(a, i) * (1 - exp(-(g / REPULSION_WIDTH) * (g / REPULSION_WIDTH)));
    return alc(a, i) / a->max_alc + COVER_WEIGHT * g;
}

/* done[k]: seed k is measured, pending, or the same pool point as an
 * earlier seed (a coarse pool's point nearest two seeds). */
static void seeds_done(const adaptive *a, long pending, unsigned char *done)
{
    for (size_t k = 0; k < N_SEEDS; k++) {
        long p = a->seed_point[k];
        done[k] = a->measured[p] || p == pending;
        for (size_t j = 0; j < k; j++)
            done[k] |= a->seed_point[j] == p;
    }
}

/* The seeds not done, nearest first from the axes at from: *first
 * receives the first of them (-1: none left), and the function returns the
 * rig time of them all. */
static double seed_route(const adaptive *a, const struct rig_axes *from, unsigned char *done,
                         long *first)
{
    struct rig_axes at = *from;
    double total = 0;
    *first = -1;
    for (;;) {
        long next = -1;
        double best = INFINITY;
        for (size_t k = 0; k < N_SEEDS; k++) {
            if (done[k])
                continue;
            /* ties to the lower pool index, as the criterion's scan */
            double c = adaptive_point_cost(a, &at, (size_t)a->seed_point[k]);
            if (c < best || (c == best && a->seed_point[k] < a->seed_point[next])) {
                best = c;
                next = (long)k;
            }
        }
        if (next < 0)
            return total;
        done[next] = 1;
        total += best;
        at = plan_point(a->pool, (size_t)a->seed_point[next])->ax;
        if (*first < 0)
            *first = a->seed_point[next];
    }
}

/* The most seeds not done that a route from the axes at measures within
 * `left` rig seconds (*count), the least time for that many (*time) and
 * that route's first pool point (*first, -1: none fits). Costs as the
 * nearest-first route counts them: the margin is the budget's check of
 * each next point when its turn comes (affordable). Exhaustive: six seeds
 * are 720 routes at most. */
static void seeds_within(const adaptive *a, const struct rig_axes *at, unsigned char *done,
                         double left, int *count, double *time, long *first)
{
    *count = 0;
    *time = 0;
    *first = -1;
    for (size_t k = 0; k < N_SEEDS; k++) {
        if (done[k])
            continue;
        size_t p = (size_t)a->seed_point[k];
        double c = adaptive_point_cost(a, at, p);
        if (c > left)
            continue;
        int n;
        double t;
        long ignored;
        done[k] = 1;
        seeds_within(a, &plan_point(a->pool, p)->ax, done, left - c, &n, &t, &ignored);
        done[k] = 0;
        if (n + 1 > *count || (n + 1 == *count && c + t < *time)) {
            *count = n + 1;
            *time = c + t;
            *first = (long)p;
        }
    }
}

/* The next seed: the nearest (the policy's later picks did best after
 * that start, docs/adaptive.md), unless the budget left is too short for
 * all the seeds on that route: then the first of the route that measures
 * the most of them within it (DS4's own order when DS4's rig time is the
 * budget), the quickest such. -1: none left, or none fits. */
static long next_seed(const adaptive *a, const struct rig_axes *from, long pending,
                      double clock)
{
    unsigned char done[N_SEEDS], route_done[N_SEEDS];
    seeds_done(a, pending, done);
    memcpy(route_done, done, sizeof done);
    long nearest;
    double t_nearest = seed_route(a, from, route_done, &nearest);
    double left = a->opt.budget_s + BUDGET_SLACK_S - clock;
    if (!(a->opt.budget_s > 0) || t_nearest <= left)
        return nearest;
    int count;
    double time;
    long first;
    seeds_within(a, from, done, left, &count, &time, &first);
    return first;
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

long adaptive_next(adaptive *a, const struct rig_axes *at, double rig_time_s, long pending,
                   struct adaptive_status *st, struct gonio_err *err)
{
    double t0 = now_s();
    if (pending >= (long)a->n_pool || pending < -1)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "adaptive: pending point %ld is not in pool %s (%zu points)",
                             pending, plan_name(a->pool), a->n_pool);
    refit(a, rig_time_s);
    /* While pending is measured, the next move starts from its axes and
     * the rig clock runs on by its move, settle and integration. */
    struct rig_axes from = *at;
    double clock = rig_time_s + a->reserve;
    a->from_turn = turn_of(a, a->last_obs);
    if (pending >= 0) {
        double cost;
        clock += budget_cost(a, at, (size_t)pending, &cost);
        from = plan_point(a->pool, (size_t)pending)->ax;
        a->from_turn = turn_of(a, pending);
    }
    const char *stop = "";
    double gain = gain_per_min(a);
    if (a->n >= MIN_STOP_SAMPLES && a->opt.target > 0 && a->predicted <= a->opt.target)
        stop = "target";
    else if (a->n >= MIN_STOP_SAMPLES && a->opt.converge && fabs(gain) < a->opt.gain_tol)
        stop = "converged";
    long best = next_seed(a, &from, pending, clock);
    double cost;
    if (*stop || (best >= 0 && !affordable(a, &from, (size_t)best, clock, &cost)))
        best = -1;
    int seeding = best >= 0;
    a->max_alc = 1e-300;
    for (size_t i = 0; !seeding && a->ens.ok && a->cover && i < a->n_pool; i++)
        if (!a->measured[i])
            a->max_alc = fmax(a->max_alc, alc(a, i));
    double best_score = -INFINITY;
    int open = 0; /* candidates left, affordable or not */
    for (size_t i = 0; !*stop && !seeding && i < a->n_pool; i++) {
        if (a->measured[i] || (long)i == pending)
            continue;
        open = 1;
        if (!affordable(a, &from, i, clock, &cost))
            continue;
        double score = worth(a, i, pending) / cost;
        if (score > best_score) {
            best_score = score;
            best = (long)i;
        }
    }
    if (!*stop && best < 0)
        stop = open ? "budget" : "exhausted";
    if (st) {
        *st = (struct adaptive_status){
            .samples = a->n, .predicted_error = a->predicted, .gain_per_min = gain,
            .predicted_next_s = 60, .decision_s = now_s() - t0,
        };
        st->predicted_next = adaptive_predicted_next(a->predicted, gain);
        snprintf(st->model, sizeof st->model, "%s",
                 strcmp(a->model, "auto") != 0 ? a->model : a->cover ? "latent" : "abc");
        snprintf(st->stop, sizeof st->stop, "%s", stop);
    }
    return *stop ? -1 : best;
}
