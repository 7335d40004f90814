/* The capture stream watchers receive (docs/protocol.md): start and
 * descriptor when a capture begins, an event per sample, stop at its end.
 * The start and descriptor are kept while the capture runs, so a watcher
 * that subscribes late is told what it is watching. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "capture/capture_files.h"
#include "capture/verdicts.h"
#include "daemon/captures.h"
#include "daemon/control_private.h"
#include "fit/fit_status.h"
#include "rig/rig.h"

static json_t *string_or_null(const char *v)
{
    return v[0] ? json_string(v) : json_null();
}

static json_t *start_doc(const struct worker_msg_start *m)
{
    json_t *s = json_object();
    json_object_set_new(s, "class", json_string("start"));
    json_object_set_new(s, "capture_id", json_string(m->req.id));
    json_object_set_new(s, "dir", json_string(m->req.dir));
    json_object_set_new(s, "plan", json_string(m->plan_name));
    json_object_set_new(s, "scene", string_or_null(m->req.scene));
    json_object_set_new(s, "material", string_or_null(m->req.material));
    json_object_set_new(s, "truth", string_or_null(m->req.truth));
    json_object_set_new(s, "rig", json_string(m->req.rig));
    json_object_set_new(s, "model", json_string(m->req.model));
    json_object_set_new(s, "order", m->req.order[0] ? json_string(m->req.order) : json_null());
    json_object_set_new(s, "stop", m->req.stop[0] ? json_string(m->req.stop) : json_null());
    json_object_set_new(s, "budget", m->req.budget_min > 0 ? json_real(m->req.budget_min)
                                                           : json_null());
    json_object_set_new(s, "stop_target", m->req.stop_target > 0
                                              ? json_real(m->req.stop_target)
                                              : json_null());
    json_object_set_new(s, "resume", json_boolean(m->req.resume));
    json_object_set_new(s, "sample", string_or_null(m->req.sample));
    json_object_set_new(s, "operator", string_or_null(m->req.operator_name));
    json_object_set_new(s, "note", string_or_null(m->req.note));
    char checks[64];
    json_object_set_new(s, "check", m->req.checks ? json_string(capture_checks_text(
                                                        m->req.checks, checks, sizeof checks))
                                                  : json_null());
    json_object_set_new(s, "total", json_integer((json_int_t)m->total));
    json_object_set_new(s, "already_done", json_integer((json_int_t)m->already_done));
    json_object_set_new(s, "estimate_s", control_json_number(m->estimate_s));
    json_object_set_new(s, "prescan", json_integer((json_int_t)m->prescan));
    json_object_set_new(s, "adaptive", json_boolean(m->adaptive));
    json_object_set_new(s, "time", json_integer((json_int_t)time(NULL)));
    return s;
}

static json_t *sample_doc(const control *c, const struct worker_msg_sample *m)
{
    const struct journal_sample *s = &m->sample;
    json_t *d = json_object();
    json_object_set_new(d, "class", json_string("event"));
    json_object_set_new(d, "seq", json_integer((json_int_t)c->seq));
    json_object_set_new(d, "point", json_integer(s->point));
    json_object_set_new(d, "done", json_integer((json_int_t)m->done));
    json_object_set_new(d, "total", json_integer((json_int_t)m->total));
    json_object_set_new(d, "theta_i", control_json_number(s->theta_i));
    json_object_set_new(d, "theta_r", control_json_number(s->theta_r));
    json_object_set_new(d, "phi_i", control_json_number(s->phi_i));
    json_object_set_new(d, "theta_o", control_json_number(s->theta_o));
    json_object_set_new(d, "phi_o", control_json_number(s->phi_o));
    json_object_set_new(d, "s", control_json_number(s->s));
    json_object_set_new(d, "a", control_json_number(s->a));
    json_object_set_new(d, "rgb",
                        json_pack("[o,o,o]", control_json_number(s->rgb[0]),
                                  control_json_number(s->rgb[1]),
                                  control_json_number(s->rgb[2])));
    if (s->counts) { /* what the detector gave; rgb null until a calibration reduces it */
        json_object_set_new(d, "unit", json_string("counts"));
        json_object_set_new(d, "raw", json_pack("[o,o,o]", control_json_number(s->raw[0]),
                                                control_json_number(s->raw[1]),
                                                control_json_number(s->raw[2])));
        json_object_set_new(d, "integration_total_s",
                            control_json_number(s->integration_total_s));
    }
    json_object_set_new(d, "integration_s", control_json_number(s->integration_s));
    json_object_set_new(d, "rig_time_s", control_json_number(s->rig_time_s));
    json_object_set_new(d, "saturated", json_boolean(s->flags & JOURNAL_FLAG_SATURATED));
    json_object_set_new(d, "eta_s", control_json_number(m->eta_s));
    if (isfinite(m->fit_log_error))
        json_object_set_new(d, "fit_log_error", json_real(m->fit_log_error));
    if (isfinite(m->predicted)) { /* the adaptive order */
        json_object_set_new(d, "predicted_error", json_real(m->predicted));
        json_object_set_new(d, "predicted_next", control_json_number(m->predicted_next));
        json_object_set_new(d, "predicted_next_s", control_json_number(m->predicted_next_s));
    }
    return d;
}

static json_t *axis_doc(const struct rig_axis *a)
{
    return json_pack("{s:o, s:o, s:o, s:o}", "speed", control_json_number(a->speed), "accel",
                     control_json_number(a->accel), "min", control_json_number(a->min), "max",
                     control_json_number(a->max));
}

static json_t *descriptor_doc(const control *c, const struct worker_msg_start *m)
{
    const struct goniod_config *cfg = c->cfg;
    json_t *drv = json_object();
    json_object_set_new(drv, "kind", json_string(goniod_driver_name(cfg->driver)));
    if (cfg->driver == GONIOD_DRIVER_SIM) {
        json_object_set_new(drv, "scene", json_string(m->req.scene));
        json_object_set_new(drv, "pace_s", control_json_number(cfg->pace_s));
    } else {
        if (cfg->driver == GONIOD_DRIVER_MODBUS_RTU) {
            char parity[2] = {cfg->parity, 0};
            json_object_set_new(drv, "device", json_string(cfg->device));
            json_object_set_new(drv, "baud", json_integer(cfg->baud));
            json_object_set_new(drv, "parity", json_string(parity));
            json_object_set_new(drv, "data_bits", json_integer(cfg->data_bits));
            json_object_set_new(drv, "stop_bits", json_integer(cfg->stop_bits));
        } else {
            json_object_set_new(drv, "host", json_string(cfg->host));
            json_object_set_new(drv, "port", json_integer(cfg->port));
        }
        json_object_set_new(drv, "slaves",
                            json_pack("{s:i, s:i, s:i, s:i, s:i}", "sample", cfg->slaves.sample,
                                      "arm", cfg->slaves.arm, "azimuth", cfg->slaves.azimuth,
                                      "detector", cfg->slaves.detector, "rotation",
                                      cfg->slaves.rotation));
        json_object_set_new(drv, "steps_per_deg", control_json_number(cfg->steps_per_deg));
        json_object_set_new(drv, "time_scale", control_json_number(cfg->time_scale));
    }
    json_t *d = json_object();
    json_object_set_new(d, "class", json_string("descriptor"));
    json_object_set_new(d, "capture_id", json_string(m->req.id));
    json_object_set_new(d, "driver", drv);
    struct rig_profile rig;
    struct gonio_err err = {0};
    if (rig_profile_load(m->req.rig, &rig, &err) == 0) {
        json_t *r = json_object();
        json_object_set_new(r, "name", json_string(rig.name));
        json_object_set_new(r, "sample", axis_doc(&rig.sample));
        json_object_set_new(r, "arm", axis_doc(&rig.arm));
        if (rig.out_of_plane)
            json_object_set_new(r, "azimuth", axis_doc(&rig.azimuth));
        if (rig.has_rotation)
            json_object_set_new(r, "rotation", axis_doc(&rig.rotation));
        json_object_set_new(r, "out_of_plane", json_boolean(rig.out_of_plane));
        json_object_set_new(r, "blind_deg", control_json_number(rig.blind_deg));
        json_object_set_new(r, "settle_s", control_json_number(rig.settle_s));
        json_object_set_new(r, "integration_s", control_json_number(rig.integration_s));
        json_object_set_new(d, "rig", r);
    }
    return d;
}

static json_t *errors_doc(const struct brdf_errors *e)
{
    return json_pack("{s:o, s:o, s:I}", "log_error", control_json_number(e->log), "rel_rmse",
                     control_json_number(e->rel_rmse), "pairs", (json_int_t)e->n_used);
}

static json_t *stop_doc(const struct worker_msg_stop *m)
{
    const struct capture_summary *s = &m->summary;
    json_t *d = json_object();
    json_object_set_new(d, "class", json_string("stop"));
    json_object_set_new(d, "capture_id", json_string(m->id));
    json_object_set_new(d, "dir", json_string(m->dir));
    int aborted = !strcmp(m->reason, "aborted") || !strcmp(m->reason, "shutdown");
    json_object_set_new(d, "exit_status",
                        json_string(m->rc < 0 ? "fail" : aborted ? "abort" : "success"));
    json_object_set_new(d, "reason", json_string(m->reason));
    if (m->has_comm) /* the bus's exchanges: what the retries absorbed */
        json_object_set_new(
            d, "comm",
            json_pack("{s:I,s:I,s:I,s:I,s:I,s:I,s:I}", "requests", (json_int_t)m->comm.requests,
                      "retries", (json_int_t)m->comm.retries, "timeouts",
                      (json_int_t)m->comm.timeouts, "bad_replies",
                      (json_int_t)m->comm.bad_replies, "exceptions",
                      (json_int_t)m->comm.exceptions, "failed", (json_int_t)m->comm.failed,
                      "reconnects", (json_int_t)m->comm.reconnects));
    if (m->rc < 0) {
        json_t *msg = json_string(m->err.msg);
        json_object_set_new(d, "message", msg ? msg : json_string("(not UTF-8)"));
        return d;
    }
    if (m->calibration[0]) { /* a calibration's: what it measured */
        json_object_set_new(d, "calibration", json_pack("{s:s, s:I, s:o}", "kind",
                                                        m->calibration, "frames",
                                                        (json_int_t)s->samples, "rig_time_s",
                                                        control_json_number(s->rig_time_s)));
        return d;
    }
    json_object_set_new(d, "samples", json_integer((json_int_t)s->samples));
    json_object_set_new(d, "rig_time_s", control_json_number(s->rig_time_s));
    json_object_set_new(d, "paused_s", control_json_number(s->paused_s));
    if (!aborted) {
        const struct brdf_abc *p = &s->params;
        json_t *r = json_object();
        json_object_set_new(r, "plan", json_string(s->plan));
        json_t *mat = string_or_null(s->material), *truth = string_or_null(s->truth);
        json_object_set_new(r, "material", mat ? mat : json_null());
        json_object_set_new(r, "truth", truth ? truth : json_null());
        json_object_set_new(r, "model", json_string(s->model));
        json_object_set_new(r, "converged", json_boolean(s->converged));
        json_object_set_new(r, "fit_status",
                            json_string(fit_status_name(fit_status_code(&s->status))));
        json_object_set_new(r, "fit_time_s", control_json_number(s->fit_time_s));
        json_object_set_new(
            r, "params",
            !s->has_params
                ? json_null() /* not ABC: the parameters are in model_file */
                : json_pack("{s:[o,o,o], s:[o,o,o], s:o, s:o, s:o}", "kd",
                            control_json_number(p->kd[0]), control_json_number(p->kd[1]),
                            control_json_number(p->kd[2]), "A", control_json_number(p->A[0]),
                            control_json_number(p->A[1]), control_json_number(p->A[2]), "B",
                            control_json_number(p->B), "C", control_json_number(p->C), "eta",
                            control_json_number(p->eta)));
        json_object_set_new(r, "model_file",
                            s->model_file[0] ? json_string(s->model_file) : json_null());
        json_object_set_new(r, "err_plan", errors_doc(&s->err_plan));
        if (s->has_truth) {
            json_object_set_new(r, "err_inplane", errors_doc(&s->err_inplane));
            json_object_set_new(r, "err_full", errors_doc(&s->err_full));
        }
        if (s->adaptive) /* results.json has the rest */
            json_object_set_new(
                r, "adaptive",
                json_pack("{s:s, s:o, s:o, s:o}", "model", s->policy.model, "predicted_error",
                          control_json_number(s->policy.predicted_error), "decision_mean_s",
                          control_json_number(s->decision_mean_s), "decision_max_s",
                          control_json_number(s->decision_max_s)));
        json_object_set_new(d, "results", r);
        /* the premise checks' verdicts and auto's choice, as results.json has them */
        json_t *checks = capture_files_checks(s), *choice = capture_verdicts_auto(s);
        json_object_set_new(d, "checks", checks ? checks : json_object());
        json_object_set_new(d, "auto", choice ? choice : json_null());
    }
    return d;
}

void control_broadcast_state(control *c)
{
    struct worker_status st;
    worker_get_status(c->w, &st);
    if (st.state == WORKER_IDLE)
        return;
    json_t *doc = json_pack("{s:s, s:s, s:s}", "class", "state", "capture_id", st.id, "state",
                            st.state == WORKER_PAUSED ? "paused" : "running");
    /* a calibration waiting on the operator says for what */
    if (doc && st.state == WORKER_PAUSED && st.cap_message[0])
        json_object_set_new(doc, "message", json_string(st.cap_message));
    char *text = control_json_text(doc);
    if (text)
        control_broadcast(c, text);
    free(text);
}

void control_dispatch(control *c, struct worker_msg *msgs)
{
    for (struct worker_msg *m = msgs, *next; m; m = next) {
        next = m->next;
        json_t *doc = NULL;
        if (m->kind == WORKER_MSG_START) {
            const struct worker_msg_start *ms = (const struct worker_msg_start *)m;
            c->seq = 0;
            free(c->start_doc);
            free(c->descriptor_doc);
            c->start_doc = control_json_text(start_doc(ms));
            c->descriptor_doc = control_json_text(descriptor_doc(c, ms));
            if (c->start_doc)
                control_broadcast(c, c->start_doc);
            if (c->descriptor_doc)
                control_broadcast(c, c->descriptor_doc);
            control_events_start(c, ms);
        } else if (m->kind == WORKER_MSG_SAMPLE) {
            c->seq++;
            doc = sample_doc(c, (const struct worker_msg_sample *)m);
            control_events_sample(c, (const struct worker_msg_sample *)m);
        } else if (m->kind == WORKER_MSG_BRINGUP) {
            control_bringup_reply(c, (const struct worker_msg_bringup *)m);
        } else if (m->kind == WORKER_MSG_PROMPT) {
            control_broadcast_state(c);
        } else {
            const struct worker_msg_stop *ms = (const struct worker_msg_stop *)m;
            if (ms->rc < 0)
                fprintf(stderr, "goniod: capture %s failed: %s\n", ms->id, ms->err.msg);
            else
                fprintf(stderr, "goniod: capture %s stopped: %s, %zu samples\n", ms->id,
                        ms->reason, ms->summary.samples);
            if (ms->has_comm)
                fprintf(stderr, "goniod: capture %s: bus %ld requests, %ld retries (%ld "
                        "timeouts, %ld bad replies), %ld exceptions, %ld failed, %ld "
                        "reconnects\n", ms->id, ms->comm.requests, ms->comm.retries,
                        ms->comm.timeouts, ms->comm.bad_replies, ms->comm.exceptions,
                        ms->comm.failed, ms->comm.reconnects);
            doc = stop_doc(ms);
            if (!ms->calibration[0])
                control_events_stop(c, ms);
            else /* a calibration's run, whole, as it ended */
                control_events_lines(c, ms->documents);
            free(ms->documents);
            if (ms->discard_dir && captures_remove(ms->dir) < 0)
                fprintf(stderr, "goniod: capture %s: %s: cannot remove: %s\n", ms->id, ms->dir,
                        strerror(errno));
            free(c->start_doc);
            free(c->descriptor_doc);
            c->start_doc = c->descriptor_doc = NULL;
        }
        if (doc) {
            char *text = control_json_text(doc);
            if (text)
                control_broadcast(c, text);
            free(text);
        }
        free(m);
    }
    control_reap(c);
}
