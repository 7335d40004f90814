#include "capture/capture.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/domain.h"
#include "brdf/material.h"
#include "common/clock.h"
#include "capture/capture_files.h"
#include "capture/eta.h"
#include "capture/sequence.h"
#include "fit/journal_samples.h"
#include "journal/journal.h"
#include "fit/abc_model.h"
#include "fit/abc_prior.h"
#include "fit/fit.h"
#include "fit/model_file.h"
#include "fit/model_run.h"
#include "fit/models.h"
#include "fit/stream.h"
#include "planner/planner.h"
#include "rig/motion.h"

/* What a capture reads, resolved and validated before anything is written. */
struct capture_inputs {
    const struct capture_rig *src; /* the host's rig source */
    struct plan_rig rig;
    struct plan *plan;
    brdf_material *truth_own; /* a named reference (cfg->truth), opened here */
    const brdf_material *truth; /* the truth errors' reference, NULL: none */
    char material_name[512]; /* what was measured, as a label; "" when unknown */
    char truth_name[512];
    const struct fit_model_kind *model; /* the final fit's (fit/models.h) */
    int adaptive; /* the plan's order is adaptive: the policy's options */
    struct adaptive_options policy;
    /* The rig time the capture will take: with the integration the rig
     * source says its detector will choose, else the rig's fixed one. */
    struct plan_estimate est;
    /* Each point's integration as the rig source knows it, for the
     * adaptive policy's costs and the ETA; NULL when it does not (both
     * learn it from the journal). */
    double *integration_s;
    /* Points measured first to meter the material (capture/sequence.h). */
    size_t prescan;
};

static void inputs_free(struct capture_inputs *in)
{
    free(in->integration_s);
    plan_free(in->plan);
    brdf_material_free(in->truth_own);
}

/* "default" names the material actually used. */
static const char *material_spec(const char *spec)
{
    return strcmp(spec, "default") ? spec : brdf_material_default_spec();
}

/* What the rig measures, as its source knows it or as the host labels it;
 * and the reference of the truth errors: the named one, else what the
 * source says the rig measures, else none. */
static int resolve_materials(const struct capture_config *cfg, struct capture_inputs *in,
                             struct gonio_err *err)
{
    if (in->src->material) {
        in->truth = in->src->material;
        snprintf(in->material_name, sizeof in->material_name, "%s",
                 brdf_material_name(in->src->material));
    } else if (cfg->material) {
        snprintf(in->material_name, sizeof in->material_name, "%s",
                 material_spec(cfg->material));
    }
    if (cfg->truth) {
        if (!(in->truth_own = brdf_material_open(material_spec(cfg->truth), err)))
            return -abs(err ? err->code : GONIO_ENOTFOUND);
        in->truth = in->truth_own;
    }
    if (in->truth)
        snprintf(in->truth_name, sizeof in->truth_name, "%s", brdf_material_name(in->truth));
    return 0;
}

static int estimate(struct capture_inputs *in, struct gonio_err *err)
{
    size_t n = plan_count(in->plan);
    const struct capture_rig *src = in->src;
    if (!src->integration_s) {
        plan_estimate(in->plan, &in->rig, &in->est);
        return 0;
    }
    if (!(in->integration_s = malloc((n ? n : 1) * sizeof *in->integration_s)))
        return gonio_err_set(err, ENOMEM, "out of memory");
    plan_estimate_points(in->plan, &in->rig, src->integration_s, src->user, NULL, &in->est);
    for (size_t i = 0; i < n; i++)
        in->integration_s[i] = src->integration_s(src->user, plan_point(in->plan, i));
    return 0;
}

/* The pre-scan: cfg->prescan's points. By default on a host's rig, whose
 * material the engine cannot meter before it measures,
 * CAPTURE_PRESCAN_DEFAULT points, but one in CAPTURE_PRESCAN_SHARE of a
 * smaller plan's, and none when that is fewer than 2: the pre-scan crosses
 * the plan's domain once, which on a small plan costs more than its ETA is
 * worth (DS3, 52 points: 6 cost 19 s of 81 s, 2 cost 1.4 s; DS4, 6 points:
 * 2 cost 8 s of 18 s; docs/plans.md). None on a rig whose
 * source knows the integration its detector will choose (the estimate
 * already counts it), and never in the adaptive order, whose policy chooses every
 * point. */
static size_t prescan_default(const struct plan *plan)
{
    size_t n = plan_count(plan) / CAPTURE_PRESCAN_SHARE;
    return n < 2 ? 0 : n > CAPTURE_PRESCAN_DEFAULT ? CAPTURE_PRESCAN_DEFAULT : n;
}

int capture_prescan_option(const char *opt, long long points, int *prescan,
                           struct gonio_err *err)
{
    if (points < 0 || points > CAPTURE_PRESCAN_MAX)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "%s %lld: a number of points from 0 (none) to %d", opt, points,
                             CAPTURE_PRESCAN_MAX);
    *prescan = points ? (int)points : CAPTURE_PRESCAN_OFF;
    return 0;
}

static int resolve_prescan(const struct capture_config *cfg, struct capture_inputs *in,
                           struct gonio_err *err)
{
    if (cfg->prescan < CAPTURE_PRESCAN_OFF || cfg->prescan > CAPTURE_PRESCAN_MAX)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "prescan %d: a number of points from 0 (none) to %d",
                             cfg->prescan, CAPTURE_PRESCAN_MAX);
    if (cfg->prescan > 0 && in->adaptive)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "--prescan %d: the adaptive order chooses every point itself "
                             "(plan '%s')",
                             cfg->prescan, plan_name(in->plan));
    in->prescan = cfg->prescan > 0                        ? (size_t)cfg->prescan
                  : cfg->prescan == CAPTURE_PRESCAN_OFF ? 0
                  : !in->src->integration_s && !in->adaptive ? prescan_default(in->plan)
                                                         : 0;
    if (in->prescan > plan_count(in->plan))
        in->prescan = plan_count(in->plan);
    return 0;
}

/* The capture's stop rule: the plan's, or --stop. */
static enum plan_stop_kind stop_kind(const struct capture_config *cfg, const struct plan *plan)
{
    if (cfg->stop)
        return strcmp(cfg->stop, "all") ? PLAN_STOP_CONVERGE : PLAN_STOP_ALL;
    return plan_stop(plan)->kind;
}

static int resolve_inputs(const struct capture_config *cfg, const struct capture_rig *src,
                          struct capture_inputs *in, struct gonio_err *err)
{
    memset(in, 0, sizeof *in);
    in->src = src;
    int rc;
    const char *rig = cfg->rig ? cfg->rig : src->profile;
    if (!rig)
        return gonio_err_set(err, GONIO_EUSAGE, "no rig profile: name one (--rig NAME|FILE)");
    if ((rc = plan_rig_load(rig, &in->rig, err)) < 0)
        return rc;
    if ((rc = plan_load(cfg->plan, &in->rig, &in->plan, err)) < 0)
        return rc;
    if (cfg->order) {
        int mode = plan_order_parse(cfg->order);
        if (mode < 0) {
            inputs_free(in);
            return gonio_err_set(err, GONIO_EUSAGE,
                                 "--order '%s': use travel, progressive, as-written, greedy or "
                                 "adaptive",
                                 cfg->order);
        }
        if ((rc = plan_order(in->plan, (enum plan_order_mode)mode, &in->rig)) < 0) {
            inputs_free(in);
            return gonio_err_set(err, -rc, "ordering plan: %s", gonio_strerror(rc));
        }
    }
    if (!(in->model = fit_model_find_rgb(cfg->model, "--model", err))) {
        inputs_free(in);
        return -GONIO_EUSAGE;
    }
    if (cfg->stop && strcmp(cfg->stop, "all") && strcmp(cfg->stop, "converge")) {
        inputs_free(in);
        return gonio_err_set(err, GONIO_EUSAGE, "--stop '%s': use all or converge", cfg->stop);
    }
    in->adaptive = plan_current_order(in->plan) == PLAN_ORDER_ADAPTIVE;
    if ((rc = sequence_options(cfg, in->plan, stop_kind(cfg, in->plan) == PLAN_STOP_CONVERGE,
                               &in->policy, err)) < 0 ||
        (rc = resolve_prescan(cfg, in, err)) < 0) {
        inputs_free(in);
        return rc;
    }
    if ((rc = resolve_materials(cfg, in, err)) == 0)
        rc = estimate(in, err);
    if (rc < 0)
        inputs_free(in);
    return rc;
}

const char *capture_phase_name(enum capture_phase phase)
{
    static const char *const names[] = {"between", "move", "acquire", "journal", "fit"};
    return (unsigned)phase < sizeof names / sizeof *names ? names[phase] : "?";
}

static void phase(const struct capture_hooks *hooks, enum capture_phase ph, int point)
{
    if (hooks->on_phase)
        hooks->on_phase(hooks->user, ph, point);
}

/* The rig time a capture reports. A resumed run continues from the last
 * journalled sample (base) by what the rig clock measured since its devices
 * opened (t0), on every driver; clock that ran while the host held the
 * capture paused is kept apart (paused), not counted as rig time. */
struct rig_clock {
    drv_clock *clock;
    double base, t0, last, paused;
};

static void rig_clock_start(struct rig_clock *rc, drv_clock *clock, double base)
{
    rc->clock = clock;
    rc->base = base;
    rc->t0 = rc->last = drv_clock_now(clock);
    rc->paused = 0;
}

static double rig_clock_now(struct rig_clock *rc)
{
    rc->last = drv_clock_now(rc->clock);
    return rc->base + (rc->last - rc->t0) - rc->paused;
}

/* The host held the capture paused since the last reading. */
static void rig_clock_paused(struct rig_clock *rc)
{
    double now = drv_clock_now(rc->clock);
    rc->paused += now - rc->last;
    rc->last = now;
}

/* Move the axes together, settle, integrate, and record where the axes
 * actually were: the sample is what the rig measured, not what was asked.
 * The settle runs from when the last axis came to rest, as its drive said
 * (drv_axis_rested); the encoders are read while it runs, so that their
 * reads add nothing to the point's time where the bus is slow. */
static int measure_point(struct capture_devices *d, struct rig_clock *clk,
                         const struct capture_hooks *hooks, const struct plan_rig *rig,
                         const struct plan_point *pt, int index, struct journal_sample *s,
                         struct gonio_err *err)
{
    drv_axis *axes[3] = {d->sample, d->arm, d->azimuth};
    const double to[3] = {pt->ax.s, pt->ax.a, pt->ax.az};
    double at[3] = {0, 0, 0}, rested = INFINITY;
    int n = d->azimuth ? 3 : 2, rc;
    for (int i = 0; i < n; i++)
        if ((rc = drv_axis_start_move(axes[i], to[i], err)) < 0)
            return rc;
    phase(hooks, CAPTURE_PHASE_MOVE, index);
    /* An axis moving against its approach direction stops beyond the
     * target, then comes back: each such approach leg is sent as its first
     * leg ends, the axes whose first legs end first first, so the move
     * lasts as long as its slowest axis (rig/motion.h). */
    const struct plan_axis *prof[3] = {&rig->sample, &rig->arm, &rig->azimuth};
    int by_leg[3] = {0, 1, 2};
    double leg[3];
    for (int i = 0; i < n; i++)
        leg[i] = plan_axis_time(drv_axis_leg_deg(axes[i]), prof[i]->speed, prof[i]->accel);
    for (int i = 1; i < n; i++)
        for (int k = i; k > 0 && leg[by_leg[k]] < leg[by_leg[k - 1]]; k--) {
            int tmp = by_leg[k];
            by_leg[k] = by_leg[k - 1];
            by_leg[k - 1] = tmp;
        }
    for (int k = 0; k < n; k++)
        if ((rc = drv_axis_wait_leg(axes[by_leg[k]], err)) < 0)
            return rc;
    for (int i = 0; i < n; i++)
        if ((rc = drv_axis_wait(axes[i], err)) < 0)
            return rc;
    phase(hooks, CAPTURE_PHASE_ACQUIRE, index);
    for (int i = 0; i < n; i++)
        if ((rc = drv_axis_position(axes[i], &at[i], err)) < 0)
            return rc;
    for (int i = 0; i < n; i++)
        rested = fmin(rested, drv_axis_rested(axes[i]));
    /* The integration starts no sooner than the detector's lag after the
     * call: the settle is over by then. */
    double left = rig->settle_s - rested - drv_detector_lag(d->detector);
    if (left > 0 && (rc = drv_clock_sleep(d->clock, left)) < 0)
        return gonio_err_set(err, -rc, "settle: %s", gonio_strerror(rc));
    struct drv_reading r;
    if ((rc = drv_detector_acquire(d->detector, rig->integration_s, &r, err)) < 0)
        return rc;
    memset(s, 0, sizeof *s);
    s->point = index;
    s->s = at[0];
    s->a = at[1];
    /* Angles from the axes, with the planner's mapping (sim.c explains). */
    brdf_axes_to_inplane(s->s, s->a, &s->theta_i, &s->theta_r);
    s->theta_o = fabs(s->theta_r);
    s->phi_i = 0.0;
    s->phi_o = fmod(at[2] + (s->theta_r >= 0 ? 180.0 : 0.0) + 360.0, 360.0);
    memcpy(s->rgb, r.rgb, sizeof s->rgb);
    s->integration_s = r.integration_s;
    s->flags = (r.flags & DRV_READING_SATURATED) ? JOURNAL_FLAG_SATURATED : 0;
    s->rig_time_s = rig_clock_now(clk);
    return 0;
}

/* What the axes' mechanics cost (re-commands, alarms, re-homes), summed. */
static void add_axis_stats(const struct capture_devices *d, struct drv_axis_stats *sum)
{
    const drv_axis *axes[3] = {d->sample, d->arm, d->azimuth};
    for (int i = 0; i < 3; i++) {
        struct drv_axis_stats st;
        drv_axis_stats(axes[i], &st);
        sum->moves += st.moves;
        sum->recommands += st.recommands;
        sum->alarms_recovered += st.alarms_recovered;
        sum->rehomes += st.rehomes;
    }
}

static void stop_axes(struct capture_devices *d)
{
    drv_axis_stop(d->sample, NULL);
    drv_axis_stop(d->arm, NULL);
    if (d->azimuth)
        drv_axis_stop(d->azimuth, NULL);
}

/* The capture's streaming fit: the stop rule of stop: converge, or with
 * progress_fit the rounds behind a host's progress figures. */
struct stream {
    fit_stream *fs;   /* NULL: no streaming fit */
    int progress;     /* rounds at 16, 32, 64... samples only */
    double log_error; /* the latest round's in-sample log error, NAN before one */
};

#define PROGRESS_FIRST 16 /* samples before the first progress round */

/* The in-sample errors of the latest round over the samples so far, for
 * the host. */
static void report_fit(const struct capture_hooks *hooks, struct stream *st,
                       const struct journal_sample *js, size_t n)
{
    const struct brdf_abc *p = fit_stream_params(st->fs);
    struct brdf_pair *pairs = malloc(n * sizeof *pairs);
    double *meas = malloc(n * 3 * sizeof *meas), *pred = malloc(n * 3 * sizeof *pred);
    if (p && pairs && meas && pred) {
        for (size_t i = 0; i < n; i++) {
            journal_sample_pair(&js[i], &pairs[i]);
            memcpy(meas + 3 * i, js[i].rgb, sizeof js[i].rgb);
            brdf_abc_eval(p, &pairs[i], pred + 3 * i);
        }
        struct brdf_errors e;
        brdf_errors_compute(pairs, meas, pred, n, &e);
        st->log_error = e.log;
        if (hooks->on_fit)
            hooks->on_fit(hooks->user, &e, n);
    }
    free(pairs);
    free(meas);
    free(pred);
}

/* Feed the journalled sample js[n - 1] to the streaming fit. A round is
 * forced (and announced as the FIT phase) where a progressive level ends,
 * or, for progress, where the count reaches 16, 32, 64... Returns 1 once
 * the stop rule has decided. */
static int stream_feed(struct stream *st, const struct plan *plan,
                       const struct capture_hooks *hooks, const struct journal_sample *js,
                       size_t n, struct gonio_err *err)
{
    if (!st->fs)
        return 0;
    const struct journal_sample *last = &js[n - 1];
    struct fit_sample s;
    fit_journal_samples(last, 1, &s);
    int force;
    if (st->progress) {
        force = n >= PROGRESS_FIRST && (n & (n - 1)) == 0;
    } else {
        const struct plan_point *pt = plan_point(plan, (size_t)last->point),
                                *next = plan_point(plan, (size_t)last->point + 1);
        force = plan_current_order(plan) == PLAN_ORDER_PROGRESSIVE &&
                (!next || next->level != pt->level);
    }
    struct fit_stream_status before, after;
    fit_stream_status(st->fs, &before);
    if (force)
        phase(hooks, CAPTURE_PHASE_FIT, (int)n);
    int rc = fit_stream_add(st->fs, &s, force, err);
    if (force)
        phase(hooks, CAPTURE_PHASE_BETWEEN, (int)n);
    fit_stream_status(st->fs, &after);
    if (rc >= 0 && after.rounds > before.rounds && (hooks->on_fit || hooks->on_progress))
        report_fit(hooks, st, js, n);
    return rc;
}

/* The ETA a host shows: capture/eta.h's, metered from the journal. */
static void progress(const struct capture_hooks *hooks, const struct capture_inputs *in,
                     const capture_eta *eta, const struct stream *st, const sequence *seq,
                     size_t done, size_t already, double rig_time_s)
{
    if (!hooks->on_progress)
        return;
    struct capture_progress p = {
        .plan = plan_name(in->plan),
        .done = done,
        .total = plan_count(in->plan),
        .already_done = already,
        .rig_time_s = rig_time_s,
        .estimate_s = eta ? capture_eta_estimate(eta) : in->est.total_s,
        .eta_s = eta ? capture_eta_left(eta) : NAN,
        .fit_log_error = st->log_error,
        .prescan = in->prescan,
    };
    struct sequence_report rep;
    if (sequence_report(seq, &rep)) {
        /* The adaptive order measures a few of the pool's points: the
         * pool's estimate says nothing, the budget says how long. */
        int budget = in->policy.budget_s > 0;
        p.estimate_s = budget ? in->policy.budget_s : NAN;
        p.eta_s = budget ? fmax(in->policy.budget_s - rig_time_s, 0) : NAN;
        p.policy = &rep.status;
    }
    hooks->on_progress(hooks->user, &p);
}

/* The ETA of a capture in plan order, having observed the journal's
 * records (a resumed capture's); none in the adaptive order, whose
 * progress counts down its budget, nor for a host that shows no progress
 * (the study): metering costs O(points) per sample. */
static int eta_new(const struct capture_inputs *in, const struct capture_hooks *hooks,
                   const sequence *seq, const struct journal_sample *js, size_t n,
                   capture_eta **out, struct gonio_err *err)
{
    *out = NULL;
    if (in->adaptive || !hooks->on_progress)
        return 0;
    size_t count = plan_count(in->plan);
    long *order = malloc((count ? count : 1) * sizeof *order);
    if (!order)
        return gonio_err_set(err, ENOMEM, "out of memory");
    sequence_order(seq, order);
    capture_eta *e = capture_eta_new(in->plan, &in->rig, order, in->integration_s, err);
    free(order);
    if (!e)
        return -abs(err ? err->code : ENOMEM);
    for (size_t i = 0; i < n; i++)
        capture_eta_observe(e, &js[i]);
    *out = e;
    return 0;
}

/* Measure every point the journal does not hold yet, from `first` on in
 * the order seq gives. Sets *aborted when the host asked to stop,
 * *converged when the streaming fit decided that further points would not
 * change the model, *paused_s to the rig clock the host held the capture
 * paused. */
static int acquire(const struct capture_config *cfg, const struct capture_inputs *in,
                   const struct capture_hooks *hooks, journal *j, sequence *seq, long first,
                   struct journal_sample **samples, size_t *n, int *aborted,
                   struct stream *fs, int *converged, double *paused_s,
                   struct drv_axis_stats *mech,
                   struct gonio_err *err)
{
    size_t count = plan_count(in->plan);
    struct journal_sample *all = realloc(*samples, count * sizeof *all);
    if (!all)
        return gonio_err_set(err, ENOMEM, "out of memory");
    *samples = all;
    size_t already = *n;
    capture_eta *eta = NULL;
    int rc = eta_new(in, hooks, seq, all, *n, &eta, err);
    if (rc < 0)
        return rc;
    progress(hooks, in, eta, fs, seq, *n, already, *n > 0 ? all[*n - 1].rig_time_s : 0);
    /* A resumed capture replays its journal: the same samples give the
     * same rounds, so a capture that had converged stays converged. */
    for (size_t i = 0; i < *n && !*converged; i++) {
        rc = stream_feed(fs, in->plan, hooks, all, i + 1, err);
        if (rc < 0) {
            capture_eta_free(eta);
            return rc;
        }
        *converged = rc;
    }
    if (*converged || first < 0) {
        capture_eta_free(eta);
        return 0;
    }

    struct capture_devices dev = {0};
    const struct capture_rig *src = in->src;
    double base = *n > 0 ? all[*n - 1].rig_time_s : 0;
    rc = src->open(src->user, &in->rig, cfg->out_dir, &dev, err);
    if (rc == 0 && *n > 0 && src->resume) {
        /* the journal keeps the sample's axes; the azimuth is the plan's */
        const struct journal_sample *last = &all[*n - 1];
        const double at[3] = {last->s, last->a, plan_point(in->plan, (size_t)last->point)->ax.az};
        src->resume(src->user, &dev, at, last->rig_time_s);
    }
    if (rc < 0) {
        capture_eta_free(eta);
        return rc;
    }
    struct rig_clock clk;
    rig_clock_start(&clk, dev.clock, base);

    for (long k = first; k >= 0 && rc == 0;) {
        enum capture_control c = hooks->control ? hooks->control(hooks->user) : CAPTURE_GO;
        if (c == CAPTURE_ABORT) {
            stop_axes(&dev);
            *aborted = 1;
            break;
        }
        if (c == CAPTURE_PAUSED)
            rig_clock_paused(&clk);
        struct journal_sample s;
        const struct plan_point *pt = plan_point(in->plan, (size_t)k);
        /* The adaptive order decides the point after k meanwhile. */
        rc = sequence_begin(seq, k, err);
        if (rc == 0)
            rc = measure_point(&dev, &clk, hooks, &in->rig, pt, (int)k, &s, err);
        if (rc < 0) {
            stop_axes(&dev); /* a failed point leaves no axis moving */
            if (err) { /* name the point the operator will find in plan.json */
                char msg[GONIO_ERR_MSG_MAX];
                snprintf(msg, sizeof msg, "%s", err->msg);
                gonio_err_set(err, err->code, "point %ld (theta_i %g, theta_r %g): %s", k,
                              pt->theta_i, pt->theta_r, msg);
            }
        }
        if (rc == 0) {
            phase(hooks, CAPTURE_PHASE_JOURNAL, (int)k);
            rc = journal_append(j, &s, err);
            phase(hooks, CAPTURE_PHASE_BETWEEN, (int)k);
        }
        long next = -1;
        if (rc < 0) {
            sequence_end(seq, NULL, &next, NULL);
            break;
        }
        all[(*n)++] = s;
        rc = sequence_end(seq, &s, &next, err);
        /* The fit round first: the host's sample event carries it. */
        if (rc == 0)
            rc = stream_feed(fs, in->plan, hooks, all, *n, err);
        if (eta)
            capture_eta_observe(eta, &s);
        if (rc >= 0)
            progress(hooks, in, eta, fs, seq, *n, already, s.rig_time_s);
        if (rc >= 0 && hooks->on_sample)
            hooks->on_sample(hooks->user, &s, *n, count);
        if (rc > 0) {
            *converged = 1;
            rc = 0;
            break;
        }
        k = next;
    }
    *paused_s = clk.paused;
    add_axis_stats(&dev, mech);
    src->close(src->user, &dev);
    capture_eta_free(eta);
    return rc;
}

/* The capture's model file, DIR/NAME.model (the name `gonio fit DIR --model
 * NAME` writes by default), recorded in the summary. */
static void model_path(const char *dir, const char *name, struct capture_summary *out,
                       char *path, size_t len)
{
    snprintf(out->model_file, sizeof out->model_file, "%s.model", name);
    snprintf(path, len, "%.4000s/%s", dir, out->model_file);
}

/* abc and abc-prior: fit_abc / fit_abc_map, warm-started from the
 * streaming fit, with parameter sds and (abc-prior) the too-few-samples
 * warning; the parameters go into results.json and, as gonio fit's abc
 * kind, into DIR/NAME.model, read back so that the errors are the file's. */
static int fit_abc_capture(const struct fit_data *data, const struct brdf_abc *warm,
                           const char *dir, const char *model, struct capture_summary *out,
                           brdf_material **fitted, struct gonio_err *err)
{
    const struct fit_sample *fs = data->rgb;
    size_t n = data->n_rgb;
    const char *material = data->material;
    struct fit_options opt = fit_default_options();
    opt.warm_start = warm; /* the streaming fit's last parameters, when there is one */
    opt.lower_bound = data->rgb_lower;
    opt.domain_weights = data->domain_weights;
    struct fit_info info;
    double t0 = gonio_monotonic_s();
    /* abc-prior: MAP with the population prior, the material left out of it */
    struct fit_abc_prior prior;
    int use_prior = !strcmp(model, "abc-prior");
    int rc = use_prior ? fit_abc_prior_build(material, &prior, err) : 0;
    if (rc == 0)
        rc = use_prior ? fit_abc_map(fs, n, &opt, &prior, &out->params, &info, err)
                       : fit_abc(fs, n, &opt, &out->params, &info, err);
    out->fit_time_s = gonio_monotonic_s() - t0;
    if (rc < 0)
        return rc;
    out->has_params = 1;
    out->sd = info.sd;
    if (use_prior)
        fit_abc_prior_warning(&info, n - info.dropped, out->warning, sizeof out->warning);
    out->converged = info.converged;
    out->status = info.status;

    /* The keys gonio fit's abc and abc-prior files carry, and where the
     * start came from (a warm start makes the file differ from gonio fit's). */
    struct fit_model_file *mf = fit_abc_fitted_file(&out->params, opt.seed, &info);
    if (mf && ((warm && fit_model_file_set(mf, "warm_start", "the capture's streaming fit")) ||
               (use_prior && fit_abc_prior_file_keys(mf, &prior, &info)))) {
        fit_model_file_free(mf);
        mf = NULL;
    }
    if (!mf)
        return gonio_err_set(err, ENOMEM, "out of memory");
    char path[4200];
    model_path(dir, model, out, path, sizeof path);
    rc = fit_model_write_open(mf, path, fitted, err);
    fit_model_file_free(mf);
    if (rc < 0)
        out->model_file[0] = '\0';
    return rc;
}

/* Any other registered RGB model: the fit `gonio fit` makes, its model
 * file written as DIR/NAME.model and read back, so that the errors below
 * are those of the file an operator renders or exports. */
static int fit_registry_capture(const struct fit_data *data, const char *dir,
                                const struct fit_model_kind *kind, struct capture_summary *out,
                                brdf_material **fitted, struct gonio_err *err)
{
    struct fit_model_options mo = fit_model_default_options();
    struct fit_model_report rep = {0};
    char path[4200];
    model_path(dir, kind->name, out, path, sizeof path);
    int rc = fit_model_run(kind, data, &mo, path, &rep, &out->fit_time_s, fitted, err);
    if (rc < 0) {
        out->model_file[0] = '\0';
        return rc;
    }
    out->converged = rep.converged;
    out->status = rep.status;
    return 0;
}

/* The final fit of the journalled samples with the capture's model, and its
 * error on them (the plan domain). Saturated readings are fitted as lower
 * bounds when the model censors them (fit_model_censors; docs/fitting.md
 * "Saturated readings"), and samples an adaptive policy chose (chosen) are
 * weighted by their share of the domain (fit/models.h fit_data). A failed
 * fit names the model and leaves the journal as it is. */
static int fit_samples(const struct journal_sample *js, size_t n, const struct brdf_abc *warm,
                       const struct fit_model_kind *kind, const char *dir, const char *material,
                       int chosen, struct capture_summary *out, brdf_material **fitted,
                       struct gonio_err *err)
{
    struct fit_sample *fs = malloc((n ? n : 1) * sizeof *fs);
    unsigned char *lower = malloc(n ? n : 1);
    if (!fs || !lower) {
        free(fs);
        free(lower);
        return gonio_err_set(err, ENOMEM, "out of memory");
    }
    out->saturated = fit_journal_samples(js, n, fs);
    for (size_t i = 0; i < n; i++)
        lower[i] = (js[i].flags & JOURNAL_FLAG_SATURATED) != 0;
    struct fit_data data = {.rgb = fs,
                            .n_rgb = n,
                            .rgb_lower = out->saturated && fit_model_censors(
                                             kind, FIT_SATURATED_DEFAULT) ? lower : NULL,
                            .material = material,
                            .domain_weights = chosen};
    int rc = !strcmp(kind->name, "abc") || !strcmp(kind->name, "abc-prior")
                 ? fit_abc_capture(&data, warm, dir, kind->name, out, fitted, err)
                 : fit_registry_capture(&data, dir, kind, out, fitted, err);
    if (rc < 0 && err) {
        char msg[GONIO_ERR_MSG_MAX];
        snprintf(msg, sizeof msg, "%s", err->msg);
        gonio_err_set(err, err->code,
                      "final fit (model %s): %s; the %zu samples stay in %s/samples.csv",
                      kind->name, msg, n, dir);
    }
    if (rc == 0) /* Plan-domain error: the model against what was measured. */
        rc = fit_sample_errors(*fitted, fs, n, &out->err_plan, err);
    free(fs);
    free(lower);
    return rc;
}

/* Errors against the true material over the in-plane and full domains. */
#define ASSESS_SEED UINT64_C(20261201) /* the sample of the full domain (assess_nodes) */
static int assess_truth(const brdf_material *truth, const brdf_material *model,
                        size_t assess_nodes, struct capture_summary *out, struct gonio_err *err)
{
    struct brdf_domain inplane = {0}, full = {0};
    int rc = brdf_domain_inplane(&inplane, err);
    if (rc >= 0)
        rc = assess_nodes ? brdf_domain_oop_random(&full, assess_nodes, ASSESS_SEED, err)
                          : brdf_domain_full(&full, err);
    if (rc >= 0)
        rc = brdf_errors_material(truth, model, &inplane, &out->err_inplane, err);
    if (rc >= 0)
        rc = brdf_errors_material(truth, model, &full, &out->err_full, err);
    if (rc >= 0) {
        out->has_truth = 1;
        rc = 0;
    }
    brdf_domain_free(&inplane);
    brdf_domain_free(&full);
    return rc;
}

/* The streaming fit a capture runs: its plan's stop rule (or --stop)
 * converge, or rounds for a host's progress figures; none otherwise, and
 * none in the adaptive order. */
static int stream_new(const struct capture_config *cfg, const struct plan *plan,
                      struct stream *st, struct gonio_err *err)
{
    memset(st, 0, sizeof *st);
    st->log_error = NAN;
    if (plan_current_order(plan) == PLAN_ORDER_ADAPTIVE)
        return 0; /* the policy stops the capture and predicts its error */
    struct plan_stop stop = *plan_stop(plan);
    stop.kind = stop_kind(cfg, plan);
    struct fit_stream_options so = fit_stream_default_options();
    if (stop.kind == PLAN_STOP_CONVERGE) {
        so.tol = stop.tol;
        so.rounds = stop.rounds;
        so.every = stop.every;
        so.min_points = stop.min_points;
    } else if (cfg->progress_fit && !cfg->measure_only) {
        st->progress = 1;
        so.converge = 0;
        so.every = 0; /* only the rounds stream_feed forces */
    } else {
        return 0;
    }
    return fit_stream_new(&so, &st->fs, err);
}

int capture_run(const struct capture_config *cfg, const struct capture_rig *rig,
                const struct capture_hooks *hooks, struct capture_summary *out,
                struct gonio_err *err)
{
    static const struct capture_hooks no_hooks;
    if (!hooks)
        hooks = &no_hooks;
    memset(out, 0, sizeof *out);
    struct capture_inputs in;
    int rc = resolve_inputs(cfg, rig, &in, err);
    if (rc < 0)
        return rc;
    snprintf(out->plan, sizeof out->plan, "%s", plan_name(in.plan));
    snprintf(out->material, sizeof out->material, "%s", in.material_name);
    snprintf(out->truth, sizeof out->truth, "%s", in.truth_name);
    snprintf(out->model, sizeof out->model, "%s", cfg->model);

    struct journal_sample *samples = NULL;
    size_t n = 0;
    int aborted = 0, converged = 0, lock_fd = -1;
    journal *j = NULL;
    brdf_material *fitted = NULL; /* the final fit, as a material */
    struct stream fs;
    if ((rc = stream_new(cfg, in.plan, &fs, err)) < 0) {
        inputs_free(&in);
        return rc;
    }
    /* Stopped before anything is written (an interrupt while planning):
     * an aborted capture with no files, not a half-made directory. */
    if (hooks->control && hooks->control(hooks->user) == CAPTURE_ABORT) {
        snprintf(out->stop_reason, sizeof out->stop_reason, "aborted");
        fit_stream_free(fs.fs);
        inputs_free(&in);
        return 0;
    }
    struct capture_setup setup = {
        .plan = in.plan,
        .rig = &in.rig,
        .source = rig->setup_json,
        .material = in.material_name[0] ? in.material_name : NULL,
        .driver = rig->driver ? rig->driver : "unknown",
        .detector = rig->detector ? rig->detector : "unknown",
        .policy = in.adaptive ? &in.policy : NULL,
    };
    rc = capture_files_prepare(cfg->out_dir, &setup, &lock_fd, err);
    if (rc == 0) {
        char path[4096];
        snprintf(path, sizeof path, "%s/samples.csv", cfg->out_dir);
        j = journal_open(path, &samples, &n, err);
        rc = j ? 0 : -abs(err ? err->code : EIO);
        if (j && cfg->lazy_journal)
            journal_set_lazy(j);
    }
    sequence *seq = NULL;
    long first = -1;
    if (rc == 0)
        rc = sequence_new(in.plan, &in.rig, in.integration_s, &in.policy, in.prescan, samples, n,
                          cfg->out_dir, &seq, &first, err);
    if (rc == 0)
        rc = acquire(cfg, &in, hooks, j, seq, first, &samples, &n, &aborted, &fs, &converged,
                     &out->paused_s, &out->mech, err);
    journal_close(j);
    if (rc == 0 && !aborted)
        rc = sequence_summary(seq, &in.policy, out, err);
    if (out->adaptive && !strcmp(out->policy.stop, "converged"))
        converged = 1; /* the policy's convergence is the capture's */
    sequence_free(seq);
    if (rc == 0) {
        out->samples = n;
        out->rig_time_s = n ? samples[n - 1].rig_time_s : 0;
        for (size_t i = 0; i < n; i++)
            out->integration_s += samples[i].integration_s;
        out->settle_s = (double)n * in.rig.settle_s;
        out->move_s = out->rig_time_s - out->settle_s - out->integration_s;
        snprintf(out->stop_reason, sizeof out->stop_reason, "%s",
                 aborted                ? "aborted"
                 : out->policy.stop[0] ? out->policy.stop
                 : converged            ? "converged"
                                        : "complete");
    }
    int fit = rc == 0 && !aborted && !cfg->measure_only;
    if (fit)
        phase(hooks, CAPTURE_PHASE_FIT, -1);
    /* The final fit starts from the stop rule's last round; progress
     * rounds do not steer it, so a capture fits the same with or without
     * them. abc-prior leaves what was measured out of its prior. */
    if (fit)
        rc = fit_samples(samples, n, fs.fs && !fs.progress ? fit_stream_params(fs.fs) : NULL,
                         in.model, cfg->out_dir,
                         in.material_name[0] ? in.material_name
                         : in.truth_name[0] ? in.truth_name
                                            : NULL,
                         in.adaptive, out, &fitted, err);
    if (rc == 0 && converged)
        out->converged = 1; /* the stop rule decided: the capture converged */
    if (rc == 0 && fit && in.truth)
        rc = assess_truth(in.truth, fitted, cfg->assess_nodes, out, err);
    if (rc == 0 && fit)
        rc = capture_files_results(cfg->out_dir, out, err);
    if (rc == 0 && !aborted)
        phase(hooks, CAPTURE_PHASE_BETWEEN, -1);
    capture_files_unlock(lock_fd);
    brdf_material_free(fitted);
    free(samples);
    fit_stream_free(fs.fs);
    inputs_free(&in);
    return rc;
}

int capture_check(const struct capture_config *cfg, const struct capture_rig *rig,
                  struct plan_estimate *est, struct gonio_err *err)
{
    struct capture_inputs in;
    int rc = resolve_inputs(cfg, rig, &in, err);
    if (rc < 0)
        return rc;
    if (est)
        *est = in.est;
    inputs_free(&in);
    return 0;
}
