/* What `gonio live` shows (cli/live_state.h). The feeding thread owns the
 * streaming fit and the JSON it builds; what pages read (rows, the info
 * and fit snapshots as text) is swapped in under the lock, so a page holds
 * the lock only to copy text. */
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "brdf/abc.h"
#include "cli/live_curve.h"
#include "cli/live_state.h"
#include "fit/journal_samples.h"
#include "fit/model_file.h"
#include "fit/stream.h"
#include "journal/journal.h"

struct live_state {
    pthread_mutex_t mu;
    pthread_cond_t cv;
    int closed;
    /* read by pages, under mu */
    unsigned long run;
    char **rows; /* one JSON array per sample of the run */
    size_t n_rows, cap_rows;
    char *info_text;
    unsigned long info_ver;
    char *fit_text;
    unsigned long fit_ver;
    /* the feeder's own */
    json_t *info;
    fit_stream *fs;
    size_t fed;          /* samples in fs */
    double last_err;     /* goniod's latest fit_log_error (NAN: none yet) */
    int final_curve;     /* the curve is the model file's: no more live rounds */
    double ti[LIVE_CURVE_INCIDENCES];
    size_t n_ti;
};

live_state *live_state_new(void)
{
    live_state *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    pthread_mutex_init(&s->mu, NULL);
    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
    pthread_cond_init(&s->cv, &ca);
    pthread_condattr_destroy(&ca);
    s->info = json_pack("{s:s,s:[]}", "state", "waiting", "alarms");
    s->last_err = NAN;
    return s;
}

static void drop_rows(live_state *s)
{
    for (size_t k = 0; k < s->n_rows; k++)
        free(s->rows[k]);
    s->n_rows = 0;
}

void live_state_free(live_state *s)
{
    if (!s)
        return;
    drop_rows(s);
    free(s->rows);
    free(s->info_text);
    free(s->fit_text);
    json_decref(s->info);
    fit_stream_free(s->fs);
    pthread_cond_destroy(&s->cv);
    pthread_mutex_destroy(&s->mu);
    free(s);
}

/* ---- publishing (feeder side) ------------------------------------------ */

static void publish_info(live_state *s)
{
    char *t = json_dumps(s->info, JSON_COMPACT);
    if (!t)
        return;
    pthread_mutex_lock(&s->mu);
    free(s->info_text);
    s->info_text = t;
    s->info_ver++;
    pthread_cond_broadcast(&s->cv);
    pthread_mutex_unlock(&s->mu);
}

static void publish_fit(live_state *s, json_t *fit)
{
    char *t = fit ? json_dumps(fit, JSON_COMPACT) : NULL;
    json_decref(fit);
    if (!t)
        return;
    pthread_mutex_lock(&s->mu);
    free(s->fit_text);
    s->fit_text = t;
    s->fit_ver++;
    pthread_cond_broadcast(&s->cv);
    pthread_mutex_unlock(&s->mu);
}

static void publish_row(live_state *s, json_t *row)
{
    char *t = json_dumps(row, JSON_COMPACT);
    json_decref(row);
    if (!t)
        return;
    pthread_mutex_lock(&s->mu);
    if (s->n_rows == s->cap_rows) {
        size_t cap = s->cap_rows ? 2 * s->cap_rows : 256;
        char **r = realloc(s->rows, cap * sizeof *r);
        if (!r) {
            pthread_mutex_unlock(&s->mu);
            free(t);
            return;
        }
        s->rows = r;
        s->cap_rows = cap;
    }
    s->rows[s->n_rows++] = t;
    pthread_cond_broadcast(&s->cv);
    pthread_mutex_unlock(&s->mu);
}

/* A new run: pages drop what they show. */
static void new_run(live_state *s)
{
    fit_stream_free(s->fs);
    s->fs = NULL;
    s->fed = 0;
    s->n_ti = 0;
    s->last_err = NAN;
    s->final_curve = 0;
    pthread_mutex_lock(&s->mu);
    drop_rows(s);
    free(s->fit_text);
    s->fit_text = NULL;
    s->run++;
    pthread_cond_broadcast(&s->cv);
    pthread_mutex_unlock(&s->mu);
}

void live_state_note(live_state *s, const char *text)
{
    json_array_append_new(json_object_get(s->info, "alarms"), json_string(text));
    publish_info(s);
}

void live_state_close(live_state *s)
{
    pthread_mutex_lock(&s->mu);
    s->closed = 1;
    pthread_cond_broadcast(&s->cv);
    pthread_mutex_unlock(&s->mu);
}

/* ---- samples and the fit ------------------------------------------------ */

static double jnum(json_t *d, const char *key)
{
    json_t *v = json_object_get(d, key);
    return json_is_number(v) ? json_number_value(v) : NAN;
}

static int in_plane(const struct journal_sample *js)
{
    return js->phi_i == 0.0 && (js->phi_o == 0.0 || js->phi_o == 180.0);
}

static void note_incidence(live_state *s, double ti)
{
    for (size_t k = 0; k < s->n_ti; k++)
        if (fabs(s->ti[k] - ti) < 0.05)
            return;
    if (s->n_ti < LIVE_CURVE_INCIDENCES)
        s->ti[s->n_ti++] = ti;
}

static void curve_from(live_state *s, const brdf_material *m, const char *source, size_t n)
{
    publish_fit(s, live_curve_json(m, s->ti, s->n_ti, source, n));
}

/* One sample: kept as a row for the pages and fed to the live fit; a round
 * when force (goniod ran one at this sample). */
static void add_sample(live_state *s, const struct journal_sample *js, long seq, double err,
                       int force)
{
    int ip = in_plane(js);
    if (ip)
        note_incidence(s, js->theta_i);
    publish_row(s, json_pack("[I,f,f,f,f,f,b,f,o,b]", (json_int_t)seq, js->theta_i,
                             js->theta_r, js->rgb[0], js->rgb[1], js->rgb[2],
                             (js->flags & JOURNAL_FLAG_SATURATED) != 0, js->rig_time_s,
                             isfinite(err) ? json_real(err) : json_null(), ip));
    if (s->final_curve)
        return;
    struct gonio_err e;
    if (!s->fs) {
        struct fit_stream_options o = fit_stream_default_options();
        o.converge = 0;
        o.every = 0; /* rounds only when forced */
        if (fit_stream_new(&o, &s->fs, &e) < 0)
            return;
    }
    struct fit_sample fsamp;
    fit_journal_samples(js, 1, &fsamp);
    s->fed++;
    if (fit_stream_add(s->fs, &fsamp, force, &e) < 0 || !force)
        return;
    const struct brdf_abc *p = fit_stream_params(s->fs);
    brdf_material *m = p ? brdf_abc_material(p, "abc") : NULL;
    if (m) {
        char src[96];
        snprintf(src, sizeof src, "ABC fit of the first %zu samples, as goniod's fit round",
                 s->fed);
        curve_from(s, m, src, s->fed);
        brdf_material_free(m);
    }
}

/* The capture's model file as the curve: the final fit, any model. */
static int final_curve(live_state *s, const char *dir, const char *model_file)
{
    if (!dir || !model_file)
        return -1;
    char spec[4200];
    snprintf(spec, sizeof spec, "model:%s/%s", dir, model_file);
    struct gonio_err e;
    brdf_material *m = fit_material_open(spec, &e);
    if (!m) {
        char note[700];
        snprintf(note, sizeof note, "final fit not shown: %s", e.msg);
        live_state_note(s, note);
        return -1;
    }
    char src[160];
    snprintf(src, sizeof src, "final fit, %s", model_file);
    s->final_curve = 1;
    curve_from(s, m, src, s->n_rows);
    brdf_material_free(m);
    return 0;
}

/* ---- the stream's documents -------------------------------------------- */

static void set(live_state *s, const char *key, json_t *v)
{
    json_object_set_new(s->info, key, v ? v : json_null());
}

static void copy(live_state *s, json_t *d, const char *key)
{
    json_t *v = json_object_get(d, key);
    set(s, key, v ? json_incref(v) : NULL);
}

/* The final errors the page shows: the stop document's results
 * (err_plan.log_error) and results.json's errors (plan.log) name them
 * differently. */
static json_t *results_summary(json_t *errs, const char *plan, const char *full, const char *log)
{
    json_t *p = json_object_get(json_object_get(errs, plan), log);
    json_t *f = json_object_get(json_object_get(errs, full), log);
    return json_pack("{s:O?,s:O?}", "plan_log_error", p, "full_log_error", f);
}

static void on_start(live_state *s, json_t *d)
{
    new_run(s);
    json_decref(s->info);
    s->info = json_pack("{s:s,s:[],s:i}", "state", "running", "alarms", "saturated", 0);
    static const char *const keys[] = {"capture_id", "dir", "plan", "scene", "material",
                                       "model", "order", "rig", "total", "already_done",
                                       "estimate_s", "adaptive", "resume", "time"};
    for (size_t k = 0; k < sizeof keys / sizeof *keys; k++)
        copy(s, d, keys[k]);
    set(s, "done", json_incref(json_object_get(d, "already_done")));
    set(s, "rig_time_s", json_real(0));
    publish_info(s);
}

static void on_descriptor(live_state *s, json_t *d)
{
    json_t *drv = json_object_get(d, "driver"), *rig = json_object_get(d, "rig");
    set(s, "driver", json_incref(json_object_get(drv, "kind")));
    set(s, "rig_name", json_incref(json_object_get(rig, "name")));
    publish_info(s);
}

static void on_event(live_state *s, json_t *d)
{
    struct journal_sample js = {
        .point = (int)json_integer_value(json_object_get(d, "point")),
        .theta_i = jnum(d, "theta_i"), .theta_r = jnum(d, "theta_r"),
        .phi_i = jnum(d, "phi_i"), .theta_o = jnum(d, "theta_o"), .phi_o = jnum(d, "phi_o"),
        .s = jnum(d, "s"), .a = jnum(d, "a"), .integration_s = jnum(d, "integration_s"),
        .rig_time_s = jnum(d, "rig_time_s"),
        .flags = json_is_true(json_object_get(d, "saturated")) ? JOURNAL_FLAG_SATURATED : 0};
    json_t *rgb = json_object_get(d, "rgb");
    for (int c = 0; c < 3; c++)
        js.rgb[c] = json_number_value(json_array_get(rgb, (size_t)c));
    double fe = jnum(d, "fit_log_error"), pe = jnum(d, "predicted_error");
    /* a new value of goniod's fit error is a round it ran at this sample */
    int round = isfinite(fe) && !(fe == s->last_err);
    if (isfinite(fe))
        s->last_err = fe;
    add_sample(s, &js, (long)json_integer_value(json_object_get(d, "seq")),
               isfinite(fe) ? fe : pe, round);
    static const char *const keys[] = {"done", "total", "rig_time_s", "eta_s", "s", "a",
                                       "integration_s", "predicted_next", "predicted_next_s"};
    for (size_t k = 0; k < sizeof keys / sizeof *keys; k++)
        copy(s, d, keys[k]);
    set(s, "error", isfinite(fe) || isfinite(pe) ? json_real(isfinite(fe) ? fe : pe) : NULL);
    set(s, "error_kind", json_string(isfinite(fe) ? "fit" : "predicted"));
    if (js.flags & JOURNAL_FLAG_SATURATED)
        set(s, "saturated",
            json_integer(json_integer_value(json_object_get(s->info, "saturated")) + 1));
    publish_info(s);
}

static void on_stop(live_state *s, json_t *d)
{
    const char *status = json_string_value(json_object_get(d, "exit_status"));
    const char *reason = json_string_value(json_object_get(d, "reason"));
    set(s, "state", json_string(!status                     ? "stopped"
                                : !strcmp(status, "success") ? "complete"
                                : !strcmp(status, "abort")   ? "aborted"
                                                             : "failed"));
    copy(s, d, "reason");
    copy(s, d, "rig_time_s");
    copy(s, d, "comm");
    set(s, "eta_s", json_real(0));
    json_t *res = json_object_get(d, "results");
    if (res)
        set(s, "results", results_summary(res, "err_plan", "err_full", "log_error"));
    const char *msg = json_string_value(json_object_get(d, "message"));
    if (status && strcmp(status, "success")) {
        char note[600];
        snprintf(note, sizeof note, "capture %s: %s", reason ? reason : status,
                 msg ? msg : "no results");
        live_state_note(s, note);
    }
    publish_info(s);
    final_curve(s, json_string_value(json_object_get(d, "dir")),
                json_string_value(json_object_get(res, "model_file")));
}

void live_state_feed(live_state *s, json_t *doc)
{
    const char *cls = json_string_value(json_object_get(doc, "class"));
    if (!cls)
        return;
    if (!strcmp(cls, "start")) {
        on_start(s, doc);
    } else if (!strcmp(cls, "descriptor")) {
        on_descriptor(s, doc);
    } else if (!strcmp(cls, "event")) {
        on_event(s, doc);
    } else if (!strcmp(cls, "state")) {
        copy(s, doc, "state");
        publish_info(s);
    } else if (!strcmp(cls, "stop")) {
        on_stop(s, doc);
    } else if (!strcmp(cls, "ERROR")) {
        char note[600];
        snprintf(note, sizeof note, "goniod: %s",
                 json_string_value(json_object_get(doc, "message")));
        live_state_note(s, note);
    }
}

/* ---- a capture directory ------------------------------------------------ */

int live_state_load_dir(live_state *s, const char *dir, struct gonio_err *err)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/samples.csv", dir);
    struct journal_sample *js = NULL;
    size_t n = 0;
    int rc = journal_read(path, &js, &n, err);
    if (rc < 0)
        return rc;
    new_run(s);
    snprintf(path, sizeof path, "%s/results.json", dir);
    json_t *res = json_load_file(path, 0, NULL);
    const char *slash = strrchr(dir, '/');
    json_decref(s->info);
    s->info = json_pack("{s:s,s:[],s:s,s:s,s:I,s:I,s:f,s:f,s:i}", "state",
                        res ? "complete" : "stopped", "alarms", "capture_id",
                        slash && slash[1] ? slash + 1 : dir, "dir", dir, "done", (json_int_t)n,
                        "total", (json_int_t)n, "rig_time_s", n ? js[n - 1].rig_time_s : 0.0,
                        "eta_s", 0.0, "saturated", 0);
    copy(s, res, "plan");
    copy(s, res, "model");
    if (res)
        set(s, "results", results_summary(json_object_get(res, "errors"), "plan", "full", "log"));
    else
        live_state_note(s, "no results.json: the capture was not fitted (aborted, failed or "
                           "still running)");
    s->final_curve = 1; /* no live rounds: the model file, or no curve */
    for (size_t k = 0; k < n; k++)
        add_sample(s, &js[k], (long)k + 1, NAN, 0);
    int sat = 0;
    for (size_t k = 0; k < n; k++)
        sat += (js[k].flags & JOURNAL_FLAG_SATURATED) != 0;
    set(s, "saturated", json_integer(sat));
    publish_info(s);
    final_curve(s, dir, json_string_value(json_object_get(res, "model_file")));
    json_decref(res);
    free(js);
    return 0;
}

/* ---- pages -------------------------------------------------------------- */

/* Append "event: NAME\ndata: TEXT\n\n" to the buffer b (size *len, cap *cap). */
static int sse(char **b, size_t *len, size_t *cap, const char *name, const char *pre,
               const char *text, const char *post)
{
    size_t need = strlen(name) + strlen(pre) + strlen(text) + strlen(post) + 20;
    if (*len + need + 1 > *cap) {
        size_t c = (*len + need + 1) * 2;
        char *nb = realloc(*b, c);
        if (!nb)
            return -1;
        *b = nb;
        *cap = c;
    }
    *len += (size_t)sprintf(*b + *len, "event: %s\ndata: %s%s%s\n\n", name, pre, text, post);
    return 0;
}

static int has_news(const live_state *s, const struct live_cursor *c)
{
    return c->run != s->run || c->samples < s->n_rows || c->info_ver != s->info_ver ||
           (s->fit_text && c->fit_ver != s->fit_ver);
}

/* The rows from c->samples, at most max: {"from":k,"rows":[...]}. */
static int rows_text(live_state *s, struct live_cursor *c, size_t max, char **b, size_t *len,
                     size_t *cap)
{
    size_t end = s->n_rows - c->samples > max ? c->samples + max : s->n_rows;
    size_t total = 64;
    for (size_t k = c->samples; k < end; k++)
        total += strlen(s->rows[k]) + 1;
    char *t = malloc(total), *p = t;
    if (!t)
        return -1;
    p += sprintf(p, "{\"from\":%zu,\"rows\":[", c->samples);
    for (size_t k = c->samples; k < end; k++)
        p += sprintf(p, "%s%s", k > c->samples ? "," : "", s->rows[k]);
    sprintf(p, "]}");
    int rc = sse(b, len, cap, "samples", "", t, "");
    free(t);
    c->samples = end;
    return rc;
}

char *live_state_next(live_state *s, struct live_cursor *c, int timeout_ms, size_t max_samples,
                      size_t *len)
{
    struct timespec until;
    clock_gettime(CLOCK_MONOTONIC, &until);
    until.tv_sec += timeout_ms / 1000;
    until.tv_nsec += (long)(timeout_ms % 1000) * 1000000L;
    if (until.tv_nsec >= 1000000000L) {
        until.tv_sec++;
        until.tv_nsec -= 1000000000L;
    }
    char *b = NULL;
    size_t cap = 0;
    *len = 0;
    pthread_mutex_lock(&s->mu);
    while (!s->closed && !has_news(s, c))
        if (pthread_cond_timedwait(&s->cv, &s->mu, &until) == ETIMEDOUT)
            break;
    if (s->closed) {
        pthread_mutex_unlock(&s->mu);
        *len = 1;
        return NULL;
    }
    int rc = 0;
    if (c->run != s->run) {
        char t[48];
        snprintf(t, sizeof t, "{\"run\":%lu}", s->run);
        rc |= sse(&b, len, &cap, "reset", "", t, "");
        c->run = s->run;
        c->samples = 0;
        c->fit_ver = 0;
    }
    if (c->info_ver != s->info_ver && s->info_text) {
        rc |= sse(&b, len, &cap, "info", "", s->info_text, "");
        c->info_ver = s->info_ver;
    }
    if (c->samples < s->n_rows)
        rc |= rows_text(s, c, max_samples ? max_samples : 1, &b, len, &cap);
    /* the curve after the samples it was fitted to */
    if (s->fit_text && c->fit_ver != s->fit_ver) {
        rc |= sse(&b, len, &cap, "fit", "", s->fit_text, "");
        c->fit_ver = s->fit_ver;
    }
    pthread_mutex_unlock(&s->mu);
    if (rc) {
        free(b);
        b = NULL;
        *len = 0;
    }
    return b;
}
