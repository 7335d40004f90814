/* The calibration root's calibrations as an operator reads them
 * (daemon/calibrations.h). */
#include "daemon/calibrations.h"

#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

/* Whether dir/name is a regular file; *mtime raised to its time when so. */
static int stat_file(const char *dir, const char *name, struct timespec *mtime)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    struct stat st;
    if (lstat(path, &st) != 0 || !S_ISREG(st.st_mode))
        return 0;
    if (st.st_mtim.tv_sec > mtime->tv_sec ||
        (st.st_mtim.tv_sec == mtime->tv_sec && st.st_mtim.tv_nsec > mtime->tv_nsec))
        *mtime = st.st_mtim;
    return 1;
}

static json_t *load(const char *dir, const char *name, struct timespec *mtime)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    return stat_file(dir, name, mtime) ? json_load_file(path, 0, NULL) : NULL;
}

/* The frames a journal holds: its whole lines after the header (a torn
 * last line is not a frame, as the run's own reading of it holds). */
static json_int_t journal_frames(const char *dir, struct timespec *mtime)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/journal.csv", dir);
    FILE *f = stat_file(dir, "journal.csv", mtime) ? fopen(path, "r") : NULL;
    if (!f)
        return 0;
    json_int_t lines = 0;
    int ch;
    while ((ch = getc(f)) != EOF)
        lines += ch == '\n';
    fclose(f);
    return lines > 0 ? lines - 1 : 0;
}

static void iso_time(time_t t, char *out, size_t size)
{
    struct tm tm;
    gmtime_r(&t, &tm);
    strftime(out, size, "%Y-%m-%dT%H:%M:%SZ", &tm);
}

static const char *jstr(json_t *d, const char *key)
{
    const char *v = json_string_value(json_object_get(d, key));
    return v ? v : "";
}

static json_t *string_or_null(json_t *v)
{
    return json_is_string(v) && json_string_length(v) ? json_incref(v) : json_null();
}

/* The state of a calibration that has no calibration.json: the live run's,
 * its end record's, else interrupted. */
static const char *unfinished_state(const char *id, const struct captures_live *live,
                                    json_t *stop)
{
    if (live->id && !strcmp(live->id, id))
        return live->state;
    const char *s = json_string_value(json_object_get(stop, "state"));
    return s ? s : "interrupted";
}

/* One calibration's entry, NULL when root/id is none. */
static json_t *entry(const char *root, const char *id, const struct captures_live *live,
                     time_t now, struct timespec *changed)
{
    char dir[4096];
    snprintf(dir, sizeof dir, "%s/%s", root, id);
    struct stat sb;
    if (lstat(dir, &sb) != 0 || !S_ISDIR(sb.st_mode))
        return NULL;
    struct timespec mtime = {0, 0};
    json_t *cal = load(dir, "calibration.json", &mtime), *req = load(dir, "request.json", &mtime);
    json_t *stop = load(dir, "stop.json", &mtime), *e = NULL;
    json_int_t done = journal_frames(dir, &mtime);
    int live_run = live->id && !strcmp(live->id, id);
    if (!json_is_object(cal) && !json_is_object(req))
        goto out; /* neither goniod's record nor a calibration */
    /* calibration.json says what was measured; before it, the record */
    json_t *src = json_is_object(cal) ? cal : req;
    json_int_t created = json_integer_value(json_object_get(src, json_is_object(cal)
                                                                     ? "created_unix"
                                                                     : "created"));
    const char *state;
    if (json_is_object(cal) && !live_run) {
        double valid_s = json_number_value(json_object_get(cal, "valid_s"));
        state = now > (time_t)created + (time_t)valid_s ? "expired" : "complete";
        done = json_integer_value(json_object_get(cal, "frames"));
    } else {
        state = unfinished_state(id, live, stop);
    }
    if (live_run) {
        done = (json_int_t)live->done;
        clock_gettime(CLOCK_REALTIME, &mtime);
    }
    char when[32], made[32];
    iso_time(mtime.tv_sec, when, sizeof when);
    iso_time((time_t)created, made, sizeof made);
    e = json_object();
    json_object_set_new(e, "id", json_string(id));
    json_object_set_new(e, "kind", string_or_null(json_object_get(src, "kind")));
    json_object_set_new(e, "state", json_string(state));
    json_object_set_new(e, "reason", json_string(jstr(stop, "reason")));
    json_object_set_new(e, "message", json_string(jstr(stop, "message")));
    /* the record names the rig profile and detector goniod resolved */
    json_object_set_new(e, "rig", string_or_null(json_object_get(src, json_is_object(cal)
                                                                          ? "rig" : "rig_name")));
    json_object_set_new(e, "detector", string_or_null(json_object_get(src, "detector")));
    json_object_set_new(e, "created", created ? json_string(made) : json_null());
    json_object_set_new(e, "expires", string_or_null(json_object_get(cal, "expires")));
    json_object_set_new(e, "frames_done", json_integer(done));
    json_object_set_new(e, "frames_total", live_run ? json_integer((json_int_t)live->total)
                                                    : json_is_object(cal) ? json_integer(done)
                                                                          : json_null());
    json_object_set_new(e, "last_change", json_string(when));
    *changed = mtime;
out:
    json_decref(cal);
    json_decref(req);
    json_decref(stop);
    return e;
}

struct entry_context {
    const struct captures_live *live;
    time_t now;
};

static json_t *calibration_entry(const char *root, const char *id, const void *ctx,
                                 struct timespec *changed)
{
    const struct entry_context *c = ctx;
    return entry(root, id, c->live, c->now, changed);
}

json_t *calibrations_list(const char *root, const struct captures_live *live, time_t now)
{
    struct entry_context c = {live, now};
    return captures_list_dir(root, calibration_entry, &c);
}
