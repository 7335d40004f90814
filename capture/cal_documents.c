/* A calibration run as event-model documents (capture/cal_documents.h). */
#include "capture/cal_documents.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/time.h>
#include <unistd.h>

#include <jansson.h>
#include <uuid/uuid.h>

double cal_documents_now(void)
{
    struct timeval tv;
    gettimeofday(&tv, NULL);
    return (double)tv.tv_sec + tv.tv_usec * 1e-6;
}

void cal_documents_uid(char out[37])
{
    uuid_t u;
    uuid_generate_random(u);
    uuid_unparse_lower(u, out);
}

/* Numbers that are not finite are null, as in every document of goniod. */
static json_t *num(double v)
{
    return isfinite(v) ? json_real(v) : json_null();
}

static json_t *str_or_null(const char *v)
{
    return v && v[0] ? json_string(v) : json_null();
}

static json_t *num_array(const double *v, int n)
{
    json_t *a = json_array();
    for (int k = 0; k < n; k++)
        json_array_append_new(a, num(v[k]));
    return a;
}

void run_uids_last(const char *dir, char out[37])
{
    char path[2400], line[64];
    out[0] = 0;
    snprintf(path, sizeof path, "%s/" CAL_RUN_UIDS_FILE, dir);
    int fd = open(path, O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
    FILE *f = fd < 0 ? NULL : fdopen(fd, "r");
    if (!f) {
        if (fd >= 0)
            close(fd);
        return;
    }
    while (fgets(line, sizeof line, f)) {
        uuid_t u;
        line[strcspn(line, "\n")] = 0;
        if (strlen(line) == 36 && uuid_parse(line, u) == 0)
            memcpy(out, line, 37);
    }
    fclose(f);
}

void cal_documents_last_uid(const char *root, const char *id, char out[37])
{
    char dir[2300];
    snprintf(dir, sizeof dir, "%s/%s", root, id);
    run_uids_last(dir, out);
}

/* Append text to ROOT/ID/name, not through a link. */
static int append(const char *root, const char *id, const char *name, const char *text,
                  struct gonio_err *err)
{
    char path[2400];
    snprintf(path, sizeof path, "%s/%s/%s", root, id, name);
    int fd = open(path, O_WRONLY | O_CREAT | O_APPEND | O_NOFOLLOW | O_CLOEXEC, 0644);
    size_t len = strlen(text);
    int ok = fd >= 0 && write(fd, text, len) == (ssize_t)len;
    int e = errno;
    if (fd >= 0 && close(fd) < 0 && ok) {
        ok = 0;
        e = errno;
    }
    return ok ? 0 : gonio_err_set(err, e ? e : EIO, "%s: %s", path, strerror(e ? e : EIO));
}

static json_t *data_key(const char *dtype, int dim, const char *units, const char *source,
                        const char *object)
{
    json_t *k = json_pack("{s:s, s:o, s:o, s:s}", "dtype", dtype, "shape",
                          dim ? json_pack("[i]", dim) : json_array(), "units",
                          units ? json_string(units) : json_null(), "source", source);
    if (object)
        json_object_set_new(k, "object_name", json_string(object));
    return k;
}

static int n_bands(const struct cal_doc_run *r)
{
    return r->n ? r->frames[0].n_bands : 0;
}

/* The calibration this one was taken with, and the uid of its last run. */
static void set_taken_with(json_t *d, const char *root, const char *key, const char *id)
{
    char uid[37] = "", k[32];
    if (id[0])
        cal_documents_last_uid(root, id, uid);
    json_object_set_new(d, key, str_or_null(id));
    snprintf(k, sizeof k, "%s_uid", key);
    json_object_set_new(d, k, str_or_null(uid));
}

static json_t *start_doc(const char *root, const struct cal_doc_run *r, const char *uid,
                         const char *continues)
{
    const struct cal_meta *m = r->meta;
    json_t *d = json_object();
    json_object_set_new(d, "uid", json_string(uid));
    json_object_set_new(d, "time", json_real(r->t_start));
    json_object_set_new(d, "plan_name", json_string("gonio calibrate"));
    json_object_set_new(d, "calibration_id", json_string(m->id));
    json_object_set_new(d, "kind", json_string(cal_kind_name(m->kind)));
    json_object_set_new(d, "rig", json_string(m->rig));
    json_object_set_new(d, "detector", json_string(m->detector));
    json_object_set_new(d, "created", json_integer((json_int_t)m->created));
    json_object_set_new(d, "valid_s", num(m->valid_s));
    json_object_set_new(d, "valid_until", num((double)m->created + m->valid_s));
    json_object_set_new(d, "integrations", num_array(m->integrations,
                                                     (int)m->n_integrations));
    set_taken_with(d, root, "dark", m->dark);
    set_taken_with(d, root, "stray", m->stray);
    json_object_set_new(d, "standard", str_or_null(m->standard));
    json_object_set_new(d, "spot", json_string(m->spot == RAD_SPOT_UNDERFILLED ? "underfilled"
                                                                               : "overfilled"));
    json_object_set_new(d, "plan", str_or_null(r->plan));
    json_object_set_new(d, m->kind == CAL_DARK ? "frames_per_integration" : "repeats",
                        json_integer(r->per_point));
    json_object_set_new(d, "num_points", json_integer((json_int_t)r->total));
    json_object_set_new(d, "continues", str_or_null(continues));
    return d;
}

/* The primary stream: a data key per field of a frame's event. */
static json_t *primary_descriptor(const struct cal_doc_run *r, const char *run,
                                  const char *uid)
{
    const char *src = r->source;
    int nb = n_bands(r);
    json_t *k = json_object();
    json_object_set_new(k, "frame", data_key("integer", 0, NULL, "gonio calibrate (frame "
                                             "index)", "gonio"));
    json_object_set_new(k, "theta_i", data_key("number", 0, "deg", "gonio calibrate "
                                               "(the point's angles)", "gonio"));
    json_object_set_new(k, "theta_r", data_key("number", 0, "deg", "gonio calibrate "
                                               "(the point's angles)", "gonio"));
    json_object_set_new(k, "counts", data_key("array", 3, "ADU", src, "detector"));
    if (nb)
        json_object_set_new(k, "bands", data_key("array", nb, "ADU", src, "detector"));
    json_object_set_new(k, "integration_s", data_key("number", 0, "s", src, "detector"));
    json_object_set_new(k, "gain_state", data_key("integer", 0, NULL, src, "detector"));
    json_object_set_new(k, "monitor", data_key("number", 0, "ADU", src, "detector"));
    json_object_set_new(k, "saturated", data_key("boolean", 0, NULL, src, "detector"));
    json_object_set_new(k, "rig_time_s", data_key("number", 0, "s", "gonio calibrate "
                                                  "(rig clock)", "gonio"));
    json_t *objects = json_object(), *v;
    const char *name;
    json_object_foreach(k, name, v) {
        const char *o = json_string_value(json_object_get(v, "object_name"));
        json_t *names = json_object_get(objects, o);
        if (!names)
            json_object_set_new(objects, o, names = json_array());
        json_array_append_new(names, json_string(name));
    }
    /* the detector's ADC as its frames state it, and its bands */
    const struct cal_frame *f0 = r->n ? &r->frames[0] : NULL;
    json_t *conf = json_pack("{s:o, s:o}", "full_scale", num(f0 ? f0->full_scale : NAN),
                             "nonlinearity", num(f0 ? f0->nonlinearity : NAN));
    json_t *ck = json_pack("{s:o, s:o}", "full_scale", data_key("number", 0, "ADU", src, NULL),
                           "nonlinearity", data_key("number", 0, NULL, src, NULL));
    if (nb) {
        json_object_set_new(conf, "bands_nm", num_array(f0->bands_nm, nb));
        json_object_set_new(ck, "bands_nm", data_key("array", nb, "nm", src, NULL));
    }
    json_t *stamps = json_object();
    json_object_foreach(conf, name, v) json_object_set_new(stamps, name, json_real(r->t_start));
    json_t *d = json_object();
    json_object_set_new(d, "uid", json_string(uid));
    json_object_set_new(d, "run_start", json_string(run));
    json_object_set_new(d, "time", json_real(r->t_start));
    json_object_set_new(d, "name", json_string("primary"));
    json_object_set_new(d, "data_keys", k);
    json_object_set_new(d, "object_keys", objects);
    json_object_set_new(d, "configuration",
                        json_pack("{s:{s:o, s:o, s:o}}", "detector", "data", conf,
                                  "data_keys", ck, "timestamps", stamps));
    return d;
}

json_t *cal_documents_event(const char *descriptor, unsigned long long seq, json_t *data,
                            double t)
{
    json_t *stamps = json_object(), *v;
    const char *k;
    json_object_foreach(data, k, v) json_object_set_new(stamps, k, json_real(t));
    char uid[37];
    cal_documents_uid(uid);
    return json_pack("{s:s, s:s, s:I, s:f, s:o, s:o}", "uid", uid, "descriptor", descriptor,
                     "seq_num", (json_int_t)seq, "time", t, "data", data, "timestamps", stamps);
}

static int saturated(const struct cal_frame *f)
{
    if (!(f->full_scale > 0))
        return 0;
    for (int c = 0; c < 3; c++)
        if (f->counts[c] >= f->full_scale)
            return 1;
    for (int k = 0; k < f->n_bands; k++)
        if (f->bands[k] >= f->full_scale)
            return 1;
    return 0;
}

static json_t *frame_data(const struct cal_frame *f, size_t index, int nb)
{
    json_t *d = json_object();
    json_object_set_new(d, "frame", json_integer((json_int_t)index));
    json_object_set_new(d, "theta_i", num(f->theta_i));
    json_object_set_new(d, "theta_r", num(f->theta_r));
    json_object_set_new(d, "counts", num_array(f->counts, 3));
    if (nb)
        json_object_set_new(d, "bands", num_array(f->bands, f->n_bands == nb ? nb : 0));
    json_object_set_new(d, "integration_s", num(f->integration_s));
    json_object_set_new(d, "gain_state", json_integer(f->gain_state));
    json_object_set_new(d, "monitor", num(f->monitor));
    json_object_set_new(d, "saturated", json_boolean(saturated(f)));
    json_object_set_new(d, "rig_time_s", num(f->rig_time_s));
    return d;
}

/* ---- the results stream: the frames' means and spreads per group ------- */

/* Frames of one group: one integration and gain state (a dark), one
 * geometry and integration (a reference, stray light). */
static int same_group(const struct cal_frame *a, const struct cal_frame *b)
{
    int geometry = a->kind == CAL_DARK ||
                   (a->theta_i == b->theta_i && a->theta_r == b->theta_r);
    return geometry && a->integration_s == b->integration_s && a->gain_state == b->gain_state;
}

/* Mean and sample spread over the group's frames of channel c (c >= 3:
 * band c - 3). */
static void moments(const struct cal_doc_run *r, const struct cal_frame *g, int c,
                    double *mean, double *sd, size_t *count)
{
    double s = 0, ss = 0;
    size_t n = 0;
    for (size_t i = 0; i < r->n; i++) {
        const struct cal_frame *f = &r->frames[i];
        if (!same_group(g, f) || (c >= 3 && f->n_bands <= c - 3))
            continue;
        double v = c < 3 ? f->counts[c] : f->bands[c - 3];
        s += v;
        ss += v * v;
        n++;
    }
    *count = n;
    *mean = n ? s / (double)n : NAN;
    *sd = n > 1 ? sqrt(fmax(0, (ss - s * s / (double)n) / (double)(n - 1))) : NAN;
}

static json_t *group_data(const struct cal_doc_run *r, const struct cal_frame *g, int nb)
{
    double mean[3 + CAL_MAX_BANDS], sd[3 + CAL_MAX_BANDS];
    size_t count = 0;
    for (int c = 0; c < 3 + nb; c++)
        moments(r, g, c, &mean[c], &sd[c], &count);
    json_t *d = json_object();
    json_object_set_new(d, "integration_s", num(g->integration_s));
    json_object_set_new(d, "gain_state", json_integer(g->gain_state));
    json_object_set_new(d, "theta_i", num(g->kind == CAL_DARK ? NAN : g->theta_i));
    json_object_set_new(d, "theta_r", num(g->kind == CAL_DARK ? NAN : g->theta_r));
    json_object_set_new(d, "frames", json_integer((json_int_t)count));
    json_object_set_new(d, "mean", num_array(mean, 3));
    json_object_set_new(d, "sd", num_array(sd, 3));
    if (nb) {
        json_object_set_new(d, "band_mean", num_array(mean + 3, nb));
        json_object_set_new(d, "band_sd", num_array(sd + 3, nb));
    }
    return d;
}

static json_t *results_descriptor(const struct cal_doc_run *r, const char *run,
                                  const char *uid)
{
    const char *src = "gonio calibrate (the frames' mean and sample standard deviation)";
    int nb = n_bands(r);
    json_t *k = json_object();
    json_object_set_new(k, "integration_s", data_key("number", 0, "s", src, NULL));
    json_object_set_new(k, "gain_state", data_key("integer", 0, NULL, src, NULL));
    json_object_set_new(k, "theta_i", data_key("number", 0, "deg", src, NULL));
    json_object_set_new(k, "theta_r", data_key("number", 0, "deg", src, NULL));
    json_object_set_new(k, "frames", data_key("integer", 0, NULL, src, NULL));
    json_object_set_new(k, "mean", data_key("array", 3, "ADU", src, NULL));
    json_object_set_new(k, "sd", data_key("array", 3, "ADU", src, NULL));
    if (nb) {
        json_object_set_new(k, "band_mean", data_key("array", nb, "ADU", src, NULL));
        json_object_set_new(k, "band_sd", data_key("array", nb, "ADU", src, NULL));
    }
    return json_pack("{s:s, s:s, s:f, s:s, s:o}", "uid", uid, "run_start", run, "time",
                     r->t_stop, "name", "results", "data_keys", k);
}

/* ---- the run ------------------------------------------------------------ */

struct out {
    const char *root, *id;
    void (*emit)(void *, const char *);
    void *user;
    int rc;
    struct gonio_err *err;
};

/* Emit and append one document; takes the reference to doc. */
static void put(struct out *o, const char *name, json_t *doc)
{
    json_t *pair = json_pack("[s,o]", name, doc);
    char *text = pair ? json_dumps(pair, JSON_COMPACT | JSON_ENSURE_ASCII) : NULL;
    json_decref(pair);
    if (!text) {
        if (o->rc == 0)
            o->rc = gonio_err_set(o->err, ENOMEM, "out of memory");
        return;
    }
    if (o->emit)
        o->emit(o->user, text);
    size_t len = strlen(text);
    char *line = malloc(len + 2);
    if (line) {
        memcpy(line, text, len);
        memcpy(line + len, "\n", 2);
    }
    int rc = line ? append(o->root, o->id, CAL_DOCUMENTS_FILE, line, o->err)
                  : gonio_err_set(o->err, ENOMEM, "out of memory");
    if (rc < 0 && o->rc == 0)
        o->rc = rc;
    free(line);
    free(text);
}

/* The results stream's events: one per group, in the frames' order. */
static size_t put_results(struct out *o, const struct cal_doc_run *r, const char *run)
{
    char uid[37];
    cal_documents_uid(uid);
    put(o, "descriptor", results_descriptor(r, run, uid));
    size_t seq = 0;
    for (size_t i = 0; i < r->n; i++) {
        size_t first = 0;
        while (!same_group(&r->frames[first], &r->frames[i]))
            first++;
        if (first == i) /* the group's first frame */
            put(o, "event", cal_documents_event(uid, ++seq, group_data(r, &r->frames[i], n_bands(r)),
                                      r->t_stop));
    }
    return seq;
}

int cal_documents(const char *root, const struct cal_doc_run *r,
                  void (*emit)(void *user, const char *line), void *user,
                  struct gonio_err *err)
{
    const struct cal_meta *m = r->meta;
    struct out o = {.root = root, .id = m->id, .emit = emit, .user = user, .err = err};
    char run[37], primary[37], previous[37], line[40];
    cal_documents_last_uid(root, m->id, previous);
    cal_documents_uid(run);
    snprintf(line, sizeof line, "%s\n", run);
    o.rc = append(root, m->id, CAL_RUN_UIDS_FILE, line, err);
    put(&o, "start", start_doc(root, r, run, previous));
    size_t n_results = 0;
    if (r->n) {
        cal_documents_uid(primary);
        put(&o, "descriptor", primary_descriptor(r, run, primary));
        for (size_t i = 0; i < r->n; i++)
            put(&o, "event", cal_documents_event(primary, i + 1, frame_data(&r->frames[i], i, n_bands(r)),
                                       r->t_stop));
        if (!strcmp(r->exit_status, "success"))
            n_results = put_results(&o, r, run);
    }
    json_t *counts = json_object();
    if (r->n)
        json_object_set_new(counts, "primary", json_integer((json_int_t)r->n));
    if (n_results)
        json_object_set_new(counts, "results", json_integer((json_int_t)n_results));
    char uid[37];
    cal_documents_uid(uid);
    put(&o, "stop",
        json_pack("{s:s, s:s, s:f, s:s, s:s, s:o, s:s, s:o}", "uid", uid, "run_start", run,
                  "time", r->t_stop, "exit_status", r->exit_status, "reason",
                  r->reason ? r->reason : "", "num_events", counts, "calibration_id", m->id,
                  "rig_time_s", num(r->n ? r->frames[r->n - 1].rig_time_s : NAN)));
    return o.rc;
}
