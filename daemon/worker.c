#include "daemon/worker.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "brdf/metrics.h"
#include "daemon/captures.h"
#include "daemon/devices.h"
#include "daemon/worker_private.h"
#include "fit/fit_status.h"
#include "sim_source/sim_source.h"

#ifdef GONIO_TEST_HOOKS
/* The phase log and holds from the environment; none without it. A bad
 * GONIOD_PHASE_HOLD item is ignored: it is a test aid, not configuration. */
static void phase_debug_init(worker *w)
{
    const char *path = getenv("GONIOD_PHASE_LOG");
    w->phase_fd = path && *path ? open(path, O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644)
                                : -1;
    const char *hold = getenv("GONIOD_PHASE_HOLD"); /* "move=0.03,fit=0.02" */
    while (hold && *hold) {
        for (int p = CAPTURE_PHASE_MOVE; p <= CAPTURE_PHASE_FIT; p++) {
            const char *name = capture_phase_name((enum capture_phase)p);
            size_t len = strlen(name);
            if (!strncmp(hold, name, len) && hold[len] == '=') {
                double v = strtod(hold + len + 1, NULL);
                w->hold_s[p] = v > 0 && v <= 10 ? v : 0;
            }
        }
        hold = strchr(hold, ',');
        hold = hold ? hold + 1 : NULL;
    }
}

static void hook_on_phase(void *user, enum capture_phase phase, int point)
{
    worker *w = user;
    if (w->phase_fd >= 0) {
        /* One write() a line, no fsync: a SIGKILL keeps the page cache, and
         * the torture only ever kills the process. */
        char line[64];
        int n = snprintf(line, sizeof line, "%s %d\n", capture_phase_name(phase), point);
        ssize_t r = write(w->phase_fd, line, (size_t)n);
        (void)r;
    }
    if (w->hold_s[phase] > 0) {
        struct timespec ts = {.tv_sec = (time_t)w->hold_s[phase]};
        ts.tv_nsec = (long)((w->hold_s[phase] - (double)ts.tv_sec) * 1e9);
        while (nanosleep(&ts, &ts) < 0 && errno == EINTR)
            ;
    }
}
#endif

/* A round of the engine's streaming fit: the figures status and the
 * events show. */
static void hook_on_fit(void *user, const struct brdf_errors *e, size_t samples)
{
    worker *w = user;
    pthread_mutex_lock(&w->mu);
    w->has_fit = 1;
    w->fit_final = 0;
    snprintf(w->fit_id, sizeof w->fit_id, "%s", w->req.id);
    w->fit_log = e->log;
    w->fit_rmse = e->rel_rmse;
    w->fit_n = samples;
    pthread_mutex_unlock(&w->mu);
}

static void push(worker *w, struct worker_msg *m);

/* Where the capture stands, for status and the events: its ETA. The first
 * call of a run announces it (the start document carries the estimate). */
static void hook_on_progress(void *user, const struct capture_progress *p)
{
    worker *w = user;
    pthread_mutex_lock(&w->mu);
    w->done = p->done;
    w->total = p->total;
    /* The rig clock of every run so far: a resumed capture's first report
     * carries its journal's, which no sample of this run may ever update
     * (a capture the journal already holds whole). */
    if (isfinite(p->rig_time_s))
        w->rig_time_s = p->rig_time_s;
    w->estimate_s = p->estimate_s;
    w->eta_s = p->eta_s;
    const struct adaptive_status *a = p->policy;
    w->predicted[0] = a ? a->predicted_error : NAN;
    w->predicted[1] = a ? a->predicted_next : NAN;
    w->predicted[2] = a ? a->predicted_next_s : NAN;
    int announce = !w->announced;
    w->announced = 1;
    pthread_mutex_unlock(&w->mu);
    struct worker_msg_start *m = announce ? calloc(1, sizeof *m) : NULL;
    if (!m)
        return;
    m->base.kind = WORKER_MSG_START;
    m->req = w->req;
    snprintf(m->plan_name, sizeof m->plan_name, "%s", p->plan);
    m->total = p->total;
    m->already_done = p->already_done;
    m->estimate_s = p->estimate_s;
    m->adaptive = p->policy != NULL;
    m->prescan = p->prescan;
    push(w, &m->base);
}

/* Queue m for the loop; the caller holds w->mu. */
static void enqueue_locked(worker *w, struct worker_msg *m)
{
    m->next = NULL;
    if (w->tail)
        w->tail->next = m;
    else
        w->head = m;
    w->tail = m;
}

static void wake(worker *w)
{
    /* One byte is enough: the loop drains the whole queue. A full pipe
     * already means "wake up". */
    ssize_t n = write(w->pipe_wr, "x", 1);
    (void)n;
}

static void push(worker *w, struct worker_msg *m)
{
    pthread_mutex_lock(&w->mu);
    enqueue_locked(w, m);
    pthread_mutex_unlock(&w->mu);
    wake(w);
}

static void hook_on_sample(void *user, const struct journal_sample *s, size_t done,
                           size_t total)
{
    worker *w = user;
    pthread_mutex_lock(&w->mu);
    w->done = done;
    w->total = total;
    w->rig_time_s = s->rig_time_s;
    double fit_log = w->has_fit && !strcmp(w->fit_id, w->req.id) ? w->fit_log : NAN;
    double eta = w->eta_s;
    double predicted[3] = {w->predicted[0], w->predicted[1], w->predicted[2]};
    pthread_mutex_unlock(&w->mu);
    struct worker_msg_sample *m = calloc(1, sizeof *m);
    if (!m)
        return; /* a lost progress event; the journal has the sample */
    m->base.kind = WORKER_MSG_SAMPLE;
    m->sample = *s;
    m->done = done;
    m->total = total;
    m->fit_log_error = fit_log;
    m->eta_s = eta;
    m->predicted = predicted[0];
    m->predicted_next = predicted[1];
    m->predicted_next_s = predicted[2];
    push(w, &m->base);
}

/* At every point boundary: pace the simulator in wall time if asked (so a
 * simulated capture lasts long enough to be watched, paused or killed), and
 * block while paused, telling the engine so (its rig clock ran meanwhile).
 * An abort ends both waits at once. */
static enum capture_control hook_control(void *user)
{
    worker *w = user;
    pthread_mutex_lock(&w->mu);
    if (w->cfg->driver == GONIOD_DRIVER_SIM && w->cfg->pace_s > 0 && !w->abort) {
        struct timespec until;
        clock_gettime(CLOCK_MONOTONIC, &until);
        double t = (double)until.tv_nsec * 1e-9 + w->cfg->pace_s;
        until.tv_sec += (time_t)t;
        until.tv_nsec = (long)((t - (double)(time_t)t) * 1e9);
        while (!w->abort && pthread_cond_timedwait(&w->cv, &w->mu, &until) != ETIMEDOUT) {
        }
    }
    int held = 0;
    while (w->paused && !w->abort) {
        held = 1;
        pthread_cond_wait(&w->cv, &w->mu);
    }
    enum capture_control c = w->abort ? CAPTURE_ABORT : held ? CAPTURE_PAUSED : CAPTURE_GO;
    pthread_mutex_unlock(&w->mu);
    return c;
}

/* The drivers' cancel check, asked while they wait on the bus: an abort
 * (a client's, or SIGTERM's shutdown) ends the point under way, not only
 * the next point boundary. */
static int hook_cancelled(void *user)
{
    worker *w = user;
    pthread_mutex_lock(&w->mu);
    int abort = w->abort;
    pthread_mutex_unlock(&w->mu);
    return abort;
}

/* Every axis where the rig profile allows it before the first move: an
 * axis left beyond the limits (by an earlier rig profile, or by hand)
 * would otherwise be driven from where the profile says it cannot be. */
static int check_start(const struct rig_profile *rig, struct capture_devices *dev,
                       struct gonio_err *err)
{
    drv_axis *axes[] = {dev->sample, dev->arm, dev->azimuth, dev->rotation};
    const struct rig_axis *prof[] = {&rig->sample, &rig->arm, &rig->azimuth, &rig->rotation};
    for (int i = 0; i < 4; i++) {
        double at;
        if (!axes[i])
            continue;
        int rc = drv_axis_position(axes[i], &at, err);
        if (rc < 0)
            return rc;
        double slack = rig->mech.in_position_deg;
        if (at < prof[i]->min - slack || at > prof[i]->max + slack) {
            const char *name = drv_axis_name(axes[i]);
            return gonio_err_set(err, GONIO_EUNREACHABLE,
                                 "axis %s is at %.2f deg, outside rig profile '%s''s limits "
                                 "axes.%s %g..%g deg; bring it inside first: gonio home %s",
                                 name, at, rig->name, name, prof[i]->min, prof[i]->max, name);
        }
    }
    return 0;
}

static int hook_open(void *user, const struct rig_profile *rig, const char *dir,
                     struct capture_devices *dev, struct gonio_err *err)
{
    (void)dir;
    worker *w = user;
    int rc = goniod_devices_open(w->cfg, rig, hook_cancelled, w, dev, &w->bus, err);
    if (rc == 0 && (rc = check_start(rig, dev, err)) < 0) {
        goniod_devices_close(dev, w->bus);
        w->bus = NULL;
    }
    return rc;
}

static void hook_close(void *user, struct capture_devices *dev)
{
    worker *w = user;
    goniod_devices_stats(w->bus, &w->comm);
    w->has_comm = w->bus != NULL;
    goniod_devices_close(dev, w->bus);
    w->bus = NULL;
}

/* The rig's sample changer (capture_rig.mount) on the capture's bus. */
int worker_hook_mount(void *user, struct capture_devices *dev, enum capture_slot slot,
                      const char *standard, struct gonio_err *err)
{
    (void)dev, (void)standard; /* the changer holds one standard, whatever its name */
    worker *w = user;
    return goniod_devices_mount(w->cfg, w->bus, (int)slot, err);
}

/* The engine's configuration of a request, the same for the check before
 * the reply and for the run. */
static struct capture_config request_config(const worker *w, const struct worker_request *r)
{
    return (struct capture_config){
        .plan = r->plan,
        .material = r->material[0] ? r->material : NULL,
        .rig = r->rig[0] ? r->rig : NULL,
        .sample = r->sample,
        .operator_name = r->operator_name,
        .note = r->note,
        .truth = r->truth[0] ? r->truth : NULL,
        .model = r->model,
        .out_dir = r->dir,
        .order = r->order[0] ? r->order : NULL,
        .stop = r->stop[0] ? r->stop : NULL,
        .budget_min = r->budget_min,
        .stop_target = r->stop_target,
        .prescan = r->prescan,
        .uncalibrated = r->uncalibrated,
        .reference_after = r->reference_after,
        .calibrations = r->calibration[0] ? w->cfg->calibration_root : NULL,
        .calibration = r->calibration[0] && strcmp(r->calibration, "newest") ? r->calibration
                                                                             : NULL,
        .checks = r->checks,
        .quiet = 1,
        .assess_nodes = (size_t)w->cfg->assess_nodes,
        .progress_fit = 1,
    };
}

/* The rig source of a request: with the sim driver the in-process
 * simulator of its scene and material (*sim, which the caller frees);
 * otherwise the configured devices, described in setup.json by the
 * request's scene when it names one (the Modbus simulator's). */
static int request_rig(worker *w, const struct worker_request *r, sim_source **sim,
                       struct capture_rig *rig, struct gonio_err *err)
{
    const char *scene = r->scene[0] ? r->scene : NULL;
    *sim = NULL;
    memset(rig, 0, sizeof *rig);
    if (w->cfg->driver == GONIOD_DRIVER_SIM) {
        if (!(*sim = sim_source_new(scene, r->material[0] ? r->material : NULL,
                                    r->rig[0] ? r->rig : NULL, err)))
            return -abs(err ? err->code : ENOMEM);
        sim_source_rig(*sim, rig);
        rig->driver = goniod_driver_name(w->cfg->driver);
        return 0;
    }
    if (scene) {
        if (!(*sim = sim_source_describe(scene, err)))
            return -abs(err ? err->code : ENOMEM);
        sim_source_rig(*sim, rig);
    }
    rig->open = hook_open;
    rig->close = hook_close;
    rig->driver = goniod_driver_name(w->cfg->driver);
    rig->detector = w->cfg->detector == GONIOD_DETECTOR_USB ? "usb-spectrometer" : "modbus";
    rig->mount = w->cfg->slaves.sample_changer ? worker_hook_mount : NULL;
    rig->user = w;
    return 0;
}

static void prepared_free(struct prepared *p)
{
    if (!p)
        return;
    capture_job_free(p->job);
    sim_source_free(p->sim);
    free(p);
}

/* The capture of req on its rig source, prepared (capture_prepare). */
static int prepare(worker *w, const struct worker_request *req, struct prepared **out,
                   struct gonio_err *err)
{
    *out = NULL;
    struct prepared *p = calloc(1, sizeof *p);
    if (!p)
        return gonio_err_set(err, ENOMEM, "out of memory");
    snprintf(p->id, sizeof p->id, "%s", req->id);
    snprintf(p->dir, sizeof p->dir, "%s", req->dir);
    struct capture_config cc = request_config(w, req);
    int rc = request_rig(w, req, &p->sim, &p->rig, err);
    if (rc == 0)
        rc = capture_prepare(&cc, &p->rig, &p->job, err);
    if (rc < 0) {
        prepared_free(p);
        return rc;
    }
    *out = p;
    return 0;
}

int worker_check(worker *w, const struct worker_request *req, struct gonio_err *err)
{
    prepared_free(w->pending);
    w->pending = NULL;
    return prepare(w, req, &w->pending, err);
}

/* The run's end in the capture directory (daemon/captures.h), written
 * before the stop is reported, so a list never shows a finished capture as
 * interrupted. A shutdown interrupted the capture; the operator did not
 * abort it. */
static void record_stop(worker *w, int rc, const char *reason, const struct gonio_err *err,
                        const struct capture_summary *sum)
{
    const char *state = rc < 0                       ? "failed"
                        : !strcmp(reason, "shutdown") ? "interrupted"
                        : !strcmp(reason, "aborted")  ? "aborted"
                                                      : "complete";
    struct captures_stop stop = {.state = state, .reason = reason,
                                 .message = rc < 0 ? err->msg : "",
                                 .summary = rc < 0 ? NULL : sum};
    struct gonio_err werr = {0};
    if (captures_record_stop(w->req.dir, &stop, &werr) < 0)
        fprintf(stderr, "goniod: capture %s: %s\n", w->req.id, werr.msg);
}

/* The failure's message says the directory goes with it. */
static void discard_note(struct gonio_err *err)
{
    char msg[GONIO_ERR_MSG_MAX];
    snprintf(msg, sizeof msg, "%s", err->msg);
    gonio_err_set(err, err->code, "%s (nothing was measured: the capture's directory is "
                  "removed)", msg);
}

static void *run(void *arg)
{
    worker *w = arg;
    struct worker_msg_stop *m = calloc(1, sizeof *m);
    struct capture_summary sum;
    struct gonio_err err = {0};
    struct capture_hooks hooks = {
        .on_sample = hook_on_sample,
        .control = hook_control,
        .on_fit = hook_on_fit,
        .on_progress = hook_on_progress,
        .ask = worker_hook_ask,
#ifdef GONIO_TEST_HOOKS
        .on_phase = hook_on_phase,
#endif
        .user = w,
    };
    w->has_comm = 0;
    memset(&sum, 0, sizeof sum);
    /* Until this run ends, the capture is running or, if goniod dies,
     * interrupted: no earlier run's end record stands. */
    captures_clear_stop(w->req.dir);
    /* A resume was not checked first: it is prepared here. */
    int rc = w->current ? 0 : prepare(w, &w->req, &w->current, &err);
    if (rc == 0)
        rc = capture_job_run(w->current->job, &hooks, &sum, &err);
    prepared_free(w->current);
    w->current = NULL;
    if (rc < 0 && !err.msg[0])
        snprintf(err.msg, sizeof err.msg, "%s", gonio_strerror(rc));

    pthread_mutex_lock(&w->mu);
    /* A new capture that failed before its first sample (a rig that did
     * not answer) measured nothing: its directory goes, so the same
     * request can be sent again once the rig is fixed. */
    int discard = rc < 0 && !w->req.resume && w->done == 0;
    if (discard)
        discard_note(&err);
    /* The engine says complete, converged or aborted; an abort names who
     * asked for it (a client, or the daemon shutting down). */
    int aborted = rc == 0 && !strcmp(sum.stop_reason, "aborted");
    const char *reason = rc < 0    ? "error"
                         : aborted ? (w->abort_reason[0] ? w->abort_reason : "aborted")
                                   : sum.stop_reason;
    if (rc == 0 && !aborted) {
        w->has_fit = w->done_fit.has = w->fit_final = 1;
        snprintf(w->fit_id, sizeof w->fit_id, "%s", w->req.id);
        snprintf(w->done_fit.id, sizeof w->done_fit.id, "%s", w->req.id);
        w->fit_log = w->done_fit.log = sum.err_plan.log;
        w->fit_rmse = w->done_fit.rmse = sum.err_plan.rel_rmse;
        w->fit_n = w->done_fit.n = sum.samples;
        snprintf(w->done_fit.status, sizeof w->done_fit.status, "%s",
                 fit_status_name(fit_status_code(&sum.status)));
    } else {
        /* the stopped capture's streaming fit goes with it */
        w->has_fit = w->fit_final = w->done_fit.has;
        snprintf(w->fit_id, sizeof w->fit_id, "%s", w->done_fit.id);
        w->fit_log = w->done_fit.log;
        w->fit_rmse = w->done_fit.rmse;
        w->fit_n = w->done_fit.n;
    }
    snprintf(w->end_state, sizeof w->end_state, "%s",
             rc < 0 ? "failed" : aborted ? "aborted" : "complete");
    snprintf(w->end_message, sizeof w->end_message, "%s", rc < 0 ? err.msg : "");
    if (rc == 0 && !aborted)
        w->eta_s = 0;
    if (!discard)
        record_stop(w, rc, reason, &err, &sum);
    /* The stop is queued as the worker goes idle, under one lock: a loop
     * that sees it idle (goniod shutting down) finds the stop to send. */
    if (m) {
        m->base.kind = WORKER_MSG_STOP;
        snprintf(m->id, sizeof m->id, "%s", w->req.id);
        snprintf(m->dir, sizeof m->dir, "%s", w->req.dir);
        m->rc = rc;
        snprintf(m->reason, sizeof m->reason, "%s", reason);
        m->err = err;
        m->summary = sum;
        m->has_comm = w->has_comm;
        m->comm = w->comm;
        m->discard_dir = discard;
        enqueue_locked(w, &m->base);
    }
    w->running = 0;
    w->paused = 0;
    pthread_mutex_unlock(&w->mu);
    if (m)
        wake(w);
    return NULL;
}

worker *worker_new(const struct goniod_config *cfg, struct gonio_err *err)
{
    worker *w = calloc(1, sizeof *w);
    int fds[2];
    if (!w)
        goto oom;
    if (pipe(fds) < 0) {
        free(w);
        return gonio_err_set(err, errno, "wake-up pipe: %s", strerror(errno)), NULL;
    }
    for (int i = 0; i < 2; i++) {
        fcntl(fds[i], F_SETFL, O_NONBLOCK);
        fcntl(fds[i], F_SETFD, FD_CLOEXEC);
    }
    w->pipe_rd = fds[0];
    w->pipe_wr = fds[1];
    w->cfg = cfg;
#ifdef GONIO_TEST_HOOKS
    phase_debug_init(w);
#endif
    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
    pthread_cond_init(&w->cv, &ca);
    pthread_condattr_destroy(&ca);
    pthread_mutex_init(&w->mu, NULL);
    return w;
oom:
    gonio_err_set(err, ENOMEM, "out of memory");
    return NULL;
}

static void join_if_finished(worker *w)
{
    pthread_mutex_lock(&w->mu);
    int join = w->thread_live && !w->running && !w->bringup_active;
    pthread_mutex_unlock(&w->mu);
    if (join) {
        pthread_join(w->thread, NULL);
        w->thread_live = 0;
    }
}

/* One thread at a time runs on the rig (a capture, a bring-up command or
 * a calibration): lock the worker for the next one. 0 with the lock held,
 * or -GONIO_EUSAGE, the lock released, naming what runs now. */
int worker_lock_idle(worker *w, struct gonio_err *err)
{
    join_if_finished(w);
    pthread_mutex_lock(&w->mu);
    if (!w->running && !w->thread_live)
        return 0;
    int rc = w->bringup_active
                 ? gonio_err_set(err, GONIO_EUSAGE, "bring-up '%s %s' is running; wait for it "
                                 "to finish", bringup_op_name(w->bringup.op), w->bringup.axis)
                 : gonio_err_set(err, GONIO_EUSAGE, "%s '%s' is running; abort it or wait for "
                                 "it to finish", w->calibration[0] ? "calibration" : "capture",
                                 w->req.id);
    pthread_mutex_unlock(&w->mu);
    return rc;
}

void worker_run_begin_locked(worker *w)
{
    w->running = 1;
    w->paused = w->abort = 0;
    w->abort_reason[0] = '\0';
    w->done = w->total = 0;
    w->rig_time_s = 0;
    w->estimate_s = w->eta_s = NAN;
    w->has_capture = 1;
    w->end_state[0] = w->end_message[0] = '\0';
}

/* Run body on the worker's thread, its state set under worker_lock_idle's
 * lock (released by now); on failure the caller puts the state back. */
int worker_spawn(worker *w, void *(*body)(void *), const char *what, struct gonio_err *err)
{
    int rc = pthread_create(&w->thread, NULL, body, w);
    if (rc != 0)
        return gonio_err_set(err, rc, "%s thread: %s", what, strerror(rc));
    w->thread_live = 1;
    return 0;
}

void worker_free(worker *w)
{
    if (!w)
        return;
    if (w->thread_live) {
        worker_abort(w, "shutdown", NULL);
        pthread_mutex_lock(&w->mu);
        w->abort = 1; /* a bring-up command's waits end too */
        pthread_mutex_unlock(&w->mu);
        pthread_join(w->thread, NULL);
    }
    for (struct worker_msg *m = w->head, *next; m; m = next) {
        next = m->next;
        if (m->kind == WORKER_MSG_STOP)
            free(((struct worker_msg_stop *)m)->documents);
        free(m);
    }
    prepared_free(w->pending);
#ifdef GONIO_TEST_HOOKS
    if (w->phase_fd >= 0)
        close(w->phase_fd);
#endif
    close(w->pipe_rd);
    close(w->pipe_wr);
    pthread_cond_destroy(&w->cv);
    pthread_mutex_destroy(&w->mu);
    free(w);
}

int worker_wake_fd(const worker *w)
{
    return w->pipe_rd;
}

int worker_start(worker *w, const struct worker_request *req, struct gonio_err *err)
{
    int rc = worker_lock_idle(w, err);
    if (rc < 0)
        return rc;
    w->req = *req;
    /* The capture worker_check prepared for this request, if it did. */
    struct prepared *p = w->pending;
    w->pending = NULL;
    if (p && (strcmp(p->id, req->id) || strcmp(p->dir, req->dir))) {
        prepared_free(p);
        p = NULL;
    }
    w->current = p;
    worker_run_begin_locked(w);
    w->announced = 0;
    w->calibration[0] = w->prompt[0] = '\0';
    pthread_mutex_unlock(&w->mu);
    if ((rc = worker_spawn(w, run, "capture", err)) < 0) {
        pthread_mutex_lock(&w->mu);
        w->running = 0;
        prepared_free(w->current);
        w->current = NULL;
        pthread_mutex_unlock(&w->mu);
    }
    return rc;
}

static int steer(worker *w, int what, const char *reason, struct gonio_err *err)
{
    pthread_mutex_lock(&w->mu);
    int rc = 0;
    if (what == 2 && !w->running && w->bringup_active)
        w->abort = 1; /* bringup_run stops the axes and reports aborted */
    else if (!w->running)
        rc = gonio_err_set(err, GONIO_EUSAGE, "no capture is running");
    else if (what == 0 && w->paused)
        rc = gonio_err_set(err, GONIO_EUSAGE, "capture '%s' is already paused", w->req.id);
    else if (what == 1 && !w->paused)
        rc = gonio_err_set(err, GONIO_EUSAGE, "capture '%s' is not paused", w->req.id);
    else if (what == 0)
        w->paused = 1;
    else if (what == 1)
        w->paused = 0;
    else if (!w->abort) {
        w->abort = 1;
        snprintf(w->abort_reason, sizeof w->abort_reason, "%s", reason);
    }
    pthread_cond_broadcast(&w->cv);
    pthread_mutex_unlock(&w->mu);
    return rc;
}

int worker_pause(worker *w, struct gonio_err *err)
{
    return steer(w, 0, NULL, err);
}

int worker_continue(worker *w, struct gonio_err *err)
{
    return steer(w, 1, NULL, err);
}

int worker_abort(worker *w, const char *reason, struct gonio_err *err)
{
    return steer(w, 2, reason, err);
}

void worker_get_status(worker *w, struct worker_status *st)
{
    memset(st, 0, sizeof *st);
    pthread_mutex_lock(&w->mu);
    st->state = !w->running ? WORKER_IDLE : w->paused ? WORKER_PAUSED : WORKER_RUNNING;
    if (w->running) {
        snprintf(st->id, sizeof st->id, "%s", w->req.id);
        st->done = w->done;
        st->total = w->total;
        st->rig_time_s = w->rig_time_s;
    }
    if ((st->has_capture = w->has_capture)) {
        snprintf(st->cap_id, sizeof st->cap_id, "%s", w->req.id);
        snprintf(st->cap_state, sizeof st->cap_state, "%s",
                 w->running ? (w->paused ? "paused" : "running") : w->end_state);
        snprintf(st->cap_message, sizeof st->cap_message, "%s",
                 w->running && w->prompt[0] ? w->prompt : w->end_message);
        snprintf(st->cap_kind, sizeof st->cap_kind, "%s",
                 w->calibration[0] ? w->calibration : "capture");
        st->cap_done = w->done;
        st->cap_total = w->total;
        st->cap_rig_time_s = w->rig_time_s;
        st->cap_estimate_s = w->estimate_s;
        st->cap_eta_s = w->eta_s;
    }
    st->has_fit = w->has_fit;
    snprintf(st->fit_id, sizeof st->fit_id, "%s", w->fit_id);
    st->fit_log_error = w->fit_log;
    st->fit_rel_rmse = w->fit_rmse;
    st->fit_samples = w->fit_n;
    if (w->bringup_active)
        snprintf(st->bringup, sizeof st->bringup, "%s%s%s", bringup_op_name(w->bringup.op),
                 w->bringup.axis[0] ? " " : "", w->bringup.axis);
    /* The verdict goes with the final fit's figures, not a streaming fit's. */
    if (w->fit_final)
        snprintf(st->fit_status, sizeof st->fit_status, "%s", w->done_fit.status);
    pthread_mutex_unlock(&w->mu);
}

struct worker_msg *worker_take(worker *w)
{
    char buf[256];
    while (read(w->pipe_rd, buf, sizeof buf) > 0) {
    }
    pthread_mutex_lock(&w->mu);
    struct worker_msg *m = w->head;
    w->head = w->tail = NULL;
    pthread_mutex_unlock(&w->mu);
    for (struct worker_msg *p = m; p; p = p->next)
        if (p->kind == WORKER_MSG_STOP || p->kind == WORKER_MSG_BRINGUP)
            join_if_finished(w);
    return m;
}

/* ---- for the calibration run and bring-up (daemon/worker_calibrate.c,
 * daemon/worker_bringup.c) ---------------------------------------------- */

void worker_push_msg(worker *w, struct worker_msg *m)
{
    push(w, m);
}

void worker_enqueue_locked(worker *w, struct worker_msg *m)
{
    enqueue_locked(w, m);
}

void worker_wake(worker *w)
{
    wake(w);
}

enum capture_control worker_hook_control(void *user)
{
    return hook_control(user);
}

int worker_hook_open(void *user, const struct rig_profile *rig, const char *dir,
                     struct capture_devices *dev, struct gonio_err *err)
{
    return hook_open(user, rig, dir, dev, err);
}

void worker_hook_close(void *user, struct capture_devices *dev)
{
    hook_close(user, dev);
}

int worker_hook_cancelled(void *user)
{
    return hook_cancelled(user);
}
