#define _XOPEN_SOURCE 700 /* realpath */
#include "daemon/control.h"

#include <errno.h>
#include <fcntl.h>
#include <dirent.h>
#include <grp.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#include <jansson.h>

#include "common/paths.h"
#include "daemon/peer.h"
#include "daemon/request.h"
#include "planner/rig.h"

#ifndef GONIO_RELEASE
#define GONIO_RELEASE "0.0.0"
#endif

struct client {
    int fd;
    size_t max_out;    /* queued output beyond this drops the client */
    char *in;          /* CONTROL_MAX_LINE + 1 bytes */
    size_t in_len;
    char *out;
    size_t out_len, out_cap;
    int watching;
    int closing;       /* close once out is sent */
    int dead;
    double last_active; /* last complete request (or the connect) */
    double tokens;      /* rate limit: requests it may send now */
    double tokens_at;   /* when tokens was last refilled */
};

struct control {
    const struct goniod_config *cfg;
    worker *w;
    int listen_fd;
    uid_t self_uid;     /* goniod's own user: always allowed */
    gid_t allowed_gid;  /* peers in this group are allowed (socket.group, else ours) */
    struct client **clients;
    size_t n_clients;
    int shutdown;
    /* The running capture's start and descriptor documents, for watchers
     * that subscribe mid-capture; NULL when idle. */
    char *start_doc, *descriptor_doc;
    unsigned long long seq; /* event sequence number within a capture */
};

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ---- output ---------------------------------------------------------- */

static void client_drop(struct client *cl, const char *why)
{
    if (!cl->dead && why)
        fprintf(stderr, "goniod: client %d dropped: %s\n", cl->fd, why);
    cl->dead = 1;
}

static void client_try_write(struct client *cl)
{
    while (!cl->dead && cl->out_len > 0) {
        ssize_t n = send(cl->fd, cl->out, cl->out_len, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (n < 0) {
            if (errno == EINTR)
                continue;
            if (errno != EAGAIN && errno != EWOULDBLOCK)
                client_drop(cl, NULL); /* gone: a disconnect is not news */
            return;
        }
        memmove(cl->out, cl->out + n, cl->out_len - (size_t)n);
        cl->out_len -= (size_t)n;
    }
    if (!cl->dead && cl->closing && cl->out_len == 0)
        cl->dead = 1;
}

/* Queue one line; a client whose queue would pass the limit is dropped. */
static void client_send_text(struct client *cl, const char *text)
{
    if (cl->dead)
        return;
    size_t len = strlen(text);
    if (cl->out_len + len + 1 > cl->max_out) {
        client_drop(cl, "too slow to read its output");
        return;
    }
    if (cl->out_len + len + 1 > cl->out_cap) {
        size_t cap = cl->out_cap ? cl->out_cap : 4096;
        while (cap < cl->out_len + len + 1)
            cap *= 2;
        char *p = realloc(cl->out, cap);
        if (!p) {
            client_drop(cl, "out of memory");
            return;
        }
        cl->out = p;
        cl->out_cap = cap;
    }
    memcpy(cl->out + cl->out_len, text, len);
    cl->out[cl->out_len + len] = '\n';
    cl->out_len += len + 1;
    client_try_write(cl);
}

static char *dump(json_t *doc)
{
    char *s = json_dumps(doc, JSON_COMPACT | JSON_PRESERVE_ORDER);
    json_decref(doc);
    return s;
}

static void client_send(struct client *cl, json_t *doc)
{
    char *s = dump(doc);
    if (s)
        client_send_text(cl, s);
    else
        client_drop(cl, "out of memory");
    free(s);
}

/* NaN and infinities have no JSON form: they become null. */
static json_t *jnum(double v)
{
    return isfinite(v) ? json_real(v) : json_null();
}

static json_t *error_doc(const char *code, const char *msg, json_t *id)
{
    json_t *e = json_object();
    json_object_set_new(e, "class", json_string("ERROR"));
    if (id)
        json_object_set(e, "id", id);
    json_object_set_new(e, "code", json_string(code));
    /* Messages come from files and requests: make sure they are UTF-8. */
    json_t *m = json_string(msg);
    json_object_set_new(e, "message", m ? m : json_string("(message not valid UTF-8)"));
    return e;
}

static void send_error(struct client *cl, const char *code, json_t *id, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

static void send_error(struct client *cl, const char *code, json_t *id, const char *fmt, ...)
{
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    client_send(cl, error_doc(code, msg, id));
}

static void broadcast(control *c, const char *text)
{
    for (size_t i = 0; i < c->n_clients; i++)
        if (c->clients[i]->watching)
            client_send_text(c->clients[i], text);
}

/* ---- requests: names and paths --------------------------------------- */

/* A capture id: one path component of safe characters. */
static int valid_id(const char *s)
{
    size_t n = strlen(s);
    if (n == 0 || n > 100 || s[0] == '.' || s[0] == '-')
        return 0;
    for (size_t i = 0; i < n; i++)
        if (!((s[i] >= 'a' && s[i] <= 'z') || (s[i] >= 'A' && s[i] <= 'Z') ||
              (s[i] >= '0' && s[i] <= '9') || s[i] == '.' || s[i] == '_' || s[i] == '-'))
            return 0;
    return 1;
}

/* Where a path named by a request may lead. */
enum { PATH_OK = 0, PATH_BAD = -1, PATH_MISSING = -2, PATH_ESCAPES = -3 };

/* path (absolute) must exist and its real path lie inside the capture
 * root's real path: a symbolic link inside the root that points out of it
 * is refused. out gets the real path, which is what the capture opens, so
 * no link is followed a second time. */
static int inside_root(const control *c, const char *path, char *out, size_t size)
{
    char root[PATH_MAX], real[PATH_MAX];
    if (!realpath(c->cfg->capture_root, root))
        return PATH_MISSING;
    if (!realpath(path, real))
        return errno == ENOENT || errno == ENOTDIR ? PATH_MISSING : PATH_BAD;
    size_t n = strlen(root);
    if (n > 1 && (strncmp(real, root, n) || real[n] != '/'))
        return PATH_ESCAPES;
    if (strlen(real) >= size)
        return PATH_BAD;
    memcpy(out, real, strlen(real) + 1);
    return PATH_OK;
}

/* A file named by a request: a relative path with no '..' component, taken
 * inside the capture root, so a client can read nothing outside it. */
static int root_path(const control *c, const char *rel, char *out, size_t size)
{
    if (!rel[0] || rel[0] == '/')
        return PATH_BAD;
    for (const char *p = rel; *p;) {
        size_t len = strcspn(p, "/");
        if (len == 2 && p[0] == '.' && p[1] == '.')
            return PATH_BAD;
        p += len;
        if (*p == '/')
            p++;
    }
    char joined[PATH_MAX];
    int n = snprintf(joined, sizeof joined, "%s/%s", c->cfg->capture_root, rel);
    if (n < 0 || (size_t)n >= sizeof joined)
        return PATH_BAD;
    return inside_root(c, joined, out, size);
}

static int path_error(struct gonio_err *err, int why, const char *what, const char *v)
{
    if (why == PATH_MISSING)
        return gonio_err_set(err, GONIO_EUSAGE, "%s '%s': no such file in the capture root",
                             what, v);
    if (why == PATH_ESCAPES)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "%s '%s': leads outside the capture root (symbolic link)", what,
                             v);
    return gonio_err_set(err, GONIO_EUSAGE,
                         "%s '%s': a path must be relative to the capture root, without '..'",
                         what, v);
}

/* A plan, scene or rig: a bare name from the configs folder, or a file
 * inside the capture root. */
static int resolve_ref(const control *c, const char *what, const char *v, char *out,
                       size_t size, struct gonio_err *err)
{
    if (gonio_ref_is_file(v)) {
        int why = root_path(c, v, out, size);
        return why < 0 ? path_error(err, why, what, v) : 0;
    }
    if (!valid_id(v))
        return gonio_err_set(err, GONIO_EUSAGE, "%s '%s': not a valid name", what, v);
    snprintf(out, size, "%s", v);
    return 0;
}

static int resolve_material(const control *c, const char *v, char *out, size_t size,
                            struct gonio_err *err)
{
    const char *colon = strchr(v, ':');
    if (!colon) {
        if (!valid_id(v))
            return gonio_err_set(err, GONIO_EUSAGE, "material '%s': not a material spec", v);
        snprintf(out, size, "%s", v);
        return 0;
    }
    const char *rest = colon + 1;
    if (!strncmp(v, "merl:", 5)) {
        char path[2048];
        int why = root_path(c, rest, path, sizeof path);
        if (why < 0)
            return path_error(err, why, "material", v);
        if (strlen(path) + 6 > size)
            return gonio_err_set(err, GONIO_EUSAGE, "material '%.100s': path too long", v);
        memcpy(out, "merl:", 5);
        memcpy(out + 5, path, strlen(path) + 1);
        return 0;
    }
    if (!valid_id(rest))
        return gonio_err_set(err, GONIO_EUSAGE, "material '%s': not a valid name", v);
    snprintf(out, size, "%s", v);
    return 0;
}

/* ---- the capture's request record (for resume) ------------------------ */

/* Look for a symbolic link among dir's entries: *link names the first one
 * found (in name), NULL when there is none. Returns -1 when dir cannot be
 * read. */
static int dir_symlink(const char *dir, char *name, size_t size, const char **link)
{
    *link = NULL;
    int fd = open(dir, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    DIR *dp = fd >= 0 ? fdopendir(fd) : NULL;
    if (!dp) {
        if (fd >= 0)
            close(fd);
        return -1;
    }
    struct dirent *e;
    while ((e = readdir(dp))) {
        struct stat st;
        if (fstatat(fd, e->d_name, &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISLNK(st.st_mode)) {
            snprintf(name, size, "%s", e->d_name);
            *link = name;
            break;
        }
    }
    closedir(dp);
    return 0;
}

static const char request_file[] = "request.json";

static int save_request(const struct worker_request *r, struct gonio_err *err)
{
    json_t *d = json_pack("{s:s, s:s, s:s, s:s, s:s, s:s, s:s, s:s}", "id", r->id, "plan",
                          r->plan, "scene", r->scene, "rig", r->rig, "material", r->material,
                          "model", r->model, "order", r->order, "stop", r->stop);
    char *text = d ? dump(d) : NULL;
    if (!text)
        return gonio_err_set(err, ENOMEM, "out of memory");
    char path[2304];
    snprintf(path, sizeof path, "%s/%s", r->dir, request_file);
    int rc = gonio_write_file_atomic(path, text, strlen(text), err);
    free(text);
    return rc;
}

static int load_request(const control *c, struct worker_request *r, struct gonio_err *err)
{
    char path[2304];
    snprintf(path, sizeof path, "%s/%s", r->dir, request_file);
    json_error_t je;
    json_t *d = json_load_file(path, JSON_REJECT_DUPLICATES, &je);
    if (!d)
        return gonio_err_set(err, GONIO_ENOTFOUND,
                             "capture '%s' has no readable %s (%s): not a goniod capture",
                             r->id, request_file, je.text);
    const char *plan, *scene, *rig, *material, *model, *order, *stop;
    if (json_unpack(d, "{s:s, s:s, s:s, s:s, s:s, s:s, s:s}", "plan", &plan, "scene", &scene,
                    "rig", &rig, "material", &material, "model", &model, "order", &order,
                    "stop", &stop) < 0) {
        json_decref(d);
        return gonio_err_set(err, GONIO_EBADDATA, "%s: lacks a field goniod writes", path);
    }
    /* goniod wrote these checked, but the record is a file: its paths are
     * held to the capture root again before anything is opened. */
    const char *merl = !strncmp(material, "merl:", 5) ? material + 5 : NULL;
    int why = PATH_OK;
    if ((strchr(plan, '/') && (why = inside_root(c, plan, r->plan, sizeof r->plan)) < 0) ||
        (strchr(scene, '/') && (why = inside_root(c, scene, r->scene, sizeof r->scene)) < 0) ||
        (strchr(rig, '/') && (why = inside_root(c, rig, r->rig, sizeof r->rig)) < 0) ||
        (merl && (why = inside_root(c, merl, r->material + 5, sizeof r->material - 5)) < 0)) {
        json_decref(d);
        return gonio_err_set(err, GONIO_EBADDATA,
                             "%s: a file it names is missing or lies outside the capture root",
                             path);
    }
    if (!strchr(plan, '/'))
        snprintf(r->plan, sizeof r->plan, "%s", plan);
    if (!strchr(scene, '/'))
        snprintf(r->scene, sizeof r->scene, "%s", scene);
    if (!strchr(rig, '/'))
        snprintf(r->rig, sizeof r->rig, "%s", rig);
    if (merl)
        memcpy(r->material, "merl:", 5);
    else
        snprintf(r->material, sizeof r->material, "%s", material);
    snprintf(r->model, sizeof r->model, "%s", model);
    snprintf(r->order, sizeof r->order, "%s", order);
    snprintf(r->stop, sizeof r->stop, "%s", stop);
    json_decref(d);
    return 0;
}

/* ---- commands -------------------------------------------------------- */

enum need { NEED_ANY, NEED_IDLE, NEED_ACTIVE };

struct command {
    /* Fill reply (an OK document to send) or return an error (err set;
     * code names the error class). */
    int (*run)(control *c, struct client *cl, json_t *req, json_t *reply, const char **code,
               struct gonio_err *err);
    enum need need;
};

static const char *jstr(json_t *req, const char *key)
{
    return json_string_value(json_object_get(req, key));
}

static int cmd_capture(control *c, struct client *cl, json_t *req, json_t *reply,
                       const char **code, struct gonio_err *err)
{
    (void)cl;
    struct worker_request r;
    memset(&r, 0, sizeof r);
    const char *plan = jstr(req, "plan"), *scene = jstr(req, "scene"),
               *rig = jstr(req, "rig"), *material = jstr(req, "material"),
               *model = jstr(req, "model"), *order = jstr(req, "order"),
               *stop = jstr(req, "stop"), *name = jstr(req, "name");
    *code = "bad-value";
    if (!plan)
        return gonio_err_set(err, GONIO_EUSAGE, "capture: 'plan' is required");
    if (stop && strcmp(stop, "all") && strcmp(stop, "converge"))
        return gonio_err_set(err, GONIO_EUSAGE, "stop '%s': use all or converge", stop);
    if (order && strcmp(order, "travel") && strcmp(order, "progressive") &&
        strcmp(order, "as-written") && strcmp(order, "greedy"))
        return gonio_err_set(err, GONIO_EUSAGE,
                             "order '%s': use travel, progressive, as-written or greedy", order);
    if (model && strcmp(model, "abc"))
        return gonio_err_set(err, GONIO_EUSAGE, "model '%s': the only model is 'abc'", model);
    int rc;
    if ((rc = resolve_ref(c, "plan", plan, r.plan, sizeof r.plan, err)) < 0)
        return rc;
    if (scene) {
        if ((rc = resolve_ref(c, "scene", scene, r.scene, sizeof r.scene, err)) < 0)
            return rc;
    } else {
        snprintf(r.scene, sizeof r.scene, "%s", c->cfg->scene);
    }
    if (rig) {
        if ((rc = resolve_ref(c, "rig", rig, r.rig, sizeof r.rig, err)) < 0)
            return rc;
    } else {
        snprintf(r.rig, sizeof r.rig, "%s", c->cfg->rig);
    }
    if (material && (rc = resolve_material(c, material, r.material, sizeof r.material, err)) < 0)
        return rc;
    snprintf(r.model, sizeof r.model, "%s", model ? model : "abc");
    snprintf(r.order, sizeof r.order, "%s", order ? order : "");
    snprintf(r.stop, sizeof r.stop, "%s", stop ? stop : "");

    if (name) {
        if (!valid_id(name))
            return gonio_err_set(err, GONIO_EUSAGE,
                                 "name '%s': a capture id is 1..100 letters, digits, '.', '_' "
                                 "or '-', not starting with '.' or '-'",
                                 name);
        snprintf(r.id, sizeof r.id, "%s", name);
    } else {
        /* A readable, sortable id; the suffix keeps two captures started
         * in the same second apart. */
        char stamp[32];
        time_t t = time(NULL);
        struct tm tm;
        gmtime_r(&t, &tm);
        strftime(stamp, sizeof stamp, "%Y%m%dT%H%M%SZ", &tm);
        char base[96];
        snprintf(base, sizeof base, "%s-%.40s", stamp, valid_id(plan) ? plan : "plan");
        snprintf(r.id, sizeof r.id, "%s", base);
        for (int k = 2; k < 1000; k++) {
            char probe[2304];
            struct stat st;
            snprintf(probe, sizeof probe, "%s/%s", c->cfg->capture_root, r.id);
            if (stat(probe, &st) != 0)
                break;
            snprintf(r.id, sizeof r.id, "%s-%d", base, k);
        }
    }
    snprintf(r.dir, sizeof r.dir, "%s/%s", c->cfg->capture_root, r.id);
    if ((rc = gonio_mkdir_p(c->cfg->capture_root, err)) < 0) {
        *code = "io";
        return rc;
    }
    if (mkdir(r.dir, 0755) < 0) {
        *code = errno == EEXIST ? "exists" : "io";
        return gonio_err_set(err, errno == EEXIST ? GONIO_EUSAGE : errno,
                             errno == EEXIST
                                 ? "capture '%s' exists; resume it or choose another name"
                                 : "capture '%s': cannot create its directory",
                             r.id);
    }
    if ((rc = save_request(&r, err)) < 0 || (rc = worker_start(c->w, &r, err)) < 0) {
        *code = "busy";
        char path[2304];
        snprintf(path, sizeof path, "%s/%s", r.dir, request_file);
        unlink(path);
        rmdir(r.dir);
        return rc;
    }
    fprintf(stderr, "goniod: capture %s started (plan %s)\n", r.id, plan);
    json_object_set_new(reply, "capture_id", json_string(r.id));
    json_object_set_new(reply, "dir", json_string(r.dir));
    return 0;
}

static json_t *status_doc(control *c)
{
    struct worker_status st;
    worker_get_status(c->w, &st);
    static const char *const names[] = {"idle", "running", "paused"};
    json_t *d = json_object();
    json_object_set_new(d, "class", json_string("STATUS"));
    json_object_set_new(d, "state", json_string(names[st.state]));
    json_object_set_new(d, "capture_id", st.state == WORKER_IDLE ? json_null()
                                                                 : json_string(st.id));
    json_object_set_new(d, "points_done", json_integer((json_int_t)st.done));
    json_object_set_new(d, "points_total", json_integer((json_int_t)st.total));
    json_object_set_new(d, "rig_time_s", jnum(st.rig_time_s));
    if (st.has_fit)
        json_object_set_new(d, "fit_error",
                            json_pack("{s:s, s:o, s:o, s:I}", "capture_id", st.fit_id,
                                      "log_error", jnum(st.fit_log_error), "rel_rmse",
                                      jnum(st.fit_rel_rmse), "samples",
                                      (json_int_t)st.fit_samples));
    else
        json_object_set_new(d, "fit_error", json_null());
    return d;
}

static int cmd_status(control *c, struct client *cl, json_t *req, json_t *reply,
                      const char **code, struct gonio_err *err)
{
    (void)cl, (void)req, (void)code, (void)err;
    json_t *d = status_doc(c);
    json_object_update(reply, d);
    json_decref(d);
    return 0;
}

static int cmd_watch(control *c, struct client *cl, json_t *req, json_t *reply,
                     const char **code, struct gonio_err *err)
{
    (void)req, (void)reply, (void)code, (void)err;
    (void)c;
    cl->watching = 1;
    return 0;
}

static int cmd_pause(control *c, struct client *cl, json_t *req, json_t *reply,
                     const char **code, struct gonio_err *err)
{
    (void)cl, (void)req, (void)reply;
    *code = "not-running";
    return worker_pause(c->w, err);
}

static int cmd_resume(control *c, struct client *cl, json_t *req, json_t *reply,
                      const char **code, struct gonio_err *err)
{
    (void)cl;
    const char *id = jstr(req, "capture_id");
    struct worker_status st;
    worker_get_status(c->w, &st);
    if (!id || (st.state != WORKER_IDLE && !strcmp(id, st.id))) {
        /* Resume the paused capture. */
        *code = "not-paused";
        return worker_continue(c->w, err);
    }
    *code = "bad-value";
    if (!valid_id(id))
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
    if (dir_symlink(r.dir, name, sizeof name, &link) < 0 || link) {
        *code = "bad-value";
        return gonio_err_set(err, GONIO_EUSAGE,
                             "capture '%s': %s%s is a symbolic link or unreadable; goniod "
                             "does not write through links",
                             id, link ? "file " : "its directory", link ? name : "");
    }
    int rc = load_request(c, &r, err);
    if (rc < 0) {
        *code = "not-found";
        return rc;
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

static int cmd_abort(control *c, struct client *cl, json_t *req, json_t *reply,
                     const char **code, struct gonio_err *err)
{
    (void)cl, (void)req, (void)reply;
    *code = "not-running";
    return worker_abort(c->w, "aborted", err);
}

static int cmd_shutdown(control *c, struct client *cl, json_t *req, json_t *reply,
                        const char **code, struct gonio_err *err)
{
    (void)cl, (void)req, (void)reply, (void)code, (void)err;
    c->shutdown = 1;
    return 0;
}

/* What each command does (docs/protocol.md); its fields are checked by
 * control_request_parse (daemon/request.c). */
static const struct command commands[CONTROL_CMD_COUNT] = {
    [CONTROL_CMD_CAPTURE] = {cmd_capture, NEED_IDLE},
    [CONTROL_CMD_STATUS] = {cmd_status, NEED_ANY},
    [CONTROL_CMD_WATCH] = {cmd_watch, NEED_ANY},
    [CONTROL_CMD_PAUSE] = {cmd_pause, NEED_ACTIVE},
    [CONTROL_CMD_RESUME] = {cmd_resume, NEED_ANY},
    [CONTROL_CMD_ABORT] = {cmd_abort, NEED_ACTIVE},
    [CONTROL_CMD_SHUTDOWN] = {cmd_shutdown, NEED_ANY},
};

static void handle_line(control *c, struct client *cl, const char *line, size_t len)
{
    struct control_request rq;
    const char *bad;
    char why[1024];
    if (control_request_parse(line, len, &rq, &bad, why, sizeof why) < 0) {
        send_error(cl, bad, rq.id, "%s", why);
        control_request_free(&rq);
        return;
    }
    const struct command *cmd = &commands[rq.cmd];
    json_t *req = rq.doc, *id = rq.id;
    const char *name = rq.name;
    struct worker_status st;
    worker_get_status(c->w, &st);
    if (cmd->need == NEED_IDLE && st.state != WORKER_IDLE) {
        send_error(cl, "busy", id,
                   "%s: capture '%s' is running; abort it or wait for it to finish", name,
                   st.id);
        control_request_free(&rq);
        return;
    }
    if (cmd->need == NEED_ACTIVE && st.state == WORKER_IDLE) {
        send_error(cl, "not-running", id, "%s: no capture is running", name);
        control_request_free(&rq);
        return;
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
        send_error(cl, code, id, "%s", err.msg[0] ? err.msg : gonio_strerror(rc));
    } else {
        client_send(cl, reply);
        /* A watcher that subscribes mid-capture still gets the capture's
         * start and descriptor first. */
        if (cmd->run == cmd_watch && c->start_doc) {
            client_send_text(cl, c->start_doc);
            client_send_text(cl, c->descriptor_doc);
        }
    }
    control_request_free(&rq);
}

/* ---- input ----------------------------------------------------------- */

/* Token bucket: rate_per_s requests a second on average, bursts of up to
 * burst. A request beyond it is answered with an error and not run, so a
 * flooding client costs a parse and a short reply per line, and if it does
 * not read those either its output limit drops it. */
static int client_take_token(control *c, struct client *cl)
{
    double t = now_s();
    cl->tokens += (t - cl->tokens_at) * c->cfg->rate_per_s;
    if (cl->tokens > c->cfg->burst)
        cl->tokens = c->cfg->burst;
    cl->tokens_at = t;
    if (cl->tokens < 1)
        return 0;
    cl->tokens -= 1;
    return 1;
}

static void refuse_rate(control *c, struct client *cl, const char *line, size_t len)
{
    /* Echo the id when there is one, so the client knows which request. */
    json_t *req = json_loadb(line, len, JSON_REJECT_DUPLICATES, NULL);
    json_t *id = json_object_get(req, "id");
    send_error(cl, "rate-limited", json_is_string(id) || json_is_integer(id) ? id : NULL,
               "more than %g requests a second (bursts of %ld); request not run",
               c->cfg->rate_per_s, c->cfg->burst);
    json_decref(req);
}

/* One recv per poll round: a client that writes without pause cannot keep
 * the loop away from the others or from the worker's messages. */
static void client_read(control *c, struct client *cl)
{
    ssize_t n = recv(cl->fd, cl->in + cl->in_len, CONTROL_MAX_LINE + 1 - cl->in_len,
                     MSG_DONTWAIT);
    if (n == 0) {
        cl->dead = 1; /* the client closed its end */
        return;
    }
    if (n < 0) {
        if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)
            cl->dead = 1;
        return; /* EINTR, EAGAIN: poll says when to come back */
    }
    cl->in_len += (size_t)n;
    char *nl;
    size_t start = 0;
    while (!cl->dead && !cl->closing &&
           (nl = memchr(cl->in + start, '\n', cl->in_len - start))) {
        size_t len = (size_t)(nl - (cl->in + start));
        /* Only a whole request counts as activity: a client trickling
         * bytes without ever finishing a line still times out. */
        cl->last_active = now_s();
        if (len > 0 && !(len == 1 && cl->in[start] == '\r')) {
            if (client_take_token(c, cl))
                handle_line(c, cl, cl->in + start, len);
            else
                refuse_rate(c, cl, cl->in + start, len);
        }
        start += len + 1;
    }
    memmove(cl->in, cl->in + start, cl->in_len - start);
    cl->in_len -= start;
    if (cl->in_len > CONTROL_MAX_LINE) {
        send_error(cl, "line-too-long", NULL,
                   "a request line is at most %d bytes; closing the connection",
                   CONTROL_MAX_LINE);
        cl->closing = 1;
        cl->in_len = 0;
        client_try_write(cl);
    }
}

static void client_free(struct client *cl)
{
    close(cl->fd);
    free(cl->in);
    free(cl->out);
    free(cl);
}

static void accept_clients(control *c)
{
    for (;;) {
        int fd = accept(c->listen_fd, NULL, NULL);
        if (fd < 0)
            return; /* EAGAIN, or a client that vanished */
        fcntl(fd, F_SETFL, O_NONBLOCK);
        fcntl(fd, F_SETFD, FD_CLOEXEC);
        struct client *cl = calloc(1, sizeof *cl);
        struct client **list = realloc(c->clients, (c->n_clients + 1) * sizeof *list);
        if (list)
            c->clients = list;
        if (cl)
            cl->in = malloc(CONTROL_MAX_LINE + 1);
        if (!cl || !list || !cl->in) {
            if (cl)
                free(cl->in);
            free(cl);
            close(fd);
            continue;
        }
        cl->fd = fd;
        cl->max_out = (size_t)c->cfg->max_queue_kib * 1024;
        cl->last_active = cl->tokens_at = now_s();
        cl->tokens = (double)c->cfg->burst;
        c->clients[c->n_clients++] = cl;
        struct peer_cred pc;
        int prc = peer_cred_get(fd, &pc);
        if (prc < 0 || !peer_allowed(&pc, c->self_uid, c->allowed_gid)) {
            if (prc < 0)
                fprintf(stderr, "goniod: refused client %d: no peer credentials: %s\n", fd,
                        strerror(-prc));
            else
                fprintf(stderr,
                        "goniod: refused client %d: pid %ld uid %ld gid %ld is not root, not "
                        "goniod's user and not in group %ld\n",
                        fd, (long)pc.pid, (long)pc.uid, (long)pc.gid, (long)c->allowed_gid);
            send_error(cl, "not-authorized", NULL,
                       "not allowed: the control socket serves root, goniod's user and "
                       "the members of group %ld",
                       (long)c->allowed_gid);
            cl->closing = 1;
            client_try_write(cl);
            continue;
        }
        if (c->n_clients > (size_t)c->cfg->max_clients) {
            send_error(cl, "too-many-clients", NULL, "goniod serves at most %d connections",
                       c->cfg->max_clients);
            cl->closing = 1;
            client_try_write(cl);
            continue;
        }
        client_send(cl, json_pack("{s:s, s:s, s:i, s:i}", "class", "VERSION", "release",
                                  GONIO_RELEASE, "proto_major", CONTROL_PROTO_MAJOR,
                                  "proto_minor", CONTROL_PROTO_MINOR));
    }
}

static void reap(control *c)
{
    size_t k = 0;
    for (size_t i = 0; i < c->n_clients; i++) {
        if (c->clients[i]->dead)
            client_free(c->clients[i]);
        else
            c->clients[k++] = c->clients[i];
    }
    c->n_clients = k;
}

/* ---- public ---------------------------------------------------------- */

control *control_new(const struct goniod_config *cfg, worker *w, struct gonio_err *err)
{
    struct sockaddr_un sa = {.sun_family = AF_UNIX};
    if (strlen(cfg->socket_path) >= sizeof sa.sun_path) {
        gonio_err_set(err, GONIO_EBADCONFIG, "%s: socket path too long", cfg->socket_path);
        return NULL;
    }
    snprintf(sa.sun_path, sizeof sa.sun_path, "%s", cfg->socket_path);
    gid_t gid = (gid_t)-1, allowed = getegid();
    if (cfg->socket_group[0]) {
        struct group *g = getgrnam(cfg->socket_group);
        if (!g) {
            gonio_err_set(err, GONIO_EBADCONFIG, "%s: socket group '%s' does not exist",
                          cfg->path, cfg->socket_group);
            return NULL;
        }
        gid = allowed = g->gr_gid;
    }
    /* A socket folder goniod creates is 0750 in the socket's group: only
     * the operators can even reach the socket. An existing folder is left
     * as it is (systemd's RuntimeDirectory=, or a test's). */
    char dir[sizeof sa.sun_path];
    snprintf(dir, sizeof dir, "%s", cfg->socket_path);
    char *slash = strrchr(dir, '/');
    struct stat st;
    if (slash && slash != dir) {
        *slash = '\0';
        if (stat(dir, &st) != 0) {
            if (gonio_mkdir_p(dir, err) < 0)
                return NULL;
            if (chmod(dir, 0750) < 0 || (gid != (gid_t)-1 && chown(dir, (uid_t)-1, gid) < 0)) {
                gonio_err_set(err, errno, "%s: %s", dir, strerror(errno));
                return NULL;
            }
        }
    }
    if (lstat(cfg->socket_path, &st) == 0 && !S_ISSOCK(st.st_mode)) {
        gonio_err_set(err, EEXIST, "%s: exists and is not a socket; not replacing it",
                      cfg->socket_path);
        return NULL;
    }
    int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) {
        gonio_err_set(err, errno, "socket: %s", strerror(errno));
        return NULL;
    }
    /* A socket file left by a daemon that died is stale when nobody
     * answers on it; a live daemon's socket is never taken over. */
    if (connect(fd, (struct sockaddr *)&sa, sizeof sa) == 0) {
        close(fd);
        gonio_err_set(err, EADDRINUSE, "%s: another goniod is listening there",
                      cfg->socket_path);
        return NULL;
    }
    close(fd);
    unlink(cfg->socket_path);
    fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    /* Created 0660 from the start (umask), so there is no moment in which
     * others could connect; chmod then makes the mode exact. */
    mode_t old_mask = umask(0117);
    int bound = fd >= 0 ? bind(fd, (struct sockaddr *)&sa, sizeof sa) : -1;
    umask(old_mask);
    if (fd < 0 || bound < 0 || chmod(cfg->socket_path, 0660) < 0 ||
        (gid != (gid_t)-1 && chown(cfg->socket_path, (uid_t)-1, gid) < 0) ||
        listen(fd, 16) < 0) {
        gonio_err_set(err, errno, "%s: %s", cfg->socket_path, strerror(errno));
        if (fd >= 0)
            close(fd);
        return NULL;
    }
    control *c = calloc(1, sizeof *c);
    if (!c) {
        close(fd);
        gonio_err_set(err, ENOMEM, "out of memory");
        return NULL;
    }
    c->cfg = cfg;
    c->w = w;
    c->listen_fd = fd;
    c->self_uid = geteuid();
    c->allowed_gid = allowed;
    return c;
}

void control_free(control *c)
{
    if (!c)
        return;
    for (size_t i = 0; i < c->n_clients; i++)
        client_free(c->clients[i]);
    free(c->clients);
    close(c->listen_fd);
    unlink(c->cfg->socket_path);
    free(c->start_doc);
    free(c->descriptor_doc);
    free(c);
}

size_t control_pollfds(control *c, struct pollfd *pfd, size_t max)
{
    reap(c);
    size_t n = 0;
    if (n < max)
        pfd[n++] = (struct pollfd){.fd = c->listen_fd, .events = POLLIN};
    for (size_t i = 0; i < c->n_clients && n < max; i++) {
        struct client *cl = c->clients[i];
        short ev = cl->closing ? 0 : POLLIN;
        if (cl->out_len)
            ev |= POLLOUT;
        pfd[n++] = (struct pollfd){.fd = cl->fd, .events = ev};
    }
    return n;
}

void control_handle(control *c, const struct pollfd *pfd, size_t n)
{
    for (size_t k = 0; k < n; k++) {
        if (!pfd[k].revents)
            continue;
        if (pfd[k].fd == c->listen_fd) {
            accept_clients(c);
            continue;
        }
        for (size_t i = 0; i < c->n_clients; i++) {
            struct client *cl = c->clients[i];
            if (cl->fd != pfd[k].fd || cl->dead)
                continue;
            if (pfd[k].revents & POLLOUT)
                client_try_write(cl);
            if (pfd[k].revents & (POLLIN | POLLHUP | POLLERR))
                client_read(c, cl);
            if ((pfd[k].revents & (POLLHUP | POLLERR)) && !(pfd[k].revents & POLLIN))
                cl->dead = 1;
        }
    }
    reap(c);
}

static json_t *sample_doc(const control *c, const struct worker_msg *m)
{
    const struct journal_sample *s = &m->sample;
    json_t *d = json_object();
    json_object_set_new(d, "class", json_string("event"));
    json_object_set_new(d, "seq", json_integer((json_int_t)c->seq));
    json_object_set_new(d, "point", json_integer(s->point));
    json_object_set_new(d, "done", json_integer((json_int_t)m->done));
    json_object_set_new(d, "total", json_integer((json_int_t)m->total));
    json_object_set_new(d, "theta_i", jnum(s->theta_i));
    json_object_set_new(d, "theta_r", jnum(s->theta_r));
    json_object_set_new(d, "phi_i", jnum(s->phi_i));
    json_object_set_new(d, "theta_o", jnum(s->theta_o));
    json_object_set_new(d, "phi_o", jnum(s->phi_o));
    json_object_set_new(d, "s", jnum(s->s));
    json_object_set_new(d, "a", jnum(s->a));
    json_object_set_new(d, "rgb", json_pack("[o,o,o]", jnum(s->rgb[0]), jnum(s->rgb[1]),
                                            jnum(s->rgb[2])));
    json_object_set_new(d, "integration_s", jnum(s->integration_s));
    json_object_set_new(d, "rig_time_s", jnum(s->rig_time_s));
    json_object_set_new(d, "saturated", json_boolean(s->flags & JOURNAL_FLAG_SATURATED));
    if (isfinite(m->fit_log_error))
        json_object_set_new(d, "fit_log_error", json_real(m->fit_log_error));
    return d;
}

static json_t *axis_doc(const struct plan_axis *a)
{
    return json_pack("{s:o, s:o, s:o, s:o}", "speed", jnum(a->speed), "accel", jnum(a->accel),
                     "min", jnum(a->min), "max", jnum(a->max));
}

static json_t *descriptor_doc(const control *c, const struct worker_msg *m)
{
    const struct goniod_config *cfg = c->cfg;
    json_t *drv = json_object();
    json_object_set_new(drv, "kind", json_string(goniod_driver_name(cfg->driver)));
    if (cfg->driver == GONIOD_DRIVER_SIM) {
        json_object_set_new(drv, "scene", json_string(m->req.scene));
        json_object_set_new(drv, "pace_s", jnum(cfg->pace_s));
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
                            json_pack("{s:i, s:i, s:i, s:i}", "sample", cfg->slaves.sample,
                                      "arm", cfg->slaves.arm, "azimuth", cfg->slaves.azimuth,
                                      "detector", cfg->slaves.detector));
        json_object_set_new(drv, "steps_per_deg", jnum(cfg->steps_per_deg));
        json_object_set_new(drv, "time_scale", jnum(cfg->time_scale));
    }
    json_t *d = json_object();
    json_object_set_new(d, "class", json_string("descriptor"));
    json_object_set_new(d, "capture_id", json_string(m->req.id));
    json_object_set_new(d, "driver", drv);
    struct plan_rig rig;
    struct gonio_err err = {0};
    if (plan_rig_load(m->req.rig, &rig, &err) == 0) {
        json_t *r = json_object();
        json_object_set_new(r, "name", json_string(rig.name));
        json_object_set_new(r, "sample", axis_doc(&rig.sample));
        json_object_set_new(r, "arm", axis_doc(&rig.arm));
        if (rig.out_of_plane)
            json_object_set_new(r, "azimuth", axis_doc(&rig.azimuth));
        json_object_set_new(r, "out_of_plane", json_boolean(rig.out_of_plane));
        json_object_set_new(r, "blind_deg", jnum(rig.blind_deg));
        json_object_set_new(r, "settle_s", jnum(rig.settle_s));
        json_object_set_new(r, "integration_s", jnum(rig.integration_s));
        json_object_set_new(d, "rig", r);
    }
    return d;
}

static json_t *errors_doc(const struct brdf_errors *e)
{
    return json_pack("{s:o, s:o, s:I}", "log_error", jnum(e->log), "rel_rmse",
                     jnum(e->rel_rmse), "pairs", (json_int_t)e->n_used);
}

static json_t *stop_doc(const struct worker_msg *m)
{
    const struct capture_summary *s = &m->summary;
    json_t *d = json_object();
    json_object_set_new(d, "class", json_string("stop"));
    json_object_set_new(d, "capture_id", json_string(m->req.id));
    json_object_set_new(d, "dir", json_string(m->req.dir));
    int aborted = !strcmp(m->reason, "aborted") || !strcmp(m->reason, "shutdown");
    json_object_set_new(d, "exit_status",
                        json_string(m->rc < 0 ? "fail" : aborted ? "abort" : "success"));
    json_object_set_new(d, "reason", json_string(m->reason));
    if (m->has_comm) /* the bus's exchanges: what the retries absorbed */
        json_object_set_new(
            d, "comm",
            json_pack("{s:I,s:I,s:I,s:I,s:I,s:I}", "requests", (json_int_t)m->comm.requests,
                      "retries", (json_int_t)m->comm.retries, "timeouts",
                      (json_int_t)m->comm.timeouts, "bad_replies",
                      (json_int_t)m->comm.bad_replies, "exceptions",
                      (json_int_t)m->comm.exceptions, "failed", (json_int_t)m->comm.failed));
    if (m->rc < 0) {
        json_t *msg = json_string(m->err.msg);
        json_object_set_new(d, "message", msg ? msg : json_string("(not UTF-8)"));
        return d;
    }
    json_object_set_new(d, "samples", json_integer((json_int_t)s->samples));
    json_object_set_new(d, "rig_time_s", jnum(s->rig_time_s));
    if (!aborted) {
        const struct brdf_abc *p = &s->params;
        json_t *r = json_object();
        json_object_set_new(r, "plan", json_string(s->plan));
        json_t *mat = json_string(s->material);
        json_object_set_new(r, "material", mat ? mat : json_null());
        json_object_set_new(r, "model", json_string(s->model));
        json_object_set_new(r, "converged", json_boolean(s->converged));
        json_object_set_new(r, "fit_time_s", jnum(s->fit_time_s));
        json_object_set_new(
            r, "params",
            json_pack("{s:[o,o,o], s:[o,o,o], s:o, s:o, s:o}", "kd", jnum(p->kd[0]),
                      jnum(p->kd[1]), jnum(p->kd[2]), "A", jnum(p->A[0]), jnum(p->A[1]),
                      jnum(p->A[2]), "B", jnum(p->B), "C", jnum(p->C), "eta", jnum(p->eta)));
        json_object_set_new(r, "err_plan", errors_doc(&s->err_plan));
        if (s->has_truth) {
            json_object_set_new(r, "err_inplane", errors_doc(&s->err_inplane));
            json_object_set_new(r, "err_full", errors_doc(&s->err_full));
        }
        json_object_set_new(d, "results", r);
    }
    return d;
}

void control_dispatch(control *c, struct worker_msg *msgs)
{
    for (struct worker_msg *m = msgs, *next; m; m = next) {
        next = m->next;
        json_t *doc = NULL;
        if (m->kind == WORKER_MSG_START) {
            c->seq = 0;
            free(c->start_doc);
            free(c->descriptor_doc);
            json_t *s = json_object();
            json_object_set_new(s, "class", json_string("start"));
            json_object_set_new(s, "capture_id", json_string(m->req.id));
            json_object_set_new(s, "dir", json_string(m->req.dir));
            json_object_set_new(s, "plan", json_string(m->plan_name));
            json_object_set_new(s, "scene", json_string(m->req.scene));
            json_object_set_new(s, "material", m->req.material[0]
                                                   ? json_string(m->req.material)
                                                   : json_null());
            json_object_set_new(s, "rig", json_string(m->req.rig));
            json_object_set_new(s, "model", json_string(m->req.model));
            json_object_set_new(s, "order", m->req.order[0] ? json_string(m->req.order)
                                                            : json_null());
            json_object_set_new(s, "stop", m->req.stop[0] ? json_string(m->req.stop)
                                                          : json_null());
            json_object_set_new(s, "resume", json_boolean(m->req.resume));
            json_object_set_new(s, "total", json_integer((json_int_t)m->total));
            json_object_set_new(s, "already_done", json_integer((json_int_t)m->already_done));
            json_object_set_new(s, "time", json_integer((json_int_t)time(NULL)));
            c->start_doc = dump(s);
            c->descriptor_doc = dump(descriptor_doc(c, m));
            if (c->start_doc)
                broadcast(c, c->start_doc);
            if (c->descriptor_doc)
                broadcast(c, c->descriptor_doc);
        } else if (m->kind == WORKER_MSG_SAMPLE) {
            c->seq++;
            doc = sample_doc(c, m);
        } else {
            if (m->rc < 0)
                fprintf(stderr, "goniod: capture %s failed: %s\n", m->req.id, m->err.msg);
            else
                fprintf(stderr, "goniod: capture %s stopped: %s, %zu samples\n", m->req.id,
                        m->reason, m->summary.samples);
            if (m->has_comm)
                fprintf(stderr, "goniod: capture %s: bus %ld requests, %ld retries (%ld "
                        "timeouts, %ld bad replies), %ld exceptions, %ld failed\n", m->req.id,
                        m->comm.requests, m->comm.retries, m->comm.timeouts,
                        m->comm.bad_replies, m->comm.exceptions, m->comm.failed);
            doc = stop_doc(m);
            free(c->start_doc);
            free(c->descriptor_doc);
            c->start_doc = c->descriptor_doc = NULL;
        }
        if (doc) {
            char *text = dump(doc);
            if (text)
                broadcast(c, text);
            free(text);
        }
        free(m);
    }
    reap(c);
}

int control_tick(control *c)
{
    double t = now_s(), next = c->cfg->idle_timeout_s;
    for (size_t i = 0; i < c->n_clients; i++) {
        struct client *cl = c->clients[i];
        if (cl->watching || cl->closing || cl->dead)
            continue;
        double idle = t - cl->last_active;
        if (idle >= c->cfg->idle_timeout_s) {
            send_error(cl, "idle-timeout", NULL, "no request for %g s; closing the connection",
                       c->cfg->idle_timeout_s);
            cl->closing = 1;
            client_try_write(cl);
        } else if (c->cfg->idle_timeout_s - idle < next) {
            next = c->cfg->idle_timeout_s - idle;
        }
    }
    reap(c);
    int ms = (int)(next * 1000) + 1;
    return ms > 60000 ? 60000 : ms;
}

void control_flush(control *c, int timeout_ms)
{
    double end = now_s() + timeout_ms / 1000.0;
    for (;;) {
        struct pollfd pfd[256];
        size_t n = 0;
        for (size_t i = 0; i < c->n_clients && n < 256; i++)
            if (!c->clients[i]->dead && c->clients[i]->out_len)
                pfd[n++] = (struct pollfd){.fd = c->clients[i]->fd, .events = POLLOUT};
        double left = end - now_s();
        if (n == 0 || left <= 0)
            return;
        if (poll(pfd, n, (int)(left * 1000) + 1) <= 0)
            return;
        for (size_t i = 0; i < c->n_clients; i++)
            client_try_write(c->clients[i]);
    }
}

int control_shutdown_requested(const control *c)
{
    return c->shutdown;
}

void control_status_text(control *c, char *buf, size_t size)
{
    struct worker_status st;
    worker_get_status(c->w, &st);
    if (st.state == WORKER_IDLE)
        snprintf(buf, size, "idle, %zu client(s)", c->n_clients);
    else
        snprintf(buf, size, "%s %s: %zu/%zu points, rig time %.0f s",
                 st.state == WORKER_PAUSED ? "paused" : "capturing", st.id, st.done, st.total,
                 st.rig_time_s);
}
