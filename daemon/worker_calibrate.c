/* A calibration measured by goniod on its rig (daemon/worker.h,
 * worker_calibrate): the engine's journalled run (capture/calibration.h)
 * on goniod's devices, in the worker's thread, steered and reported as a
 * capture is, with the operator asked through goniod's pause, or the
 * rig's sample changer swapping what sits in the sample's place. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "brdf/standard.h"
#include "capture/cal_documents.h"
#include "capture/calibration.h"
#include "daemon/captures.h"
#include "daemon/worker_private.h"

/* The detector a calibration is of: as the capture names it (request_rig
 * in worker.c), so that a capture finds its calibration. */
static void detector_name(const worker *w, sim_source *sim, char *out, size_t size)
{
    struct capture_rig crig = {0};
    if (sim)
        sim_source_rig(sim, &crig);
    snprintf(out, size, "%s",
             w->cfg->driver == GONIOD_DRIVER_SIM
                 ? (crig.detector ? crig.detector : "unknown")
             : w->cfg->detector == GONIOD_DETECTOR_USB ? "usb-spectrometer" : "modbus");
}

/* The in-process simulated rig of a sim-driver goniod: the configured
 * scene, measuring the standard for a reference and a light trap (nothing
 * mounted) for the stray light. NULL on any other. */
static sim_source *sim_rig(const worker *w, const struct worker_calibration *c,
                           struct gonio_err *err)
{
    if (w->cfg->driver != GONIOD_DRIVER_SIM)
        return NULL;
    char material[1100];
    snprintf(material, sizeof material, "standard:%s", c->standard);
    return sim_source_new(w->cfg->scene, c->kind == CAL_REFERENCE ? material
                                         : c->kind == CAL_STRAY   ? "trap"
                                                                  : NULL, c->rig, err);
}

/* The run's description, as calibration.json will have it. */
static void fill_meta(const worker *w, const struct worker_calibration *c,
                      const struct rig_profile *prof, sim_source *sim, struct cal_meta *m)
{
    memset(m, 0, sizeof *m);
    snprintf(m->id, sizeof m->id, "%s", c->id);
    m->kind = (enum cal_kind)c->kind;
    m->created = (time_t)c->created;
    m->valid_s = c->valid_s;
    snprintf(m->rig, sizeof m->rig, "%s", prof->name);
    detector_name(w, sim, m->detector, sizeof m->detector);
    /* control_calibrate.c held the standard to calibration.json's length */
    snprintf(m->standard, sizeof m->standard, "%.*s", (int)sizeof m->standard - 1,
             c->kind == CAL_REFERENCE ? c->standard : "");
    snprintf(m->dark, sizeof m->dark, "%s", c->kind != CAL_DARK ? c->dark : "");
    snprintf(m->stray, sizeof m->stray, "%s", c->kind == CAL_REFERENCE ? c->stray : "");
    m->integrations[m->n_integrations++] = prof->integration_s;
    if (c->kind == CAL_DARK && c->integration_s > 0)
        m->integrations[m->n_integrations++] = c->integration_s;
    if (c->kind == CAL_DARK && c->ladder)
        cal_add_ladder(m, prof);
    m->in_position_deg = prof->mech.in_position_deg;
    m->spot = c->underfilled ? RAD_SPOT_UNDERFILLED : RAD_SPOT_OVERFILLED;
}

int worker_calibrate_check(worker *w, struct worker_calibration *c, struct gonio_err *err)
{
    struct rig_profile prof;
    struct brdf_standard std;
    struct plan *plan = NULL;
    int rc = rig_profile_load(c->rig, &prof, err);
    if (rc < 0)
        return rc;
    struct gonio_err why = {0};
    if (c->kind == CAL_REFERENCE && brdf_standard_load(c->standard, &std, &why) < 0)
        return gonio_err_set(err, GONIO_EUSAGE, "standard '%s': %s", c->standard, why.msg);
    if (c->kind != CAL_DARK && (rc = plan_load(c->plan, &prof, &plan, err)) < 0)
        return rc;
    plan_free(plan);
    sim_source *sim = sim_rig(w, c, err);
    if (w->cfg->driver == GONIOD_DRIVER_SIM && !sim)
        return -abs(err && err->code ? err->code : EINVAL);
    /* what the calibration will be of, for its record and gonio list */
    snprintf(c->rig_name, sizeof c->rig_name, "%s", prof.name);
    detector_name(w, sim, c->detector, sizeof c->detector);
    sim_source_free(sim);
    if (c->kind == CAL_DARK)
        return 0;
    struct cal_need need = {.rig = prof.name, .detector = c->detector,
                            .integration_s = prof.integration_s, .gain_state = -1,
                            .now = time(NULL)};
    struct cal_meta dark;
    if ((rc = cal_select_dark(w->cfg->calibration_root, c->dark[0] ? c->dark : NULL, &need,
                              &dark, err)) < 0)
        return rc;
    snprintf(c->dark, sizeof c->dark, "%s", dark.id);
    struct cal_meta stray;
    if (c->kind == CAL_REFERENCE && c->stray[0] &&
        (rc = cal_select_stray(w->cfg->calibration_root, c->stray, c->dark, &need, &stray,
                               err)) < 0)
        return rc;
    if (c->kind == CAL_REFERENCE && c->stray[0])
        snprintf(c->stray, sizeof c->stray, "%s", stray.id);
    return 0;
}

/* The operator must act: goniod pauses with the instruction until
 * `gonio resume` (or an abort). */
enum capture_control worker_hook_ask(void *user, const char *instruction)
{
    worker *w = user;
    pthread_mutex_lock(&w->mu);
    snprintf(w->prompt, sizeof w->prompt, "%s", instruction);
    w->paused = 1;
    pthread_mutex_unlock(&w->mu);
    fprintf(stderr, "goniod: %s %s waits: %s\n", w->calibration[0] ? "calibration" : "capture",
            w->calibration[0] ? w->cal.id : w->req.id, instruction);
    struct worker_msg *m = calloc(1, sizeof *m);
    if (m) {
        m->kind = WORKER_MSG_PROMPT;
        worker_push_msg(w, m);
    }
    enum capture_control c = worker_hook_control(w);
    pthread_mutex_lock(&w->mu);
    w->prompt[0] = '\0';
    pthread_mutex_unlock(&w->mu);
    return c;
}

static void on_frame(void *user, size_t done, size_t total, double rig_time_s)
{
    worker *w = user;
    pthread_mutex_lock(&w->mu);
    w->done = done;
    w->total = total;
    if (isfinite(rig_time_s))
        w->rig_time_s = rig_time_s;
    pthread_mutex_unlock(&w->mu);
}

/* Measure on the rig: the devices opened, the run, the devices closed. */
static int measure(worker *w, const struct cal_run *run, sim_source *sim, int *aborted,
                   struct cal_frame **frames, size_t *n, struct gonio_err *err)
{
    struct capture_devices dev;
    struct capture_rig crig = {0};
    if (sim)
        sim_source_rig(sim, &crig);
    int rc = sim ? crig.open(crig.user, run->rig, run->root, &dev, err)
                 : worker_hook_open(w, run->rig, run->root, &dev, err);
    if (rc < 0)
        return rc;
    /* A rig with a sample changer swaps the standard or the light trap in
     * (the in-process simulated rig measures them as it was made). */
    int changer = !sim && w->cfg->slaves.sample_changer;
    struct cal_hooks hooks = {.control = worker_hook_control, .ask = worker_hook_ask,
                              .on_frame = on_frame, .user = w,
                              .mount = changer ? worker_hook_mount : NULL, .mount_user = w};
    pthread_mutex_lock(&w->mu);
    w->total = cal_run_total(run);
    pthread_mutex_unlock(&w->mu);
    rc = cal_run_measure(&dev, run, &hooks, frames, n, aborted, err);
    if (sim)
        crig.close(crig.user, &dev);
    else
        worker_hook_close(w, &dev);
    return rc;
}

/* Queue the stop and go idle, under one lock (as a capture's run does). */
static void finish(worker *w, int rc, int aborted, size_t n, double rig_time_s,
                   const struct gonio_err *err, char *documents)
{
    struct worker_msg_stop *m = calloc(1, sizeof *m);
    pthread_mutex_lock(&w->mu);
    const char *reason = rc < 0    ? "error"
                         : aborted ? (w->abort_reason[0] ? w->abort_reason : "aborted")
                                   : "complete";
    snprintf(w->end_state, sizeof w->end_state, "%s",
             rc < 0 ? "failed" : aborted ? "aborted" : "complete");
    snprintf(w->end_message, sizeof w->end_message, "%s", rc < 0 ? err->msg : "");
    if (m) {
        m->base.kind = WORKER_MSG_STOP;
        snprintf(m->id, sizeof m->id, "%s", w->cal.id);
        snprintf(m->dir, sizeof m->dir, "%s", w->cal.dir);
        snprintf(m->calibration, sizeof m->calibration, "%s", w->calibration);
        m->rc = rc;
        snprintf(m->reason, sizeof m->reason, "%s", reason);
        m->err = *err;
        m->summary.samples = n;
        m->summary.rig_time_s = rig_time_s;
        m->has_comm = w->has_comm;
        m->comm = w->comm;
        m->documents = documents;
        worker_enqueue_locked(w, &m->base);
    } else {
        free(documents);
    }
    w->running = 0;
    w->paused = 0;
    w->prompt[0] = '\0';
    pthread_mutex_unlock(&w->mu);
    if (m)
        worker_wake(w);
}

/* A run that stopped short records why in its directory, as a capture's
 * does (daemon/calibrations.h), before the stop is reported; a complete
 * one has its calibration.json. */
static void record_stop(worker *w, int rc, int aborted, const struct gonio_err *err)
{
    if (rc == 0 && !aborted)
        return;
    pthread_mutex_lock(&w->mu);
    char reason[32];
    snprintf(reason, sizeof reason, "%s",
             rc < 0 ? "error" : w->abort_reason[0] ? w->abort_reason : "aborted");
    pthread_mutex_unlock(&w->mu);
    struct captures_stop stop = {.state = rc < 0 ? "failed"
                                          : !strcmp(reason, "shutdown") ? "interrupted"
                                                                        : "aborted",
                                 .reason = reason, .message = rc < 0 ? err->msg : ""};
    struct gonio_err werr = {0};
    if (captures_record_stop(w->cal.dir, &stop, &werr) < 0)
        fprintf(stderr, "goniod: calibration %s: %s\n", w->cal.id, werr.msg);
}

static void *run_calibration(void *arg)
{
    worker *w = arg;
    const struct worker_calibration *c = &w->cal;
    struct gonio_err err = {0};
    /* until this run ends it runs or, if goniod dies, is interrupted */
    captures_clear_stop(c->dir);
    struct rig_profile prof;
    struct plan *plan = NULL;
    struct cal_frame *frames = NULL;
    size_t n = 0;
    int aborted = 0;
    w->has_comm = 0;
    int rc = rig_profile_load(c->rig, &prof, &err);
    if (rc == 0 && c->kind != CAL_DARK && (rc = plan_load(c->plan, &prof, &plan, &err)) > 0)
        rc = 0;
    sim_source *sim = rc == 0 ? sim_rig(w, c, &err) : NULL;
    if (rc == 0 && w->cfg->driver == GONIOD_DRIVER_SIM && !sim)
        rc = -abs(err.code ? err.code : EINVAL);
    struct cal_meta meta;
    double t_start = cal_documents_now();
    size_t total = 0;
    int described = rc == 0; /* meta says what the run is of */
    if (rc == 0) {
        fill_meta(w, c, &prof, sim, &meta);
        struct cal_run run = {.root = w->cfg->calibration_root, .meta = &meta, .rig = &prof,
                              .plan = plan, .per_point = c->per_point};
        total = cal_run_total(&run);
        rc = measure(w, &run, sim, &aborted, &frames, &n, &err);
    }
    if (rc == 0 && !aborted && n > 0) {
        meta.gain_state = frames[0].gain_state; /* what a capture must match */
        rc = cal_write(w->cfg->calibration_root, &meta, frames, n, &err);
    }
    if (rc < 0 && !err.msg[0])
        snprintf(err.msg, sizeof err.msg, "%s", gonio_strerror(rc));
    fprintf(stderr, "goniod: calibration %s %s: %zu frames%s%s\n", c->id,
            rc < 0 ? "failed" : aborted ? "stopped" : "complete", n, rc < 0 ? ": " : "",
            rc < 0 ? err.msg : "");
    record_stop(w, rc, aborted, &err);
    char *documents = described ? worker_calibration_documents(w, &meta, frames, n, total, rc,
                                                               aborted, &err, t_start)
                                : NULL;
    finish(w, rc, aborted, n, n ? frames[n - 1].rig_time_s : NAN, &err, documents);
    free(frames);
    plan_free(plan);
    sim_source_free(sim);
    return NULL;
}

int worker_calibrate(worker *w, const struct worker_calibration *c, struct gonio_err *err)
{
    int rc = worker_lock_idle(w, err);
    if (rc < 0)
        return rc;
    w->cal = *c;
    memset(&w->req, 0, sizeof w->req); /* status and abort name the calibration */
    snprintf(w->req.id, sizeof w->req.id, "%s", c->id);
    snprintf(w->req.dir, sizeof w->req.dir, "%s", c->dir);
    snprintf(w->calibration, sizeof w->calibration, "%s",
             cal_kind_name((enum cal_kind)c->kind));
    w->prompt[0] = '\0';
    worker_run_begin_locked(w);
    w->announced = 1; /* no capture start document */
    pthread_mutex_unlock(&w->mu);
    if ((rc = worker_spawn(w, run_calibration, "calibration", err)) < 0) {
        pthread_mutex_lock(&w->mu);
        w->running = 0;
        pthread_mutex_unlock(&w->mu);
    }
    return rc;
}
