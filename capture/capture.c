#include "capture/capture.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "capture/capture_files.h"
#include "capture/journal_plan.h"
#include "capture/autorange.h"
#include "capture/calibration.h"
#include "capture/capture_bands.h"
#include "capture/calibration_check.h"
#include "capture/eta.h"
#include "capture/final_fit.h"
#include "capture/isotropy_check.h"
#include "capture/job.h"
#include "capture/live_fit.h"
#include "capture/measure.h"
#include "capture/reference_after.h"
#include "capture/sequence.h"
#include "journal/journal.h"
#include "planner/planner.h"

const char *capture_phase_name(enum capture_phase phase)
{
    static const char *const names[] = {"between", "move", "acquire", "journal", "fit"};
    return (unsigned)phase < sizeof names / sizeof *names ? names[phase] : "?";
}

void capture_phase_enter(const struct capture_hooks *hooks, enum capture_phase ph, int point)
{
    if (hooks->on_phase)
        hooks->on_phase(hooks->user, ph, point);
}

/* The ETA a host shows: capture/eta.h's, metered from the journal. */
static void progress(const struct capture_hooks *hooks, const struct capture_job *in,
                     const capture_eta *eta, const struct live_fit *st, const sequence *seq,
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
static int eta_new(const struct capture_job *in, const struct capture_hooks *hooks,
                   const sequence *seq, const struct autorange *ar,
                   const struct journal_sample *js, size_t n, capture_eta **out,
                   struct gonio_err *err)
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
    capture_eta_ranging(e, ar, in->prescan);
    /* A resumed capture's first record moved from where the capture found
     * the axes (plan.json's start), not from home. */
    struct rig_axes start;
    plan_order_start(in->plan, &start);
    if (n > 0)
        capture_eta_start(e, &start);
    for (size_t i = 0; i < n; i++)
        capture_eta_observe(e, &js[i]);
    *out = e;
    return 0;
}

/* The axes' present positions (the encoders, read once the devices are
 * open, before the first move): a capture starts wherever the last one, or
 * a bring-up command, left them. */
static int axes_now(const struct capture_devices *dev, struct rig_axes *at,
                    struct gonio_err *err)
{
    *at = (struct rig_axes){0, 0, 0};
    int rc = drv_axis_position(dev->sample, &at->s, err);
    if (rc == 0)
        rc = drv_axis_position(dev->arm, &at->a, err);
    if (rc == 0 && dev->azimuth)
        rc = drv_axis_position(dev->azimuth, &at->az, err);
    return rc;
}

/* One run of a job: the directory, the journal and what was measured. */
struct run {
    capture_job *job;
    const struct capture_hooks *hooks;
    struct capture_summary *out;
    int lock_fd;
    journal *j;
    struct sequence_setup order;
    sequence *seq;
    struct journal_sample *samples; /* the journal's, then this run's (room for the plan) */
    struct capture_ranging ranging; /* its dark frames are journalled, not samples */
    size_t n, already;              /* samples, of which journalled by earlier runs */
    struct live_fit fit;
    capture_eta *eta;
    int aborted, converged;
};

/* Replay a resumed capture's journal into the streaming fit: the same
 * samples give the same rounds, so a capture that had converged stays
 * converged. */
static int replay_journal(struct run *r, struct gonio_err *err)
{
    for (size_t i = 0; i < r->n && !r->converged; i++) {
        int rc = live_fit_feed(&r->fit, r->job->plan, r->hooks, r->samples, i + 1, err);
        if (rc < 0)
            return rc;
        r->converged = rc;
    }
    return 0;
}

static int near(const struct rig_axes *a, const struct rig_axes *b, double band)
{
    return fabs(a->s - b->s) <= band && fabs(a->a - b->a) <= band && fabs(a->az - b->az) <= band;
}

/* A resumed capture whose axes stand away from where its journal left them
 * (beyond the in-position band: moved by a bring-up command, another
 * capture or by hand) travels the points left from where they stand.
 * plan.json and the journal's point numbers stay as they are (a point's
 * number is its identity, not its place on the path); the ETA follows the
 * new path. Axes where the journal left them go on as never interrupted. */
static int reroute_resumed(struct run *r, const struct rig_axes *at, long *first,
                           struct gonio_err *err)
{
    capture_job *job = r->job;
    const struct journal_sample *last = &r->samples[r->n - 1];
    if (near(at, &plan_point(job->plan, (size_t)last->point)->ax,
             job->rig.mech.in_position_deg))
        return 0;
    int rc = sequence_reroute(r->seq, at, first, err);
    if (rc < 0 || !r->eta)
        return rc;
    capture_eta_free(r->eta);
    r->eta = NULL;
    return eta_new(job, r->hooks, r->seq, &r->ranging.ar, r->samples, r->n, &r->eta, err);
}

/* A new capture whose axes stand away from home (beyond the in-position
 * band) orders its travel from where they stand, before its first record:
 * plan.json is written again with that order and its start, and the
 * sequence made again over it. *first: its first point. The orders that do
 * not travel (as written, adaptive) keep theirs; a capture with records
 * is rerouted (reroute_resumed). */
static int order_from(struct run *r, const struct rig_axes *at, long *first,
                      struct gonio_err *err)
{
    capture_job *job = r->job;
    enum plan_order_mode mode = plan_current_order(job->plan);
    double band = job->rig.mech.in_position_deg;
    if (r->n > 0 && mode != PLAN_ORDER_AS_WRITTEN && mode != PLAN_ORDER_ADAPTIVE)
        return reroute_resumed(r, at, first, err);
    if (r->n > 0 || r->ranging.ar.n_dark > 0 || mode == PLAN_ORDER_AS_WRITTEN ||
        mode == PLAN_ORDER_ADAPTIVE ||
        (fabs(at->s) <= band && fabs(at->a) <= band && fabs(at->az) <= band))
        return 0;
    int rc = plan_order_from(job->plan, mode, &job->rig, at);
    if (rc < 0)
        return gonio_err_set(err, -rc, "ordering plan: %s", gonio_strerror(rc));
    if ((rc = capture_files_plan_rewrite(job->cfg.out_dir, job->plan, &job->rig, err)) < 0)
        return rc;
    sequence_free(r->seq);
    r->seq = NULL;
    if ((rc = sequence_new(&r->order, r->samples, r->n, &r->seq, first, err)) < 0)
        return rc;
    capture_eta_free(r->eta);
    return eta_new(job, r->hooks, r->seq, &r->ranging.ar, r->samples, r->n, &r->eta, err);
}

/* Open the source's devices; a resumed capture's where its journal left
 * them (the journal keeps the sample's axes; the azimuth is the plan's). */
static int open_devices(const struct run *r, struct capture_devices *dev, struct gonio_err *err)
{
    const struct capture_job *job = r->job;
    const struct capture_rig *src = job->src;
    memset(dev, 0, sizeof *dev);
    int rc = src->open(src->user, &job->rig, job->cfg.out_dir, dev, err);
    if (rc == 0 && r->n > 0 && src->resume) {
        const struct journal_sample *last = &r->samples[r->n - 1];
        const double at[3] = {last->s, last->a,
                              plan_point(job->plan, (size_t)last->point)->ax.az};
        src->resume(src->user, dev, at, last->rig_time_s);
    }
    return rc;
}

/* Measure point k and journal it; *next receives the point after it (-1:
 * none). Returns 1 when the streaming fit decided. */
static int measure_one(struct run *r, struct capture_devices *dev, struct capture_clock *clk,
                       long k, long *next, struct gonio_err *err)
{
    const struct capture_job *job = r->job;
    const struct capture_hooks *hooks = r->hooks;
    const struct plan_point *pt = plan_point(job->plan, (size_t)k);
    struct journal_sample s;
    /* The adaptive order decides the point after k meanwhile. */
    int rc = sequence_begin(r->seq, k, err);
    if (rc == 0)
        rc = capture_measure_point(dev, clk, hooks, &job->rig, pt, pt->rotation, (int)k,
                                   &r->ranging, &s, err);
    if (rc == 0) /* a source that could not say so before: its first reading tells */
        rc = capture_calibration_check(&job->cfg, s.counts, job->src->detector, err);
    if (rc == 0 && dev->counts && !s.counts) /* never BRDF from a detector of counts */
        rc = gonio_err_set(err, GONIO_EDEVICE,
                           "the detector said at open that it gives counts, and its reading "
                           "is BRDF: a detector that changed its mode is not trusted");
    if (rc < 0) {
        capture_axes_stop(dev); /* a failed point leaves no axis moving */
        if (err) { /* name the point the operator will find in plan.json */
            char msg[GONIO_ERR_MSG_MAX];
            snprintf(msg, sizeof msg, "%s", err->msg);
            gonio_err_set(err, err->code, "point %ld (theta_i %g, theta_r %g): %s", k,
                          pt->theta_i, pt->theta_r, msg);
        }
    }
    if (rc == 0 && job->cal) { /* counts to BRDF and u before the record is written */
        struct rad_value v;
        struct journal_plan jp = {.plan = job->plan, .count = plan_count(job->plan)};
        rc = cal_reduce_sample(job->cal, &jp, r->samples, r->n, &s, &v, err);
    }
    if (rc == 0) {
        capture_phase_enter(hooks, CAPTURE_PHASE_JOURNAL, (int)k);
        rc = journal_append(r->j, &s, err);
        if (rc == 0)
            rc = capture_bands_append(job->cfg.out_dir, &s, &r->ranging.bands, err);
        capture_phase_enter(hooks, CAPTURE_PHASE_BETWEEN, (int)k);
    }
    *next = -1;
    if (rc < 0) {
        sequence_end(r->seq, NULL, next, NULL);
        return rc;
    }
    r->samples[r->n++] = s;
    rc = sequence_end(r->seq, &s, next, err);
    /* The fit round first: the host's sample event carries it. */
    if (rc == 0)
        rc = live_fit_feed(&r->fit, job->plan, hooks, r->samples, r->n, err);
    if (r->eta)
        capture_eta_observe(r->eta, &s);
    if (rc >= 0)
        progress(hooks, job, r->eta, &r->fit, r->seq, r->n, r->already, s.rig_time_s);
    if (rc >= 0 && hooks->on_sample)
        hooks->on_sample(hooks->user, &s, r->n, plan_count(job->plan));
    return rc;
}

/* A premise check's reading: the placed point pt with the sample turned
 * rotation_deg, on the capture's devices, not journalled (no plan point),
 * counts reduced through the capture's calibration; NAN when saturated or
 * outside the calibration's reference. */
struct check_ctx {
    struct run *r;
    struct capture_devices *dev;
    struct capture_clock *clk;
};

static int check_read(struct check_ctx *c, const struct plan_point *pt, double rotation_deg,
                      double rgb[3], struct gonio_err *err)
{
    static const struct capture_hooks no_hooks;
    struct journal_sample s;
    rgb[0] = rgb[1] = rgb[2] = NAN;
    int rc = capture_measure_point(c->dev, c->clk, &no_hooks, &c->r->job->rig, pt, rotation_deg,
                                   -1, &c->r->ranging, &s, err);
    if (rc < 0) {
        capture_axes_stop(c->dev);
        return rc;
    }
    if (c->r->job->cal) { /* counts to BRDF as the capture's samples are */
        /* A geometry the reference does not cover gives no value, as one
         * the rig cannot reach: the check decides on the others. */
        rc = cal_reduce_reading(c->r->job->cal, pt, &s, err);
        if (rc == -GONIO_EBADCONFIG)
            return 0;
        if (rc < 0)
            return rc;
    }
    if (!(s.flags & JOURNAL_FLAG_SATURATED))
        memcpy(rgb, s.rgb, sizeof s.rgb);
    return 0;
}

/* The isotropy check's measurement: the in-plane pair, the sample turned. */
static int check_measure(void *user, const struct iso_check_pair *p, double rotation_deg,
                         double *value, struct gonio_err *err)
{
    struct plan_point pt = {.theta_i = p->theta_i, .theta_r = p->theta_r};
    brdf_inplane_to_axes(p->theta_i, p->theta_r, &pt.ax.s, &pt.ax.a);
    double rgb[3];
    int rc = check_read(user, &pt, rotation_deg, rgb, err);
    *value = (rgb[0] + rgb[1] + rgb[2]) / 3.0;
    return rc;
}

/* The in-plane sufficiency check's: the out-of-plane pair or its in-plane
 * counterpart (NAN where the rig cannot reach it), and the fitted model's
 * prediction of a pair. */
static int oop_measure(void *user, const struct oop_check_pair *p, int in_plane,
                       double rgb[3], struct gonio_err *err)
{
    struct check_ctx *c = user;
    struct plan_point pt = {.theta_i = p->in_theta_i, .theta_r = p->in_theta_r};
    if (!in_plane)
        pt = (struct plan_point){
            .theta_i = p->theta_i, .theta_o = p->theta_o, .phi_o = p->phi_o, .out_of_plane = 1};
    char why[160];
    rgb[0] = rgb[1] = rgb[2] = NAN;
    if (plan_point_place(&pt, &c->r->job->rig, why, sizeof why) < 0)
        return 0;
    return check_read(c, &pt, 0.0, rgb, err);
}

static void oop_predict(void *user, const struct brdf_pair *p, double rgb[3])
{
    brdf_material_eval(user, p, 1, rgb);
}

/* The in-plane sufficiency check after the final fit (capture_config
 * checks), of the fitted model, on the devices opened again where the
 * capture left them; its rig time apart. */
static int check_out_of_plane(struct run *r, const brdf_material *model, struct gonio_err *err)
{
    struct capture_devices dev;
    int rc = open_devices(r, &dev, err);
    if (rc < 0)
        return rc;
    struct capture_clock clk;
    capture_clock_start(&clk, dev.clock, 0);
    struct check_ctx c = {r, &dev, &clk};
    if (!dev.azimuth)
        rc = gonio_err_set(err, GONIO_EUSAGE, "--check out-of-plane: the rig source has no "
                           "azimuth axis device");
    else
        rc = oop_check_run(oop_predict, (void *)model, oop_measure, &c,
                           r->job->rig.mech.in_position_deg, &r->out->oop, err);
    if (rc == 0) /* the fit's full-domain error, estimated (capture/oop_estimate.h) */
        rc = oop_estimate_run(oop_predict, (void *)model, oop_measure, &c, &r->out->oop.full, err);
    r->out->oop.rig_time_s = capture_clock_now(&clk);
    r->out->has_oop = rc == 0;
    capture_axis_stats_add(&dev, &r->out->mech);
    r->job->src->close(r->job->src->user, &dev);
    return rc;
}

/* The isotropy check after the capture's last point (capture_config
 * checks), on the rig's rotation axis; its rig time apart. */
static int check_isotropy(struct run *r, struct capture_devices *dev,
                          struct capture_clock *clk, struct gonio_err *err)
{
    if (!dev->rotation)
        return gonio_err_set(err, GONIO_EUSAGE, "--check isotropy: the rig source has no "
                             "rotation axis device");
    struct check_ctx c = {r, dev, clk};
    double t0 = capture_clock_now(clk);
    int rc = iso_check_run(r->samples, r->n, check_measure, &c, &r->out->isotropy, err);
    if (rc < 0)
        return rc;
    r->out->isotropy.rig_time_s = capture_clock_now(clk) - t0;
    r->out->has_isotropy = 1;
    return 0;
}

/* Measure every point the journal does not hold yet, from `first` on in
 * the order the sequence gives. Sets r->aborted when the host asked to
 * stop, r->converged when the streaming fit decided that further points
 * would not change the model, the summary's paused_s to the rig clock the
 * host held the capture paused. */
static int acquire(struct run *r, long first, struct gonio_err *err)
{
    const struct capture_job *job = r->job;
    const struct capture_hooks *hooks = r->hooks;
    size_t count = plan_count(job->plan);
    struct journal_sample *all = realloc(r->samples, (count ? count : 1) * sizeof *all);
    if (!all)
        return gonio_err_set(err, ENOMEM, "out of memory");
    r->samples = all;
    r->already = r->n;
    int rc = eta_new(job, hooks, r->seq, &r->ranging.ar, all, r->n, &r->eta, err);
    if (rc < 0)
        return rc;
    double rig_s = r->n > 0 ? all[r->n - 1].rig_time_s : 0;
    /* The first report (a host's start document) waits for the axes'
     * positions when there is a point to measure. */
    /* The standard still to be read again after the last point (a capture
     * resumed between the two) needs the devices too. */
    int after_due = job->cfg.reference_after && job->cal &&
                    reference_after_read(job->cfg.out_dir, job->cal, NULL, NULL, err) == 0;
    if ((rc = replay_journal(r, err)) < 0 || ((r->converged || first < 0) && !after_due)) {
        progress(hooks, job, r->eta, &r->fit, r->seq, r->n, r->already, rig_s);
        return rc;
    }
    struct capture_devices dev;
    struct rig_axes at;
    rc = open_devices(r, &dev, err);
    if (rc == 0 && dev.counts && /* the detector said so at open: before the first move */
        (rc = capture_calibration_check(&job->cfg, 1, job->src->detector, err)) < 0)
        job->src->close(job->src->user, &dev);
    else if (rc == 0 && ((rc = axes_now(&dev, &at, err)) < 0 ||
                         (rc = order_from(r, &at, &first, err)) < 0))
        job->src->close(job->src->user, &dev);
    else if (rc == 0 && r->eta)
        capture_eta_start(r->eta, &at);
    progress(hooks, job, r->eta, &r->fit, r->seq, r->n, r->already, rig_s);
    if (rc < 0) {
        r->aborted = rc == -ECANCELED; /* the host stopped it while the devices opened */
        return r->aborted ? 0 : rc;
    }
    struct capture_clock clk;
    capture_clock_start(&clk, dev.clock, rig_s);
    for (long k = r->converged ? -1 : first; k >= 0 && rc == 0;) {
        enum capture_control c = hooks->control ? hooks->control(hooks->user) : CAPTURE_GO;
        if (c == CAPTURE_ABORT) {
            capture_axes_stop(&dev);
            r->aborted = 1;
            break;
        }
        if (c == CAPTURE_PAUSED)
            capture_clock_paused(&clk);
        rc = measure_one(r, &dev, &clk, k, &k, err);
        if (rc == -ECANCELED) { /* the host's abort ended the point's waits: nothing journalled */
            r->aborted = 1;
            rc = 0;
            break;
        }
        if (rc > 0) {
            r->converged = 1;
            rc = 0;
            break;
        }
    }
    if (rc == 0 && !r->aborted && (r->job->cfg.checks & CAPTURE_CHECK_ISOTROPY))
        rc = check_isotropy(r, &dev, &clk, err);
    if (rc == 0 && !r->aborted && job->cfg.reference_after && job->cal && r->n > 0) {
        struct cal_frame *f = NULL;
        size_t nf = 0;
        rc = reference_after_measure(&dev, job->src, hooks, &job->rig, job->cfg.out_dir,
                                     job->cal, &f, &nf, &r->aborted, err);
        free(f);
    }
    r->out->paused_s = clk.paused;
    capture_axis_stats_add(&dev, &r->out->mech);
    job->src->close(job->src->user, &dev);
    return rc;
}

/* A calibrated capture ranges only where its calibration has a dark
 * frame at every rung of the ladder (gonio calibrate dark --ladder); else
 * it stays at the fixed integration, which every calibration covers. A
 * rung counts as covered by a dark within a microsecond of it: a device
 * takes its integration in whole microseconds (the Modbus register), and
 * the rung's readings, like the dark's, carry the integration it took. */
static void range_within(struct autorange *ar, const struct cal_loaded *cal)
{
    double ladder[AUTORANGE_RUNGS];
    size_t n = autorange_ladder(ar, ladder, AUTORANGE_RUNGS);
    for (size_t k = 0; k < n; k++) {
        size_t j = 0;
        while (j < cal->cal.n_darks &&
               !(cal->cal.darks[j].gain_state == cal->meta.gain_state &&
                 fabs(cal->cal.darks[j].integration_s - ladder[k]) <= 1e-6))
            j++;
        if (j == cal->cal.n_darks) {
            ar->min_s = ar->max_s = ar->fixed_s;
            return;
        }
    }
}

/* Prepare the directory (or take up a resumed one), open the journal and
 * the sequence after what it holds; *first: the first point to measure. */
static int open_capture(struct run *r, long *first, struct gonio_err *err)
{
    capture_job *job = r->job;
    const struct capture_rig *src = job->src;
    struct capture_setup setup = {
        .plan = job->plan,
        .rig = &job->rig,
        .source = src->setup_json,
        .material = job->material_name[0] ? job->material_name : NULL,
        .driver = src->driver ? src->driver : "unknown",
        .detector = src->detector ? src->detector : "unknown",
        .policy = job->adaptive ? &job->policy : NULL,
        .full_scale = src->counts_full_scale,
        .nonlinearity = src->counts_nonlinearity,
        .calibration = job->cal ? job->cal->meta.id : NULL,
        .sample = job->cfg.sample,
        .operator_name = job->cfg.operator_name,
        .note = job->cfg.note,
    };
    struct autorange ar;
    double ladder[AUTORANGE_RUNGS];
    autorange_init(&ar, &job->rig);
    if (job->cal)
        range_within(&ar, job->cal);
    if (src->counts) {
        setup.ladder = ladder;
        setup.n_ladder = autorange_ladder(&ar, ladder, AUTORANGE_RUNGS);
    }
    const char *dir = job->cfg.out_dir;
    /* A capture ordered from where it found the axes resumes in that order:
     * its journal's points are that order's. */
    struct rig_axes start;
    int rc = 0;
    if (capture_files_plan_start(dir, &start) &&
        (rc = plan_order_from(job->plan, plan_current_order(job->plan), &job->rig, &start)) < 0)
        return gonio_err_set(err, -rc, "ordering plan: %s", gonio_strerror(rc));
    rc = capture_files_prepare(dir, &setup, &r->lock_fd, err);
    if (rc < 0)
        return rc;
    char path[4096];
    snprintf(path, sizeof path, "%s/samples.csv", dir);
    if (!(r->j = journal_open(path, &r->samples, &r->n, err)))
        return -abs(err ? err->code : EIO);
    /* A resume trusts only records measured at their plan points. */
    struct journal_plan jp = {.plan = job->plan, .count = plan_count(job->plan)};
    if (r->n > 0 &&
        (rc = journal_plan_check(path, r->samples, r->n, &jp, job->rig.mech.in_position_deg,
                                 err)) < 0)
        return rc;
    /* Dark frames are the ranging's, not samples of the plan. */
    autorange_init(&r->ranging.ar, &job->rig);
    if (job->cal)
        range_within(&r->ranging.ar, job->cal);
    r->ranging.ar.full_scale = src->counts ? src->counts_full_scale : 0;
    r->ranging.j = r->j;
    size_t kept = 0;
    for (size_t i = 0; i < r->n; i++) {
        autorange_note(&r->ranging.ar, &r->samples[i]);
        if (!(r->samples[i].flags & JOURNAL_FLAG_DARK))
            r->samples[kept++] = r->samples[i];
    }
    r->n = kept;
    if (job->cfg.lazy_journal)
        journal_set_lazy(r->j);
    r->order = (struct sequence_setup){.plan = job->plan,
                                       .rig = &job->rig,
                                       .integration_s = job->integration_s,
                                       .opt = &job->policy,
                                       .prescan = job->prescan,
                                       .dir = dir};
    return sequence_new(&r->order, r->samples, r->n, &r->seq, first, err);
}

/* The figures of what was measured, from the journal, and why it stopped. */
static void summarize(const struct run *r, struct capture_summary *out)
{
    out->samples = r->n;
    out->darks = r->ranging.darks;
    out->retakes = r->ranging.ar.retakes;
    out->rig_time_s = r->n ? r->samples[r->n - 1].rig_time_s : 0;
    for (size_t i = 0; i < r->n; i++)
        out->integration_s += r->samples[i].integration_s;
    out->settle_s = (double)r->n * r->job->rig.settle_s;
    out->move_s = out->rig_time_s - out->settle_s - out->integration_s;
    snprintf(out->stop_reason, sizeof out->stop_reason, "%s",
             r->aborted            ? "aborted"
             : out->policy.stop[0] ? out->policy.stop
             : r->converged        ? "converged"
                                   : "complete");
}

/* The final fit of the capture's samples into *fitted (capture_fit_samples),
 * made again while --model auto's choice is judged insufficient by the
 * in-plane sufficiency check and a new choice checked in turn (fit_auto_settle,
 * which `gonio fit --model auto` replays from results.json). The summary
 * keeps the final choice's check, with the rig time of them all. */
struct final {
    struct run *r;
    const double *usys;
    brdf_material **fitted;
    struct oop_check_result seen[FIT_AUTO_MAX_CANDIDATES]; /* each check, in order, */
    char seen_model[FIT_AUTO_MAX_CANDIDATES][16];           /* of the model it judged */
    size_t n_seen;
};

static int final_fit(void *user, struct gonio_err *err)
{
    struct final *f = user;
    const capture_job *job = f->r->job;
    const struct live_fit *lf = &f->r->fit;
    brdf_material_free(*f->fitted);
    *f->fitted = NULL;
    int rc = capture_fit_samples(
        f->r->samples, f->r->n, lf->fs && !lf->progress ? fit_stream_params(lf->fs) : NULL,
        job->model, job->cfg.out_dir,
        job->material_name[0] ? job->material_name
        : job->truth_name[0]  ? job->truth_name
                              : NULL,
        job->adaptive, f->usys, f->r->out, f->fitted, err);
    if (rc == 0 && f->r->converged)
        f->r->out->converged = 1; /* the stop rule decided: the capture converged */
    return rc;
}

static int settle_check(void *user, const char *model, char *verdict, size_t len,
                        struct gonio_err *err)
{
    struct final *f = user; /* model: the one fitted last, *fitted */
    snprintf(f->seen_model[f->n_seen], sizeof *f->seen_model, "%s", model);
    int rc = check_out_of_plane(f->r, *f->fitted, err);
    f->seen[f->n_seen++] = f->r->out->oop;
    snprintf(verdict, len, "%s", rc < 0 ? "" : f->r->out->oop.verdict);
    return rc;
}

static int check_out_of_plane_chosen(struct final *f, struct gonio_err *err)
{
    struct capture_summary *out = f->r->out;
    if (!out->auto_chosen[0])
        return check_out_of_plane(f->r, *f->fitted, err);
    const struct fit_auto_steps steps = {final_fit, settle_check, f};
    int rc = fit_auto_settle(&out->auto_evidence, out->auto_chosen, out->auto_why,
                             sizeof out->auto_why, &steps, err);
    double spent = 0;
    for (size_t k = 0; k < f->n_seen; k++) {
        spent += f->seen[k].rig_time_s;
        if (!strcmp(f->seen_model[k], out->auto_chosen)) /* the final choice's */
            out->oop = f->seen[k];
    }
    out->oop.rig_time_s = spent;
    return rc;
}

/* The final fit and its errors, and results.json. The final fit starts
 * from the stop rule's last round; progress rounds do not steer it, so a
 * capture fits the same with or without them. abc-prior leaves what was
 * measured out of its prior. */
static int finish(struct run *r, struct gonio_err *err)
{
    const capture_job *job = r->job;
    struct capture_summary *out = r->out;
    brdf_material *fitted = NULL; /* the final fit, as a material */
    size_t valued = 0;
    for (size_t i = 0; i < r->n; i++)
        valued += journal_sample_has_brdf(&r->samples[i]);
    if (r->n > 0 && valued == 0) { /* --uncalibrated: counts, nothing to fit */
        snprintf(out->not_fitted, sizeof out->not_fitted,
                 "uncalibrated: the detector gave counts and no calibration reduced them "
                 "to BRDF (%zu samples of counts in samples.csv)", r->n);
        return capture_files_results(job->cfg.out_dir, out, err);
    }
    capture_phase_enter(r->hooks, CAPTURE_PHASE_FIT, -1);
    double usys[3] = {0}; /* the calibration's shared error, for fits weighted by u */
    struct journal_plan jp = {.plan = job->plan, .count = plan_count(job->plan)};
    if (job->cal)
        rad_systematic_rel_u(&job->cal->cal, usys);
    struct final f = {.r = r, .usys = job->cal ? usys : NULL, .fitted = &fitted};
    int rc = final_fit(&f, err);
    if (rc == 0 && (job->cfg.checks & CAPTURE_CHECK_OUT_OF_PLANE))
        rc = check_out_of_plane_chosen(&f, err);
    if (rc == 0 && job->truth)
        rc = capture_assess_truth(job->truth, fitted, job->cfg.assess_nodes, out, err);
    if (rc == 0)
        rc = capture_files_results(job->cfg.out_dir, out, err);
    if (rc == 0 && job->cal)
        rc = cal_results_budget(job->cal, &jp, r->samples, r->n, job->cfg.out_dir, err);
    brdf_material_free(fitted);
    return rc;
}

/* The capture's samples reduced again with the drift its standard read
 * again shows, the journal written again with them and opened anew for
 * what follows (a check's dark frames). */
static int drift_correct(struct run *r, struct gonio_err *err)
{
    capture_job *job = r->job;
    struct cal_frame *f = NULL;
    size_t nf = 0;
    char path[4200];
    snprintf(path, sizeof path, "%s/samples.csv", job->cfg.out_dir);
    int rc = reference_after_read(job->cfg.out_dir, job->cal, &f, &nf, err);
    if (rc == 0)
        rc = gonio_err_set(err, GONIO_EBADDATA, "%s/%s: the standard's readings after the "
                           "capture are not all there (%zu)", job->cfg.out_dir,
                           REFERENCE_AFTER_ID, nf);
    if (rc > 0)
        rc = reference_after_derive(job->cal, f, nf, r->samples[r->n - 1].rig_time_s, err);
    free(f);
    struct journal_plan jp = {.plan = job->plan, .count = plan_count(job->plan)};
    journal_close(r->j);
    r->j = NULL;
    if (rc == 0)
        rc = reference_after_apply(job->cal, &jp, path, r->samples, r->n, err);
    struct journal_sample *again = NULL;
    size_t n_again = 0;
    r->j = journal_open(path, &again, &n_again, rc == 0 ? err : NULL);
    free(again);
    r->ranging.j = r->j;
    return rc < 0 ? rc : r->j ? 0 : -abs(err ? err->code : EIO);
}

int capture_job_run(capture_job *job, const struct capture_hooks *hooks,
                    struct capture_summary *out, struct gonio_err *err)
{
    static const struct capture_hooks no_hooks;
    memset(out, 0, sizeof *out);
    if (job->ran)
        return gonio_err_set(err, GONIO_EUSAGE, "a prepared capture runs once");
    job->ran = 1;
    struct run r = {.job = job, .hooks = hooks ? hooks : &no_hooks, .out = out, .lock_fd = -1};
    snprintf(out->plan, sizeof out->plan, "%s", plan_name(job->plan));
    snprintf(out->material, sizeof out->material, "%s", job->material_name);
    snprintf(out->truth, sizeof out->truth, "%s", job->truth_name);
    snprintf(out->model, sizeof out->model, "%s", job->cfg.model);
    int rc = live_fit_new(&job->cfg, job->plan, &r.fit, err);
    if (rc < 0)
        return rc;
    /* Stopped before anything is written (an interrupt while planning):
     * an aborted capture with no files, not a half-made directory. */
    if (r.hooks->control && r.hooks->control(r.hooks->user) == CAPTURE_ABORT) {
        snprintf(out->stop_reason, sizeof out->stop_reason, "aborted");
        fit_stream_free(r.fit.fs);
        return 0;
    }
    if (job->cfg.reference_after && !job->src->mount && !r.hooks->ask)
        rc = gonio_err_set(err, GONIO_EUSAGE, "--reference-after: the rig has no sample "
                           "changer and nobody is asked to mount the standard (capture "
                           "through goniod)");
    if (rc < 0) {
        fit_stream_free(r.fit.fs);
        return rc;
    }
    long first = -1;
    rc = open_capture(&r, &first, err);
    if (rc == 0)
        rc = acquire(&r, first, err);
    if (rc == 0 && !r.aborted && job->cfg.reference_after && r.n > 0)
        rc = drift_correct(&r, err);
    capture_eta_free(r.eta);
    if (rc == 0 && !r.aborted)
        rc = sequence_summary(r.seq, &job->policy, out, err);
    if (out->adaptive && !strcmp(out->policy.stop, "converged"))
        r.converged = 1; /* the policy's convergence is the capture's */
    sequence_free(r.seq);
    if (rc == 0)
        summarize(&r, out);
    struct journal_plan jp = {.plan = job->plan, .count = plan_count(job->plan)};
    if (rc == 0 && !r.aborted && job->cal) /* a spectral detector's bands, whole */
        rc = capture_bands_reduce(job->cal, &jp, r.samples, r.n, job->cfg.out_dir, err);
    /* the journal stays open for the dark frames of a check after the fit */
    if (rc == 0 && !r.aborted && !job->cfg.measure_only)
        rc = finish(&r, err);
    journal_close(r.j);
    if (rc == 0 && !r.aborted)
        capture_phase_enter(r.hooks, CAPTURE_PHASE_BETWEEN, -1);
    capture_files_unlock(r.lock_fd);
    free(r.samples);
    fit_stream_free(r.fit.fs);
    return rc;
}

int capture_run(const struct capture_config *cfg, const struct capture_rig *rig,
                const struct capture_hooks *hooks, struct capture_summary *out,
                struct gonio_err *err)
{
    memset(out, 0, sizeof *out);
    capture_job *job;
    int rc = capture_prepare(cfg, rig, &job, err);
    if (rc == 0)
        rc = capture_job_run(job, hooks, out, err);
    capture_job_free(job);
    return rc;
}
