/* The capture root's captures: their end records and the list an operator
 * reads (daemon/captures.h). */
#include "daemon/captures.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "common/paths.h"
#include "fit/fit_status.h"
#include "journal/journal.h"

static const char stop_file[] = "stop.json";

/* name under the directory parent, removed: a directory with what it
 * holds (depth bounds the descent), anything else (a link too) unlinked. */
static int remove_at(int parent, const char *name, int depth)
{
    int fd = depth < 16 ? openat(parent, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW) : -1;
    if (fd < 0)
        return unlinkat(parent, name, 0);
    DIR *d = fdopendir(fd);
    if (!d) {
        close(fd);
        return -1;
    }
    int rc = 0;
    for (struct dirent *e; (e = readdir(d));) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        struct stat st;
        if (fstatat(fd, e->d_name, &st, AT_SYMLINK_NOFOLLOW) < 0)
            rc = -1;
        else if (S_ISDIR(st.st_mode) ? remove_at(fd, e->d_name, depth + 1) < 0
                                      : unlinkat(fd, e->d_name, 0) < 0)
            rc = -1;
    }
    closedir(d);
    return unlinkat(parent, name, AT_REMOVEDIR) < 0 ? -1 : rc;
}

int captures_remove(const char *dir)
{
    return remove_at(AT_FDCWD, dir, 0);
}

static json_t *number_or_null(double v)
{
    return isfinite(v) ? json_real(v) : json_null();
}

static void iso_time(time_t t, char *out, size_t size)
{
    struct tm tm;
    gmtime_r(&t, &tm);
    strftime(out, size, "%Y-%m-%dT%H:%M:%SZ", &tm);
}

int captures_record_stop(const char *dir, const struct captures_stop *stop,
                         struct gonio_err *err)
{
    char when[32];
    time_t now = time(NULL);
    iso_time(now, when, sizeof when);
    json_t *d = json_object();
    json_object_set_new(d, "state", json_string(stop->state));
    json_object_set_new(d, "reason", json_string(stop->reason));
    json_t *msg = json_string(stop->message ? stop->message : "");
    json_object_set_new(d, "message", msg ? msg : json_string("(not UTF-8)"));
    json_object_set_new(d, "time", json_string(when));
    const struct capture_summary *s = stop->summary;
    if (s) {
        json_object_set_new(d, "samples", json_integer((json_int_t)s->samples));
        json_object_set_new(d, "rig_time_s", number_or_null(s->rig_time_s));
        if (!strcmp(stop->state, "complete")) { /* the final fit's verdict */
            json_object_set_new(d, "fit_status",
                                json_string(fit_status_name(fit_status_code(&s->status))));
            json_object_set_new(d, "plan_log_error", number_or_null(s->err_plan.log));
        }
    }
    char *text = json_dumps(d, JSON_COMPACT);
    json_decref(d);
    if (!text)
        return gonio_err_set(err, ENOMEM, "out of memory");
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", dir, stop_file);
    int rc = gonio_write_file_atomic(path, text, strlen(text), err);
    free(text);
    return rc;
}

void captures_clear_stop(const char *dir)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", dir, stop_file);
    unlink(path);
}

/* dir/name parsed, or NULL; *mtime raised to the file's when it exists. */
static json_t *load(const char *dir, const char *name, struct timespec *mtime)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    struct stat st;
    if (lstat(path, &st) != 0 || !S_ISREG(st.st_mode))
        return NULL;
    if (mtime && (st.st_mtim.tv_sec > mtime->tv_sec ||
                  (st.st_mtim.tv_sec == mtime->tv_sec && st.st_mtim.tv_nsec > mtime->tv_nsec)))
        *mtime = st.st_mtim;
    return json_load_file(path, 0, NULL);
}

static int has_file(const char *dir, const char *name, struct timespec *mtime)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    struct stat st;
    if (lstat(path, &st) != 0 || !S_ISREG(st.st_mode))
        return 0;
    if (mtime && (st.st_mtim.tv_sec > mtime->tv_sec ||
                  (st.st_mtim.tv_sec == mtime->tv_sec && st.st_mtim.tv_nsec > mtime->tv_nsec)))
        *mtime = st.st_mtim;
    return 1;
}

void captures_end_state(const char *dir, char *state, size_t size)
{
    json_t *req = load(dir, "request.json", NULL);
    json_t *stop = req ? load(dir, stop_file, NULL) : NULL;
    const char *s = json_string_value(json_object_get(stop, "state"));
    snprintf(state, size, "%s",
             !req ? "" : s ? s : has_file(dir, "results.json", NULL) ? "complete" : "interrupted");
    json_decref(stop);
    json_decref(req);
}

static const char *jstr(json_t *d, const char *key)
{
    const char *v = json_string_value(json_object_get(d, key));
    return v ? v : "";
}

/* One capture's entry, NULL when dir is no goniod capture. */
static json_t *entry(const char *root, const char *id, const struct captures_live *live,
                     struct timespec *changed)
{
    char dir[4200];
    snprintf(dir, sizeof dir, "%s/%s", root, id);
    struct stat sb;
    if (lstat(dir, &sb) != 0 || !S_ISDIR(sb.st_mode))
        return NULL; /* a link is no capture (as resume holds) */
    struct timespec mtime = {0, 0};
    json_t *req = load(dir, "request.json", &mtime);
    if (!json_is_object(req)) {
        json_decref(req);
        return NULL;
    }
    json_t *plan = load(dir, "plan.json", &mtime), *stop = load(dir, stop_file, &mtime);
    int has_results = has_file(dir, "results.json", &mtime);
    /* The journal: what was measured, in every run so far. */
    char path[4300];
    snprintf(path, sizeof path, "%s/samples.csv", dir);
    struct journal_sample *samples = NULL;
    size_t n = 0;
    struct gonio_err err = {0};
    double rig_time_s = 0;
    if (has_file(dir, "samples.csv", &mtime) && journal_read(path, &samples, &n, &err) == 0 &&
        n > 0)
        rig_time_s = samples[n - 1].rig_time_s;
    free(samples);
    json_int_t total = json_integer_value(json_object_get(plan, "count"));
    const char *plan_name = json_string_value(json_object_get(plan, "plan"));
    const char *state = json_string_value(json_object_get(stop, "state"));
    if (!state)
        state = has_results ? "complete" : "interrupted";
    if (live->id && !strcmp(live->id, id)) {
        state = live->state;
        n = live->done;
        total = (json_int_t)live->total;
        rig_time_s = live->rig_time_s;
        clock_gettime(CLOCK_REALTIME, &mtime);
    } else if (json_is_number(json_object_get(stop, "rig_time_s"))) {
        rig_time_s = json_number_value(json_object_get(stop, "rig_time_s"));
    }
    char when[32];
    iso_time(mtime.tv_sec, when, sizeof when);
    json_t *e = json_object();
    json_object_set_new(e, "id", json_string(id));
    json_object_set_new(e, "plan", json_string(plan_name ? plan_name : jstr(req, "plan")));
    json_object_set_new(e, "state", json_string(state));
    json_object_set_new(e, "reason", json_string(jstr(stop, "reason")));
    json_object_set_new(e, "message", json_string(jstr(stop, "message")));
    json_object_set_new(e, "samples_done", json_integer((json_int_t)n));
    json_object_set_new(e, "samples_total", json_integer(total));
    json_object_set_new(e, "rig_time_s", number_or_null(rig_time_s));
    json_object_set_new(e, "last_change", json_string(when));
    json_t *fs = json_object_get(stop, "fit_status"), *pe = json_object_get(stop, "plan_log_error");
    json_object_set_new(e, "fit_status", json_is_string(fs) ? json_incref(fs) : json_null());
    json_object_set_new(e, "plan_log_error", json_is_number(pe) ? json_incref(pe) : json_null());
    static const char *const meta[] = {"sample", "operator", "note"}; /* request.json's */
    for (int k = 0; k < 3; k++) {
        json_t *v = json_object_get(req, meta[k]);
        json_object_set_new(e, meta[k], json_is_string(v) && json_string_length(v)
                                            ? json_incref(v) : json_null());
    }
    json_decref(stop);
    json_decref(plan);
    json_decref(req);
    *changed = mtime;
    return e;
}

struct listed {
    json_t *e;
    struct timespec changed;
};

static int newest_first(const void *a, const void *b)
{
    const struct listed *x = a, *y = b;
    if (x->changed.tv_sec != y->changed.tv_sec)
        return x->changed.tv_sec < y->changed.tv_sec ? 1 : -1;
    if (x->changed.tv_nsec != y->changed.tv_nsec)
        return x->changed.tv_nsec < y->changed.tv_nsec ? 1 : -1;
    /* The same instant: the ids, which goniod makes sortable by start time. */
    return -strcmp(json_string_value(json_object_get(x->e, "id")),
                   json_string_value(json_object_get(y->e, "id")));
}

json_t *captures_list_dir(const char *root, captures_entry_fn *entry_of, const void *ctx)
{
    json_t *out = json_array();
    DIR *d = opendir(root);
    if (!d || !out) {
        if (d)
            closedir(d);
        return out;
    }
    struct listed *v = NULL;
    size_t n = 0, cap = 0;
    struct dirent *de;
    while ((de = readdir(d))) {
        if (de->d_name[0] == '.')
            continue;
        struct timespec changed = {0, 0};
        json_t *e = entry_of(root, de->d_name, ctx, &changed);
        if (!e)
            continue;
        if (n == cap) {
            size_t ncap = cap ? 2 * cap : 16;
            struct listed *nv = realloc(v, ncap * sizeof *nv);
            if (!nv) {
                json_decref(e);
                break;
            }
            v = nv;
            cap = ncap;
        }
        v[n++] = (struct listed){e, changed};
    }
    closedir(d);
    if (n)
        qsort(v, n, sizeof *v, newest_first);
    for (size_t i = 0; i < n; i++)
        json_array_append_new(out, v[i].e);
    free(v);
    return out;
}

static json_t *capture_entry(const char *root, const char *id, const void *live,
                             struct timespec *changed)
{
    return entry(root, id, live, changed);
}

json_t *captures_list(const char *root, const struct captures_live *live)
{
    return captures_list_dir(root, capture_entry, live);
}
