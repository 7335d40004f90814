/* A capture run as Bluesky event-model documents (docs/protocol.md, "Event-model
 * documents"): [name, doc] pairs as Bluesky's callbacks take them, for
 * watchers that asked for them (watch with format event-model), so that a
 * facility's callbacks, databroker or Tiled can take goniod's runs.
 *
 * One run per capture run (a resume is a new run that names the one it
 * continues): run_start, the primary stream's descriptor (a data key for
 * every field of an event, the rig and driver configuration in its
 * configuration), an event per sample, the fit stream's descriptor and its
 * one event when the run ends with a fit, run_stop. The uid of each run is
 * appended to the capture directory's run-uids.txt, which is how the next
 * run of that directory knows what it continues. */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "capture/cal_documents.h"
#include "capture/capture_files.h"
#include "capture/verdicts.h"
#include "daemon/control_private.h"
#include "modbus_map/modbus_map.h"
#include "rig/rig.h"

#define RUN_UIDS "run-uids.txt"

static json_t *string_or_null(const char *v)
{
    return v && v[0] ? json_string(v) : json_null();
}

/* The one line of [name, doc]; takes the reference to doc. */
static char *pair_text(const char *name, json_t *doc)
{
    return control_json_text(json_pack("[s,o]", name, doc));
}

static void send_pair(control *c, const char *name, json_t *doc)
{
    char *text = pair_text(name, doc);
    if (text)
        control_broadcast_to(c, CONTROL_WATCH_EVENTS, text);
    free(text);
}

/* ---- what produced each field ------------------------------------------ */

enum source { SRC_PLAN, SRC_ANGLES, SRC_SAMPLE, SRC_ARM, SRC_CHANNELS, SRC_INTEGRATION,
              SRC_STATUS, SRC_CLOCK, SRC_ENGINE, SRC_FIT, SRC_POLICY };

/* The device and register (or goniod's part) a field comes from. */
static void source_text(const control *c, enum source src, char *out, size_t size)
{
    const struct goniod_config *cfg = c->cfg;
    static const char *computed[] = {
        [SRC_PLAN] = "goniod:plan (point index)",
        [SRC_ANGLES] = "goniod:angles from the sample and arm axes' positions",
        [SRC_CLOCK] = "goniod:rig clock",
        [SRC_ENGINE] = "goniod:capture engine (progress)",
        [SRC_FIT] = "goniod:capture engine (streaming ABC fit)",
        [SRC_POLICY] = "goniod:capture engine (adaptive policy)",
    };
    if (src < SRC_SAMPLE || src > SRC_STATUS || src == SRC_ANGLES) {
        snprintf(out, size, "%s", computed[src]);
        return;
    }
    if (cfg->driver == GONIOD_DRIVER_SIM) {
        static const char *sim[] = {[SRC_SAMPLE] = "sample axis position",
                                    [SRC_ARM] = "arm axis position",
                                    [SRC_CHANNELS] = "detector channels",
                                    [SRC_INTEGRATION] = "detector integration time",
                                    [SRC_STATUS] = "detector status"};
        snprintf(out, size, "gonio-sim:%s", sim[src]);
        return;
    }
    int detector = src >= SRC_CHANNELS;
    if (detector && cfg->detector == GONIOD_DETECTOR_USB) {
        snprintf(out, size, "usb:%04x:%04x spectrometer %s", (unsigned)cfg->usb.vendor,
                 (unsigned)cfg->usb.product,
                 src == SRC_CHANNELS ? "bands" : src == SRC_STATUS ? "saturation" : "integration");
        return;
    }
    char bus[300];
    if (cfg->driver == GONIOD_DRIVER_MODBUS_RTU)
        snprintf(bus, sizeof bus, "modbus-rtu:%s", cfg->device);
    else
        snprintf(bus, sizeof bus, "modbus-tcp:%s:%d", cfg->host, cfg->port);
    int slave = src == SRC_SAMPLE ? cfg->slaves.sample
                : src == SRC_ARM  ? cfg->slaves.arm
                                  : cfg->slaves.detector;
    static const struct {
        int reg;
        const char *what;
    } regs[] = {[SRC_SAMPLE] = {MB_AX_FEEDBACK, "feedback position"},
                [SRC_ARM] = {MB_AX_FEEDBACK, "feedback position"},
                [SRC_CHANNELS] = {MB_DET_CHANNELS, "channels"},
                [SRC_INTEGRATION] = {MB_DET_INTEGRATION, "integration"},
                [SRC_STATUS] = {MB_DET_STATUS, "status"}};
    snprintf(out, size, "%s slave %d register 0x%02X (%s)", bus, slave, regs[src].reg,
             regs[src].what);
}

/* The device a source belongs to, as object_keys and object_name name it
 * (no '.' or '/': event-model's key pattern). */
static const char *object_of(enum source src)
{
    switch (src) {
    case SRC_SAMPLE: return "sample_axis";
    case SRC_ARM: return "arm_axis";
    case SRC_CHANNELS:
    case SRC_INTEGRATION:
    case SRC_STATUS: return "detector";
    default: return "goniod";
    }
}

/* The fields of the primary stream's events, in the order the data holds
 * them. */
static const struct field {
    const char *name, *dtype, *units;
    int dim; /* 0: a scalar, else an array of dim */
    enum source src;
    int adaptive; /* 0: every order, 1: only the adaptive one, -1: all others */
} fields[] = {
    {"point", "integer", NULL, 0, SRC_PLAN, 0},
    {"theta_i", "number", "deg", 0, SRC_ANGLES, 0},
    {"theta_r", "number", "deg", 0, SRC_ANGLES, 0},
    {"phi_i", "number", "deg", 0, SRC_ANGLES, 0},
    {"theta_o", "number", "deg", 0, SRC_ANGLES, 0},
    {"phi_o", "number", "deg", 0, SRC_ANGLES, 0},
    {"s", "number", "deg", 0, SRC_SAMPLE, 0},
    {"a", "number", "deg", 0, SRC_ARM, 0},
    {"rgb", "array", "1/sr", 3, SRC_CHANNELS, 0},
    {"integration_s", "number", "s", 0, SRC_INTEGRATION, 0},
    {"saturated", "boolean", NULL, 0, SRC_STATUS, 0},
    {"rig_time_s", "number", "s", 0, SRC_CLOCK, 0},
    {"done", "integer", NULL, 0, SRC_ENGINE, 0},
    {"total", "integer", NULL, 0, SRC_ENGINE, 0},
    {"eta_s", "number", "s", 0, SRC_ENGINE, 0},
    {"fit_log_error", "number", NULL, 0, SRC_FIT, -1},
    {"predicted_error", "number", NULL, 0, SRC_POLICY, 1},
    {"predicted_next", "number", NULL, 0, SRC_POLICY, 1},
    {"predicted_next_s", "number", "s", 0, SRC_POLICY, 1},
};
#define N_FIELDS (sizeof fields / sizeof fields[0])

static int field_used(const struct field *f, int in_adaptive)
{
    return f->adaptive == 0 || (f->adaptive > 0) == (in_adaptive != 0);
}

static json_t *data_key(const char *dtype, int dim, const char *units, const char *source)
{
    json_t *k = json_object();
    json_object_set_new(k, "dtype", json_string(dtype));
    json_object_set_new(k, "shape", dim ? json_pack("[i]", dim) : json_array());
    json_object_set_new(k, "units", units ? json_string(units) : json_null());
    json_object_set_new(k, "source", json_string(source));
    return k;
}

/* ---- configuration ------------------------------------------------------ */

/* The unit of a configuration field, by its name. */
static const char *config_units(const char *key)
{
    size_t n = strlen(key);
    if (n > 2 && !strcmp(key + n - 2, "_s"))
        return "s";
    if (strstr(key, "speed"))
        return "deg/s";
    if (strstr(key, "accel"))
        return "deg/s^2";
    if (strstr(key, "_min") || strstr(key, "_max") || !strcmp(key, "blind_deg"))
        return "deg";
    return NULL;
}

/* One configuration object: data as given, a data key per field (its dtype
 * from its JSON type) and one timestamp for all. Takes data. */
static json_t *configuration(json_t *data, const char *source, double t)
{
    json_t *keys = json_object(), *stamps = json_object(), *v;
    const char *k;
    json_object_foreach(data, k, v) {
        const char *dtype = json_is_integer(v)   ? "integer"
                            : json_is_number(v)  ? "number"
                            : json_is_boolean(v) ? "boolean"
                                                 : "string";
        json_object_set_new(keys, k, data_key(dtype, 0, config_units(k), source));
        json_object_set_new(stamps, k, json_real(t));
    }
    return json_pack("{s:o, s:o, s:o}", "data", data, "data_keys", keys, "timestamps", stamps);
}

static void set_axis(json_t *d, const char *name, const struct rig_axis *a)
{
    char k[64];
    const struct {
        const char *what;
        double v;
    } f[] = {{"speed", a->speed}, {"accel", a->accel}, {"min", a->min}, {"max", a->max}};
    for (size_t i = 0; i < 4; i++) {
        snprintf(k, sizeof k, "%s_%s", name, f[i].what);
        json_object_set_new(d, k, control_json_number(f[i].v));
    }
}

static json_t *rig_configuration(const struct worker_msg_start *m, double t)
{
    struct rig_profile rig;
    struct gonio_err err = {0};
    if (rig_profile_load(m->req.rig, &rig, &err) != 0)
        return NULL;
    json_t *d = json_object();
    json_object_set_new(d, "name", json_string(rig.name));
    set_axis(d, "sample", &rig.sample);
    set_axis(d, "arm", &rig.arm);
    if (rig.out_of_plane)
        set_axis(d, "azimuth", &rig.azimuth);
    if (rig.has_rotation)
        set_axis(d, "rotation", &rig.rotation);
    json_object_set_new(d, "out_of_plane", json_boolean(rig.out_of_plane));
    json_object_set_new(d, "blind_deg", control_json_number(rig.blind_deg));
    json_object_set_new(d, "settle_s", control_json_number(rig.settle_s));
    json_object_set_new(d, "integration_s", control_json_number(rig.integration_s));
    char source[1100];
    snprintf(source, sizeof source, "rig profile %s", m->req.rig);
    return configuration(d, source, t);
}

static json_t *driver_configuration(const control *c, const struct worker_msg_start *m,
                                    double t)
{
    const struct goniod_config *cfg = c->cfg;
    json_t *d = json_object();
    json_object_set_new(d, "kind", json_string(goniod_driver_name(cfg->driver)));
    if (cfg->driver == GONIOD_DRIVER_SIM) {
        json_object_set_new(d, "scene", json_string(m->req.scene));
        json_object_set_new(d, "pace_s", control_json_number(cfg->pace_s));
    } else {
        if (cfg->driver == GONIOD_DRIVER_MODBUS_RTU) {
            char parity[2] = {cfg->parity, 0};
            json_object_set_new(d, "device", json_string(cfg->device));
            json_object_set_new(d, "baud", json_integer(cfg->baud));
            json_object_set_new(d, "parity", json_string(parity));
            json_object_set_new(d, "data_bits", json_integer(cfg->data_bits));
            json_object_set_new(d, "stop_bits", json_integer(cfg->stop_bits));
        } else {
            json_object_set_new(d, "host", json_string(cfg->host));
            json_object_set_new(d, "port", json_integer(cfg->port));
        }
        json_object_set_new(d, "slave_sample", json_integer(cfg->slaves.sample));
        json_object_set_new(d, "slave_arm", json_integer(cfg->slaves.arm));
        json_object_set_new(d, "slave_azimuth", json_integer(cfg->slaves.azimuth));
        json_object_set_new(d, "slave_rotation", json_integer(cfg->slaves.rotation));
        json_object_set_new(d, "slave_detector", json_integer(cfg->slaves.detector));
        json_object_set_new(d, "steps_per_deg", control_json_number(cfg->steps_per_deg));
        json_object_set_new(d, "time_scale", control_json_number(cfg->time_scale));
    }
    char source[1100];
    snprintf(source, sizeof source, "goniod configuration %s", cfg->path);
    return configuration(d, source, t);
}

/* ---- the run's uids on disk --------------------------------------------- */

/* Append uid to dir's record; not through a link. A failure is logged:
 * the run goes on, only the next run cannot name it. */
static void record_run(const char *dir, const char *uid)
{
    char path[2200], line[40];
    snprintf(path, sizeof path, "%s/" RUN_UIDS, dir);
    int fd = open(path, O_WRONLY | O_CREAT | O_APPEND | O_NOFOLLOW | O_CLOEXEC, 0644);
    int n = snprintf(line, sizeof line, "%s\n", uid);
    if (fd < 0 || write(fd, line, (size_t)n) != n)
        fprintf(stderr, "goniod: %s: %s\n", path, strerror(errno));
    if (fd >= 0)
        close(fd);
}

/* ---- the documents ------------------------------------------------------ */

/* The calibration the capture reduces with, as its setup.json names it
 * (written before its first sample), and the uid of that calibration's
 * last run (capture/cal_documents.h): null, null for an uncalibrated
 * capture, a uid null for a calibration that has no run recorded. */
static void set_calibration(const control *c, json_t *d, const char *dir)
{
    char path[2200], uid[37] = "";
    snprintf(path, sizeof path, "%s/setup.json", dir);
    json_t *setup = json_load_file(path, 0, NULL);
    const char *id = json_string_value(json_object_get(setup, "calibration"));
    if (id && c->cfg->calibration_root[0])
        cal_documents_last_uid(c->cfg->calibration_root, id, uid);
    json_object_set_new(d, "calibration", string_or_null(id));
    json_object_set_new(d, "calibration_uid", string_or_null(uid));
    json_decref(setup);
}

static json_t *run_start_doc(control *c, const struct worker_msg_start *m, double t)
{
    const struct worker_request *r = &m->req;
    char previous[37];
    run_uids_last(r->dir, previous);
    json_t *d = json_object();
    json_object_set_new(d, "uid", json_string(c->ev.run));
    json_object_set_new(d, "time", json_real(t));
    json_object_set_new(d, "plan_name", json_string("gonio capture"));
    json_object_set_new(d, "plan", json_string(m->plan_name));
    json_object_set_new(d, "capture_id", json_string(r->id));
    json_object_set_new(d, "dir", json_string(r->dir));
    json_object_set_new(d, "rig", json_string(r->rig));
    json_object_set_new(d, "scene", string_or_null(r->scene));
    json_object_set_new(d, "sample", json_pack("{s:o, s:o}", "material",
                                               string_or_null(r->material), "truth",
                                               string_or_null(r->truth)));
    json_object_set_new(d, "model", json_string(r->model));
    json_object_set_new(d, "order", string_or_null(r->order));
    json_object_set_new(d, "stop", string_or_null(r->stop));
    json_object_set_new(d, "budget", r->budget_min > 0 ? json_real(r->budget_min) : json_null());
    json_object_set_new(d, "stop_target",
                        r->stop_target > 0 ? json_real(r->stop_target) : json_null());
    json_object_set_new(d, "resume", json_boolean(r->resume));
    json_object_set_new(d, "continues", string_or_null(r->resume ? previous : NULL));
    json_object_set_new(d, "num_points", json_integer((json_int_t)m->total));
    json_object_set_new(d, "already_done", json_integer((json_int_t)m->already_done));
    json_object_set_new(d, "estimate_s", control_json_number(m->estimate_s));
    json_object_set_new(d, "prescan", json_integer((json_int_t)m->prescan));
    json_object_set_new(d, "adaptive", json_boolean(m->adaptive));
    set_calibration(c, d, r->dir);
    json_object_set_new(d, "hints",
                        json_pack("{s:[[[s],s]]}", "dimensions", "theta_r", "primary"));
    return d;
}

static json_t *primary_descriptor_doc(control *c, const struct worker_msg_start *m, double t)
{
    json_t *keys = json_object(), *objects = json_object();
    char source[400];
    for (size_t i = 0; i < N_FIELDS; i++) {
        const struct field *f = &fields[i];
        if (!field_used(f, m->adaptive))
            continue;
        source_text(c, f->src, source, sizeof source);
        json_t *k = data_key(f->dtype, f->dim, f->units, source);
        json_object_set_new(k, "object_name", json_string(object_of(f->src)));
        json_object_set_new(keys, f->name, k);
        json_t *names = json_object_get(objects, object_of(f->src));
        if (!names)
            json_object_set_new(objects, object_of(f->src), names = json_array());
        json_array_append_new(names, json_string(f->name));
    }
    json_t *conf = json_object();
    json_t *rig = rig_configuration(m, t);
    if (rig)
        json_object_set_new(conf, "rig", rig);
    json_object_set_new(conf, "driver", driver_configuration(c, m, t));
    json_t *d = json_object();
    json_object_set_new(d, "uid", json_string(c->ev.primary));
    json_object_set_new(d, "run_start", json_string(c->ev.run));
    json_object_set_new(d, "time", json_real(t));
    json_object_set_new(d, "name", json_string("primary"));
    json_object_set_new(d, "data_keys", keys);
    json_object_set_new(d, "object_keys", objects);
    json_object_set_new(d, "configuration", conf);
    return d;
}

void control_events_start(control *c, const struct worker_msg_start *m)
{
    control_events_free(c);
    double t = cal_documents_now();
    cal_documents_uid(c->ev.run);
    cal_documents_uid(c->ev.primary);
    c->ev.seq = 0;
    c->ev.adaptive = m->adaptive;
    c->ev.start_text = pair_text("start", run_start_doc(c, m, t));
    c->ev.descriptor_text = pair_text("descriptor", primary_descriptor_doc(c, m, t));
    record_run(m->req.dir, c->ev.run);
    if (c->ev.start_text)
        control_broadcast_to(c, CONTROL_WATCH_EVENTS, c->ev.start_text);
    if (c->ev.descriptor_text)
        control_broadcast_to(c, CONTROL_WATCH_EVENTS, c->ev.descriptor_text);
}

void control_events_greet(control *c, struct control_client *cl)
{
    if (c->ev.start_text)
        control_client_send_text(cl, c->ev.start_text);
    if (c->ev.descriptor_text)
        control_client_send_text(cl, c->ev.descriptor_text);
}

void control_events_sample(control *c, const struct worker_msg_sample *m)
{
    if (!c->ev.run[0])
        return;
    const struct journal_sample *s = &m->sample;
    const double values[] = {s->theta_i, s->theta_r, s->phi_i, s->theta_o, s->phi_o, s->s, s->a};
    json_t *data = json_object();
    json_object_set_new(data, "point", json_integer(s->point));
    for (size_t i = 0; i < 7; i++)
        json_object_set_new(data, fields[1 + i].name, control_json_number(values[i]));
    json_object_set_new(data, "rgb",
                        json_pack("[o,o,o]", control_json_number(s->rgb[0]),
                                  control_json_number(s->rgb[1]),
                                  control_json_number(s->rgb[2])));
    json_object_set_new(data, "integration_s", control_json_number(s->integration_s));
    json_object_set_new(data, "saturated", json_boolean(s->flags & JOURNAL_FLAG_SATURATED));
    json_object_set_new(data, "rig_time_s", control_json_number(s->rig_time_s));
    json_object_set_new(data, "done", json_integer((json_int_t)m->done));
    json_object_set_new(data, "total", json_integer((json_int_t)m->total));
    json_object_set_new(data, "eta_s", control_json_number(m->eta_s));
    if (c->ev.adaptive) { /* null until the policy predicts */
        json_object_set_new(data, "predicted_error", control_json_number(m->predicted));
        json_object_set_new(data, "predicted_next", control_json_number(m->predicted_next));
        json_object_set_new(data, "predicted_next_s",
                            control_json_number(m->predicted_next_s));
    } else { /* null until the streaming fit's first round */
        json_object_set_new(data, "fit_log_error", control_json_number(m->fit_log_error));
    }
    send_pair(c, "event",
              cal_documents_event(c->ev.primary, ++c->ev.seq, data, cal_documents_now()));
}

static void set_errors(json_t *d, const char *prefix, const struct brdf_errors *e)
{
    char k[64];
    snprintf(k, sizeof k, "%s_log_error", prefix);
    json_object_set_new(d, k, control_json_number(e->log));
    snprintf(k, sizeof k, "%s_rel_rmse", prefix);
    json_object_set_new(d, k, control_json_number(e->rel_rmse));
    snprintf(k, sizeof k, "%s_pairs", prefix);
    json_object_set_new(d, k, json_integer((json_int_t)e->n_used));
}

/* The final fit as one event's data (results.json's figures). */
static json_t *fit_data(const struct capture_summary *s)
{
    json_t *d = json_object();
    json_object_set_new(d, "model", json_string(s->model));
    json_object_set_new(d, "model_file", json_string(s->model_file));
    json_object_set_new(d, "converged", json_boolean(s->converged));
    json_object_set_new(d, "fit_time_s", control_json_number(s->fit_time_s));
    json_object_set_new(d, "samples", json_integer((json_int_t)s->samples));
    set_errors(d, "plan", &s->err_plan);
    if (s->has_truth) {
        set_errors(d, "inplane", &s->err_inplane);
        set_errors(d, "full", &s->err_full);
    }
    if (s->has_params) {
        const struct brdf_abc *p = &s->params;
        json_object_set_new(d, "kd", json_pack("[o,o,o]", control_json_number(p->kd[0]),
                                               control_json_number(p->kd[1]),
                                               control_json_number(p->kd[2])));
        json_object_set_new(d, "A", json_pack("[o,o,o]", control_json_number(p->A[0]),
                                              control_json_number(p->A[1]),
                                              control_json_number(p->A[2])));
        json_object_set_new(d, "B", control_json_number(p->B));
        json_object_set_new(d, "C", control_json_number(p->C));
        json_object_set_new(d, "eta", control_json_number(p->eta));
    }
    if (s->adaptive)
        json_object_set_new(d, "predicted_error",
                            control_json_number(s->policy.predicted_error));
    /* the checks' verdicts and auto's choice as results.json has them, flat
     * as data keys are (capture/verdicts.h) */
    json_t *checks = capture_files_checks(s), *choice = capture_verdicts_auto(s);
    capture_verdicts_flat(checks, choice, d);
    json_decref(checks);
    json_decref(choice);
    return d;
}

/* The fit stream: its descriptor (data keys from the data's JSON types) and
 * its one event. */
static void send_fit(control *c, const struct capture_summary *s, double t)
{
    json_t *data = fit_data(s), *keys = json_object(), *v;
    const char *k;
    char source[128];
    snprintf(source, sizeof source, "goniod:capture engine (final %s fit)", s->model);
    json_object_foreach(data, k, v) {
        int dim = json_is_array(v) ? (int)json_array_size(v) : 0;
        const char *dtype = dim                  ? "array"
                            : json_is_integer(v) ? "integer"
                            : json_is_boolean(v) ? "boolean"
                            : json_is_string(v)  ? "string"
                                                 : "number";
        size_t len = strlen(k); /* "_s": seconds, "_deg": degrees */
        const char *units = len > 2 && !strcmp(k + len - 2, "_s")   ? "s"
                            : len > 4 && !strcmp(k + len - 4, "_deg") ? "deg"
                            : !strcmp(k, "kd") || !strcmp(k, "A")     ? "1/sr"
                                                                      : NULL;
        json_object_set_new(keys, k, data_key(dtype, dim, units, source));
    }
    char uid[37];
    cal_documents_uid(uid);
    send_pair(c, "descriptor",
              json_pack("{s:s, s:s, s:f, s:s, s:o}", "uid", uid, "run_start", c->ev.run,
                        "time", t, "name", "fit", "data_keys", keys));
    send_pair(c, "event", cal_documents_event(uid, 1, data, t));
}

void control_events_stop(control *c, const struct worker_msg_stop *m)
{
    double t = cal_documents_now();
    if (!c->ev.run[0]) { /* it failed before its first point (a corrupt journal) */
        char previous[37];
        run_uids_last(m->dir, previous);
        cal_documents_uid(c->ev.run);
        send_pair(c, "start",
                  json_pack("{s:s, s:f, s:s, s:s, s:s, s:o}", "uid", c->ev.run, "time", t,
                            "plan_name", "gonio capture", "capture_id", m->id, "dir", m->dir,
                            "continues", string_or_null(previous)));
        record_run(m->dir, c->ev.run);
    }
    int aborted = !strcmp(m->reason, "aborted") || !strcmp(m->reason, "shutdown");
    int fitted = m->rc >= 0 && !aborted;
    if (fitted)
        send_fit(c, &m->summary, t);
    char uid[37];
    cal_documents_uid(uid);
    json_t *d = json_object();
    json_object_set_new(d, "uid", json_string(uid));
    json_object_set_new(d, "run_start", json_string(c->ev.run));
    json_object_set_new(d, "time", json_real(t));
    json_object_set_new(d, "exit_status",
                        json_string(m->rc < 0 ? "fail" : aborted ? "abort" : "success"));
    json_t *msg = m->rc < 0 ? json_string(m->err.msg) : NULL;
    json_object_set_new(d, "reason", msg ? msg : json_string(m->reason));
    json_object_set_new(d, "stop_reason", json_string(m->reason));
    json_t *counts = json_object(); /* of the streams the run described */
    if (c->ev.primary[0])
        json_object_set_new(counts, "primary", json_integer((json_int_t)c->ev.seq));
    if (fitted)
        json_object_set_new(counts, "fit", json_integer(1));
    json_object_set_new(d, "num_events", counts);
    json_object_set_new(d, "capture_id", json_string(m->id));
    if (m->rc >= 0) {
        json_object_set_new(d, "rig_time_s", control_json_number(m->summary.rig_time_s));
        json_object_set_new(d, "paused_s", control_json_number(m->summary.paused_s));
    }
    send_pair(c, "stop", d);
    control_events_free(c);
}

void control_events_lines(control *c, const char *text)
{
    for (const char *p = text, *nl; p && (nl = strchr(p, '\n')); p = nl + 1) {
        char *line = strndup(p, (size_t)(nl - p));
        if (line)
            control_broadcast_to(c, CONTROL_WATCH_EVENTS, line);
        free(line);
    }
}

void control_events_free(control *c)
{
    free(c->ev.start_text);
    free(c->ev.descriptor_text);
    memset(&c->ev, 0, sizeof c->ev);
}
