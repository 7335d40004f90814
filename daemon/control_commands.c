/* What each control command does (docs/protocol.md). A request's fields are
 * checked before it gets here, by control_request_parse (daemon/request.c,
 * the part the fuzzer reaches); this file keeps the handlers, whether each
 * needs the rig idle or busy, and the reply. */
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "brdf/material.h"
#include "common/paths.h"
#include "common/version.h"
#include "daemon/calibrations.h"
#include "daemon/captures.h"
#include "daemon/control_private.h"
#include "daemon/request.h"
#include "rig/rig.h"

enum need { NEED_ANY, NEED_IDLE, NEED_ACTIVE };

struct command {
    /* Fill reply (an OK document to send) or return an error (err set;
     * code names the error class). */
    int (*run)(control *c, struct control_client *cl, json_t *req, json_t *reply,
               const char **code, struct gonio_err *err);
    enum need need;
};

static const char *jstr(json_t *req, const char *key)
{
    return json_string_value(json_object_get(req, key));
}

/* On hardware the material is what the sample is, a spec results are
 * compared with, not a label: one that does not resolve is refused (the
 * simulator's is resolved by its own check). */
static int material_resolves(const char *spec, struct gonio_err *err)
{
    struct gonio_err why = {0};
    brdf_material *m = brdf_material_open(spec, &why);
    if (m) {
        brdf_material_free(m);
        return 0;
    }
    return gonio_err_set(err, GONIO_EUSAGE,
                         "material '%s' does not resolve (%s); on a hardware rig it names a "
                         "material spec, not a label",
                         spec, why.msg);
}

/* The request's check (docs/checks.md, capture/checks.h), only on a rig
 * whose profile has the axis it needs; refused here, before anything is
 * created, naming the rig as the request named it. */
static int check_option(const char *check, const char *rig_name, const char *rig_ref,
                        unsigned *checks, struct gonio_err *err)
{
    *checks = 0;
    if (!check)
        return 0;
    int rc = capture_checks_parse("check", check, checks, err);
    struct rig_profile rp;
    if (rc == 0)
        rc = rig_profile_load(rig_ref, &rp, err);
    if (rc == 0)
        rc = capture_checks_rig("check", *checks, &rp, rig_name, err);
    return rc;
}

/* The capture's id: the request's name, else a readable, sortable stamp and
 * the plan's name (a sent file's without its extension). */
static int capture_id(const control *c, json_t *req, const char *plan,
                      struct worker_request *r, struct gonio_err *err)
{
    const char *name = jstr(req, "name");
    if (name) {
        if (!control_valid_id(name))
            return gonio_err_set(err, GONIO_EUSAGE,
                                 "name '%s': a capture id is 1..100 letters, digits, '.', '_' "
                                 "or '-', not starting with '.' or '-'",
                                 name);
        snprintf(r->id, sizeof r->id, "%s", name);
        return 0;
    }
    char label[64];
    const char *slash = strrchr(plan, '/');
    snprintf(label, sizeof label, "%.40s", slash ? slash + 1 : plan);
    char *dot = strrchr(label, '.');
    if (dot && dot != label && (!strcmp(dot, ".yaml") || !strcmp(dot, ".yml")))
        *dot = 0;
    char stamp[32];
    time_t t = time(NULL);
    struct tm tm;
    gmtime_r(&t, &tm);
    strftime(stamp, sizeof stamp, "%Y%m%dT%H%M%SZ", &tm);
    char base[96];
    snprintf(base, sizeof base, "%s-%s", stamp, control_valid_id(label) ? label : "plan");
    snprintf(r->id, sizeof r->id, "%s", base);
    /* the suffix keeps two captures started in the same second apart */
    for (int k = 2; k < 1000; k++) {
        char probe[2304];
        struct stat st;
        snprintf(probe, sizeof probe, "%s/%s", c->cfg->capture_root, r->id);
        if (stat(probe, &st) != 0)
            break;
        snprintf(r->id, sizeof r->id, "%s-%d", base, k);
    }
    return 0;
}

/* The request's plan, scene, rig, materials, metadata and options into r,
 * checked as the engine will use them (worker_check): nothing is created
 * here. A file the request carried is read from its copy (sent). */
static int capture_inputs(control *c, json_t *req, const struct control_sent *sent,
                          struct worker_request *r, struct gonio_err *err)
{
    const char *plan = jstr(req, "plan"), *scene = jstr(req, "scene"),
               *rig = jstr(req, "rig"), *material = jstr(req, "material"),
               *model = jstr(req, "model"), *order = jstr(req, "order"),
               *stop = jstr(req, "stop"), *truth = jstr(req, "truth");
    const char *sent_plan = control_sent_path(sent, "plan"),
               *sent_rig = control_sent_path(sent, "rig"),
               *sent_scene = control_sent_path(sent, "scene");
    int rc;
    if (sent_plan)
        snprintf(r->plan, sizeof r->plan, "%s", sent_plan);
    else if ((rc = control_resolve_ref(c, "plan", plan, r->plan, sizeof r->plan, err)) < 0)
        return rc;
    if (sent_scene) {
        snprintf(r->scene, sizeof r->scene, "%s", sent_scene);
    } else if (scene) {
        if ((rc = control_resolve_ref(c, "scene", scene, r->scene, sizeof r->scene, err)) < 0)
            return rc;
    } else if (c->cfg->driver == GONIOD_DRIVER_SIM) {
        snprintf(r->scene, sizeof r->scene, "%s", c->cfg->scene);
    } /* hardware measures what it measures: no scene unless named */
    if (sent_rig) {
        snprintf(r->rig, sizeof r->rig, "%s", sent_rig);
    } else if (rig) {
        if ((rc = control_resolve_ref(c, "rig", rig, r->rig, sizeof r->rig, err)) < 0)
            return rc;
    } else {
        snprintf(r->rig, sizeof r->rig, "%s", c->cfg->rig);
    }
    if ((rc = goniod_config_rig_check(c->cfg, r->rig, err)) < 0)
        return rc;
    if ((rc = check_option(jstr(req, "check"), rig ? rig : c->cfg->rig, r->rig, &r->checks,
                           err)) < 0)
        return rc;
    if (material &&
        (rc = control_resolve_material(c, material, r->material, sizeof r->material, err)) < 0)
        return rc;
    if (material && c->cfg->driver != GONIOD_DRIVER_SIM &&
        (rc = material_resolves(r->material, err)) < 0)
        return rc;
    /* What the operator says of the capture: kept, never interpreted. */
    static const char *const meta_keys[] = {"sample", "operator", "note"};
    char *meta_out[] = {r->sample, r->operator_name, r->note};
    size_t meta_size[] = {sizeof r->sample, sizeof r->operator_name, sizeof r->note};
    for (int k = 0; k < 3; k++) {
        const char *v = jstr(req, meta_keys[k]);
        if (!v)
            continue;
        size_t len = strlen(v);
        int ctl = 0;
        for (size_t i = 0; i < len; i++)
            ctl |= (unsigned char)v[i] < 0x20 || v[i] == 0x7f;
        if (len >= meta_size[k] || ctl)
            return gonio_err_set(err, GONIO_EUSAGE,
                                 "%s '%.60s': at most %zu bytes of text without control "
                                 "characters",
                                 meta_keys[k], v, meta_size[k] - 1);
        memcpy(meta_out[k], v, len + 1);
    }
    if (truth && (rc = control_resolve_material(c, truth, r->truth, sizeof r->truth, err)) < 0)
        return rc;
    snprintf(r->model, sizeof r->model, "%s", model ? model : "abc");
    snprintf(r->order, sizeof r->order, "%s", order ? order : "");
    snprintf(r->stop, sizeof r->stop, "%s", stop ? stop : "");
    /* In range (daemon/request.c); whether the order takes them is the
     * engine's check. */
    r->budget_min = json_number_value(json_object_get(req, "budget"));
    r->stop_target = json_number_value(json_object_get(req, "stop_target"));
    r->uncalibrated = json_is_true(json_object_get(req, "uncalibrated"));
    r->reference_after = json_is_true(json_object_get(req, "reference_after"));
    const char *cal = jstr(req, "calibration");
    if (cal && (!control_valid_id(cal) || strlen(cal) >= sizeof r->calibration))
        return gonio_err_set(err, GONIO_EUSAGE, "calibration '%.60s': a calibration id (gonio "
                             "calibrate printed it) or newest", cal);
    snprintf(r->calibration, sizeof r->calibration, "%s", cal ? cal : "");
    json_t *prescan = json_object_get(req, "prescan");
    if (prescan && (rc = capture_prescan_option("prescan", json_integer_value(prescan),
                                                &r->prescan, err)) < 0)
        return rc;
    /* Everything the engine will read, resolved as it will resolve it,
     * before the OK: a bad request creates nothing. */
    return worker_check(c->w, r, err);
}

/* The capture's directory, created (or not: EEXIST) for the request. */
static int capture_mkdir(const control *c, const struct worker_request *r, const char **code,
                         struct gonio_err *err)
{
    int rc = gonio_mkdir_p(c->cfg->capture_root, err);
    if (rc < 0) {
        *code = "io";
        return rc;
    }
    if (mkdir(r->dir, 0755) == 0)
        return 0;
    *code = errno == EEXIST ? "exists" : "io";
    return gonio_err_set(err, errno == EEXIST ? GONIO_EUSAGE : errno,
                         errno == EEXIST
                             ? "capture '%s' exists; resume it or choose another name"
                             : "capture '%s': cannot create its directory",
                         r->id);
}

static int cmd_capture(control *c, struct control_client *cl, json_t *req, json_t *reply,
                       const char **code, struct gonio_err *err)
{
    (void)cl;
    struct worker_request r;
    memset(&r, 0, sizeof r);
    const char *plan = jstr(req, "plan");
    *code = "bad-value";
    if (!plan)
        return gonio_err_set(err, GONIO_EUSAGE, "capture: 'plan' is required");
    struct control_sent sent;
    int rc;
    if ((rc = control_sent_take(req, &sent, err)) < 0 ||
        (rc = capture_id(c, req, plan, &r, err)) < 0)
        return rc;
    snprintf(r.dir, sizeof r.dir, "%s/%s", c->cfg->capture_root, r.id);
    /* The files the request carries are checked where the capture will
     * read them: in its directory, which goes again if the check fails. */
    if (sent.n && (rc = capture_mkdir(c, &r, code, err)) < 0)
        return rc;
    if (sent.n && (rc = control_sent_write(&sent, r.dir, err)) < 0) {
        *code = rc == -GONIO_EUSAGE ? "bad-value" : "io";
        control_sent_discard(&sent, r.dir);
        rmdir(r.dir);
        return rc;
    }
    if ((rc = capture_inputs(c, req, &sent, &r, err)) < 0) {
        control_sent_rename(&sent, err);
        control_sent_discard(&sent, r.dir);
        if (sent.n)
            rmdir(r.dir);
        return rc;
    }
    if (!sent.n && (rc = capture_mkdir(c, &r, code, err)) < 0)
        return rc;
    if ((rc = control_save_request(&r, err)) < 0 || (rc = worker_start(c->w, &r, err)) < 0) {
        *code = "busy";
        control_sent_discard(&sent, r.dir);
        control_discard_request(&r);
        return rc;
    }
    fprintf(stderr, "goniod: capture %s started (plan %s)\n", r.id, plan);
    json_object_set_new(reply, "capture_id", json_string(r.id));
    json_object_set_new(reply, "dir", json_string(r.dir));
    return 0;
}

/* The current capture, else the last one: null before any. */
static json_t *capture_doc(const struct worker_status *st)
{
    if (!st->has_capture)
        return json_null();
    return json_pack("{s:s, s:s, s:s, s:o, s:I, s:I, s:o, s:o, s:o}", "capture_id", st->cap_id,
                     "kind", st->cap_kind,
                     "state", st->cap_state, "message",
                     st->cap_message[0] ? json_string(st->cap_message) : json_null(),
                     "points_done", (json_int_t)st->cap_done, "points_total",
                     (json_int_t)st->cap_total, "rig_time_s",
                     control_json_number(st->cap_rig_time_s), "estimate_s",
                     control_json_number(st->cap_estimate_s), "eta_s",
                     control_json_number(st->cap_eta_s));
}

static json_t *status_doc(control *c)
{
    struct worker_status st;
    worker_get_status(c->w, &st);
    static const char *const names[] = {"idle", "running", "paused"};
    json_t *d = json_object();
    json_object_set_new(d, "class", json_string("STATUS"));
    json_object_set_new(d, "state", json_string(names[st.state]));
    json_object_set_new(d, "release", json_string(gonio_version()));
    json_object_set_new(d, "capture_id", st.state == WORKER_IDLE ? json_null()
                                                                 : json_string(st.id));
    json_object_set_new(d, "points_done", json_integer((json_int_t)st.done));
    json_object_set_new(d, "points_total", json_integer((json_int_t)st.total));
    json_object_set_new(d, "rig_time_s", control_json_number(st.rig_time_s));
    if (st.has_fit)
        json_object_set_new(d, "fit_error",
                            json_pack("{s:s, s:o, s:o, s:I, s:o}", "capture_id", st.fit_id,
                                      "log_error", control_json_number(st.fit_log_error),
                                      "rel_rmse", control_json_number(st.fit_rel_rmse),
                                      "samples", (json_int_t)st.fit_samples, "status",
                                      st.fit_status[0] ? json_string(st.fit_status)
                                                       : json_null()));
    else
        json_object_set_new(d, "fit_error", json_null());
    json_object_set_new(d, "capture", capture_doc(&st));
    json_object_set_new(d, "bringup", st.bringup[0] ? json_string(st.bringup) : json_null());
    return d;
}

static int cmd_status(control *c, struct control_client *cl, json_t *req, json_t *reply,
                      const char **code, struct gonio_err *err)
{
    (void)cl, (void)req, (void)code, (void)err;
    json_t *d = status_doc(c);
    json_object_update(reply, d);
    json_decref(d);
    return 0;
}

static int cmd_watch(control *c, struct control_client *cl, json_t *req, json_t *reply,
                     const char **code, struct gonio_err *err)
{
    (void)c, (void)reply;
    /* The running capture's first documents follow the OK
     * (control_handle_line). */
    const char *format = jstr(req, "format");
    if (!format || !strcmp(format, "stream")) {
        cl->watching |= CONTROL_WATCH_STREAM;
        return 0;
    }
    if (strcmp(format, "event-model") != 0) {
        *code = "bad-value";
        return gonio_err_set(err, GONIO_EUSAGE,
                             "watch: field 'format' '%s': use stream or event-model", format);
    }
    cl->watching |= CONTROL_WATCH_EVENTS;
    return 0;
}

static int cmd_pause(control *c, struct control_client *cl, json_t *req, json_t *reply,
                     const char **code, struct gonio_err *err)
{
    (void)cl, (void)req, (void)reply;
    *code = "not-running";
    int rc = worker_pause(c->w, err);
    if (rc == 0)
        control_broadcast_state(c);
    return rc;
}

static int cmd_resume(control *c, struct control_client *cl, json_t *req, json_t *reply,
                      const char **code, struct gonio_err *err)
{
    (void)cl;
    const char *id = jstr(req, "capture_id");
    struct worker_status st;
    worker_get_status(c->w, &st);
    if (!id || (st.state != WORKER_IDLE && !strcmp(id, st.id))) {
        /* Resume the paused capture. */
        *code = "not-paused";
        int rc = worker_continue(c->w, err);
        if (rc == 0)
            control_broadcast_state(c);
        return rc;
    }
    *code = "bad-value";
    if (!control_valid_id(id))
        return gonio_err_set(err, GONIO_EUSAGE, "capture_id '%s': not a capture id", id);
    if (st.state != WORKER_IDLE) {
        *code = "busy";
        return gonio_err_set(err, GONIO_EUSAGE,
                             "capture '%s' is running; it must end before '%s' can resume",
                             st.id, id);
    }
    struct worker_request r;
    memset(&r, 0, sizeof r);
    snprintf(r.id, sizeof r.id, "%s", id);
    snprintf(r.dir, sizeof r.dir, "%s/%s", c->cfg->capture_root, id);
    struct stat cb;
    if (lstat(r.dir, &cb) != 0 && control_is_calibration(c, id))
        return control_resume_calibration(c, id, reply, code, err);
    /* lstat: a capture directory that is a symbolic link is no capture,
     * and neither is one holding a link goniod would write through. */
    struct stat sb;
    if (lstat(r.dir, &sb) != 0 || !S_ISDIR(sb.st_mode)) {
        *code = "not-found";
        return gonio_err_set(err, GONIO_ENOTFOUND, "no capture '%s' in %s", id,
                             c->cfg->capture_root);
    }
    const char *link = NULL;
    char name[256];
    if (control_dir_symlink(r.dir, name, sizeof name, &link) < 0 || link) {
        *code = "bad-value";
        return gonio_err_set(err, GONIO_EUSAGE,
                             "capture '%s': %s%s is a symbolic link or unreadable; goniod "
                             "does not write through links",
                             id, link ? "file " : "its directory", link ? name : "");
    }
    int rc = control_load_request(c, &r, err);
    if (rc < 0) {
        *code = "not-found";
        return rc;
    }
    *code = "bad-value";
    if ((rc = goniod_config_rig_check(c->cfg, r.rig, err)) < 0)
        return rc;
    /* A complete capture has nothing left to measure: resuming it would
     * only fit again and rewrite its results, which only refit asks for. */
    char ended[16];
    captures_end_state(r.dir, ended, sizeof ended);
    if (!strcmp(ended, "complete") && !json_is_true(json_object_get(req, "refit"))) {
        *code = "complete";
        return gonio_err_set(err, GONIO_EUSAGE,
                             "capture '%s' is complete; nothing was changed (a resume with "
                             "refit, gonio resume --refit, fits its samples again)",
                             id);
    }
    r.resume = 1;
    *code = "busy";
    if ((rc = worker_start(c->w, &r, err)) < 0)
        return rc;
    fprintf(stderr, "goniod: capture %s resumed\n", id);
    json_object_set_new(reply, "capture_id", json_string(id));
    json_object_set_new(reply, "dir", json_string(r.dir));
    return 0;
}

static int cmd_abort(control *c, struct control_client *cl, json_t *req, json_t *reply,
                     const char **code, struct gonio_err *err)
{
    (void)cl, (void)req;
    *code = "not-running";
    struct worker_status st;
    worker_get_status(c->w, &st);
    int rc = worker_abort(c->w, "aborted", err);
    if (rc == 0 && st.state == WORKER_IDLE) /* a bring-up command: its own reply says aborted */
        json_object_set_new(reply, "bringup", json_string(st.bringup));
    else if (rc == 0) /* what `resume` takes to continue it */
        json_object_set_new(reply, "capture_id", json_string(st.id));
    return rc;
}

static int cmd_list(control *c, struct control_client *cl, json_t *req, json_t *reply,
                    const char **code, struct gonio_err *err)
{
    (void)cl, (void)req;
    struct worker_status st;
    worker_get_status(c->w, &st);
    struct captures_live live = {
        .id = st.state == WORKER_IDLE ? NULL : st.id,
        .state = st.state == WORKER_PAUSED ? "paused" : "running",
        .done = st.done,
        .total = st.total,
        .rig_time_s = st.rig_time_s,
    };
    /* the run is a capture's or a calibration's: the other list has none */
    struct captures_live none = {0};
    int cal = live.id && st.cap_kind[0] && strcmp(st.cap_kind, "capture") != 0;
    json_t *list = captures_list(c->cfg->capture_root, cal ? &none : &live);
    json_t *cals = calibrations_list(c->cfg->calibration_root, cal ? &live : &none, time(NULL));
    if (!list || !cals) {
        json_decref(list);
        json_decref(cals);
        *code = "io";
        return gonio_err_set(err, ENOMEM, "out of memory");
    }
    json_object_set_new(reply, "captures", list);
    json_object_set_new(reply, "calibrations", cals);
    return 0;
}

static int cmd_shutdown(control *c, struct control_client *cl, json_t *req, json_t *reply,
                        const char **code, struct gonio_err *err)
{
    (void)cl, (void)req, (void)reply, (void)code, (void)err;
    c->shutdown = 1;
    return 0;
}

static int cmd_calibrate(control *c, struct control_client *cl, json_t *req, json_t *reply,
                         const char **code, struct gonio_err *err)
{
    (void)cl;
    return control_cmd_calibrate(c, req, reply, code, err);
}

/* bring-up: control_bringup.c */
#define BRINGUP_CMD(fn, op)                                                                  \
    static int fn(control *c, struct control_client *cl, json_t *req, json_t *reply,        \
                  const char **code, struct gonio_err *err)                                  \
    {                                                                                        \
        (void)reply;                                                                         \
        return control_cmd_bringup(c, op, req, code, err, cl);                               \
    }
BRINGUP_CMD(cmd_home, BRINGUP_HOME)
BRINGUP_CMD(cmd_move, BRINGUP_MOVE)
BRINGUP_CMD(cmd_where, BRINGUP_WHERE)
BRINGUP_CMD(cmd_limits, BRINGUP_LIMITS)

/* What each command does, indexed like request.c's table of names and
 * fields. */
static const struct command commands[CONTROL_CMD_COUNT] = {
    [CONTROL_CMD_CAPTURE] = {cmd_capture, NEED_IDLE},
    [CONTROL_CMD_STATUS] = {cmd_status, NEED_ANY},
    [CONTROL_CMD_WATCH] = {cmd_watch, NEED_ANY},
    [CONTROL_CMD_PAUSE] = {cmd_pause, NEED_ACTIVE},
    [CONTROL_CMD_RESUME] = {cmd_resume, NEED_ANY},
    [CONTROL_CMD_ABORT] = {cmd_abort, NEED_ACTIVE},
    [CONTROL_CMD_SHUTDOWN] = {cmd_shutdown, NEED_ANY},
    [CONTROL_CMD_HOME] = {cmd_home, NEED_IDLE},
    [CONTROL_CMD_MOVE] = {cmd_move, NEED_IDLE},
    [CONTROL_CMD_WHERE] = {cmd_where, NEED_IDLE},
    [CONTROL_CMD_LIMITS] = {cmd_limits, NEED_IDLE},
    [CONTROL_CMD_LIST] = {cmd_list, NEED_ANY},
    [CONTROL_CMD_CALIBRATE] = {cmd_calibrate, NEED_IDLE},
};

int control_handle_line(control *c, struct control_client *cl, const char *line, size_t len)
{
    struct control_request rq;
    const char *bad;
    char why[1024];
    if (control_request_parse(line, len, &rq, &bad, why, sizeof why) < 0) {
        control_send_error(cl, bad, rq.id, "%s", why);
        control_request_free(&rq);
        return 0;
    }
    const struct command *cmd = &commands[rq.cmd];
    json_t *req = rq.doc, *id = rq.id;
    const char *name = rq.name;
    struct worker_status st;
    worker_get_status(c->w, &st);
    if (cmd->need == NEED_IDLE && st.state != WORKER_IDLE) {
        control_send_error(cl, "busy", id,
                           "%s: capture '%s' is running; abort it or wait for it to finish",
                           name, st.id);
        control_request_free(&rq);
        return 1;
    }
    if (cmd->need == NEED_IDLE && st.bringup[0]) {
        control_send_error(cl, "busy", id, "%s: bring-up '%s' is running; wait for it to finish",
                           name, st.bringup);
        control_request_free(&rq);
        return 1;
    }
    if (cmd->need == NEED_ACTIVE && st.state == WORKER_IDLE &&
        !(cmd->run == cmd_abort && st.bringup[0])) {
        control_send_error(cl, "not-running", id, "%s: no capture is running", name);
        control_request_free(&rq);
        return 1;
    }
    json_t *reply = json_object();
    json_object_set_new(reply, "class", json_string("OK"));
    json_object_set_new(reply, "cmd", json_string(name));
    if (id)
        json_object_set(reply, "id", id);
    struct gonio_err err = {0};
    const char *code = "failed";
    int rc = cmd->run(c, cl, req, reply, &code, &err);
    if (rc < 0) {
        json_decref(reply);
        control_send_error(cl, code, id, "%s", err.msg[0] ? err.msg : gonio_strerror(rc));
    } else if (rc > 0) {
        json_decref(reply); /* answered later (bring-up) */
    } else {
        control_client_send(cl, reply);
        /* A watcher that subscribes mid-capture still gets the capture's
         * start and descriptor first. */
        if (cmd->run == cmd_watch) {
            const char *format = jstr(req, "format");
            if (format && !strcmp(format, "event-model"))
                control_events_greet(c, cl);
            else if (c->start_doc) {
                control_client_send_text(cl, c->start_doc);
                control_client_send_text(cl, c->descriptor_doc);
            }
        }
    }
    control_request_free(&rq);
    return 1;
}
