/* What a control request may name on disk: capture ids, and plan, scene,
 * rig and MERL files, all held inside the capture root (docs/goniod.md,
 * "Paths from requests"); and the request record a capture keeps for
 * resume, whose paths are held to the root again when it is read back. */
#define _XOPEN_SOURCE 700 /* realpath */
#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "common/paths.h"
#include "daemon/control_private.h"

int control_valid_id(const char *s)
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

int control_resolve_ref(const control *c, const char *what, const char *v, char *out,
                        size_t size, struct gonio_err *err)
{
    if (gonio_ref_is_file(v)) {
        int why = root_path(c, v, out, size);
        return why < 0 ? path_error(err, why, what, v) : 0;
    }
    if (!control_valid_id(v))
        return gonio_err_set(err, GONIO_EUSAGE, "%s '%s': not a valid name", what, v);
    snprintf(out, size, "%s", v);
    return 0;
}

int control_resolve_material(const control *c, const char *v, char *out, size_t size,
                             struct gonio_err *err)
{
    const char *colon = strchr(v, ':');
    if (!colon) {
        if (!control_valid_id(v))
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
    /* A name, with its parameters after '?' for the analytic materials
     * that take them (docs/checks.md: analytic:aniso-ggx?ax=0.05&ay=0.2):
     * key=value pairs of letters, digits, '.', '_', '+' and '-'; what they
     * mean is the material's check. */
    const char *query = strchr(rest, '?');
    char name[128];
    size_t n = query ? (size_t)(query - rest) : strlen(rest);
    int ok = n < sizeof name && strlen(v) < size;
    if (ok) {
        memcpy(name, rest, n);
        name[n] = 0;
        ok = control_valid_id(name);
    }
    for (const char *q = query ? query + 1 : ""; ok && *q; q++)
        ok = isalnum((unsigned char)*q) || strchr("._+-=&", *q);
    if (!ok || (query && !query[1]))
        return gonio_err_set(err, GONIO_EUSAGE, "material '%.200s': not a valid name", v);
    snprintf(out, size, "%s", v);
    return 0;
}

int control_dir_symlink(const char *dir, char *name, size_t size, const char **link)
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

/* ---- the capture's request record (for resume) ------------------------ */

static const char request_file[] = "request.json";

static void request_path(const struct worker_request *r, char *out, size_t size)
{
    snprintf(out, size, "%s/%s", r->dir, request_file);
}

int control_save_request(const struct worker_request *r, struct gonio_err *err)
{
    char checks[64];
    json_t *d = json_pack("{s:s, s:s, s:s, s:s, s:s, s:s, s:s, s:s, s:s, s:f, s:f, s:i, s:s, "
                          "s:s, s:s, s:b, s:s}", "id",
                          r->id, "plan", r->plan, "scene", r->scene, "rig", r->rig, "material",
                          r->material, "truth", r->truth, "model", r->model, "order", r->order,
                          "stop", r->stop, "budget", r->budget_min, "stop_target",
                          r->stop_target, "prescan", r->prescan, "sample", r->sample,
                          "operator", r->operator_name, "note", r->note, "uncalibrated", r->uncalibrated,
                          "check", capture_checks_text(r->checks, checks, sizeof checks));
    if (d && r->calibration[0])
        json_object_set_new(d, "calibration", json_string(r->calibration));
    if (d && r->reference_after)
        json_object_set_new(d, "reference_after", json_true());
    char *text = d ? control_json_text(d) : NULL;
    if (!text)
        return gonio_err_set(err, ENOMEM, "out of memory");
    char path[2304];
    request_path(r, path, sizeof path);
    int rc = gonio_write_file_atomic(path, text, strlen(text), err);
    free(text);
    return rc;
}

int control_load_request(const control *c, struct worker_request *r, struct gonio_err *err)
{
    char path[2304];
    request_path(r, path, sizeof path);
    json_error_t je;
    json_t *d = json_load_file(path, JSON_REJECT_DUPLICATES, &je);
    if (!d)
        return gonio_err_set(err, GONIO_ENOTFOUND,
                             "capture '%s' has no readable %s (%s): not a goniod capture",
                             r->id, request_file, je.text);
    const char *plan, *scene, *rig, *material, *truth = "", *model, *order, *stop;
    double budget = 0, target = 0;
    int prescan = 0, uncalibrated = 0;
    const char *check = "";
    r->checks = 0;
    /* truth, budget, stop_target, prescan, uncalibrated, check: absent from
     * the records of older goniods */
    if (json_unpack(d, "{s:s, s:s, s:s, s:s, s?:s, s:s, s:s, s:s, s?:F, s?:F, s?:i, s?:b, s?:s}",
                    "plan", &plan, "scene", &scene, "rig", &rig, "material", &material,
                    "truth", &truth, "model", &model, "order", &order, "stop", &stop, "budget",
                    &budget, "stop_target", &target, "prescan", &prescan, "uncalibrated",
                    &uncalibrated, "check", &check) < 0 ||
        (check[0] && capture_checks_parse("check", check, &r->checks, NULL) < 0)) {
        json_decref(d);
        return gonio_err_set(err, GONIO_EBADDATA, "%s: lacks a field goniod writes, or has a value it does not", path);
    }
    /* goniod wrote these checked, but the record is a file: its paths are
     * held to the capture root again before anything is opened. */
    const char *merl = !strncmp(material, "merl:", 5) ? material + 5 : NULL;
    const char *truth_merl = !strncmp(truth, "merl:", 5) ? truth + 5 : NULL;
    int why = PATH_OK;
    if ((strchr(plan, '/') && (why = inside_root(c, plan, r->plan, sizeof r->plan)) < 0) ||
        (strchr(scene, '/') && (why = inside_root(c, scene, r->scene, sizeof r->scene)) < 0) ||
        (strchr(rig, '/') && strcmp(rig, c->cfg->rig) &&
         (why = inside_root(c, rig, r->rig, sizeof r->rig)) < 0) ||
        (merl && (why = inside_root(c, merl, r->material + 5, sizeof r->material - 5)) < 0) ||
        (truth_merl &&
         (why = inside_root(c, truth_merl, r->truth + 5, sizeof r->truth - 5)) < 0)) {
        json_decref(d);
        return gonio_err_set(err, GONIO_EBADDATA,
                             "%s: a file it names is missing or lies outside the capture root",
                             path);
    }
    if (!strchr(plan, '/'))
        snprintf(r->plan, sizeof r->plan, "%s", plan);
    if (!strchr(scene, '/'))
        snprintf(r->scene, sizeof r->scene, "%s", scene);
    /* goniod's own rig profile (driver.rig, a request naming none) is the
     * configuration's, trusted wherever it lies, as it was at the request. */
    if (!strchr(rig, '/') || !strcmp(rig, c->cfg->rig))
        snprintf(r->rig, sizeof r->rig, "%s", rig);
    if (merl)
        memcpy(r->material, "merl:", 5);
    else
        snprintf(r->material, sizeof r->material, "%s", material);
    if (truth_merl)
        memcpy(r->truth, "merl:", 5);
    else
        snprintf(r->truth, sizeof r->truth, "%s", truth);
    snprintf(r->model, sizeof r->model, "%s", model);
    snprintf(r->order, sizeof r->order, "%s", order);
    snprintf(r->stop, sizeof r->stop, "%s", stop);
    r->budget_min = budget;
    r->stop_target = target;
    r->prescan = prescan;
    /* the operator's metadata: absent from the records of older goniods */
    const char *meta[] = {"sample", "operator", "note"};
    char *meta_out[] = {r->sample, r->operator_name, r->note};
    size_t meta_size[] = {sizeof r->sample, sizeof r->operator_name, sizeof r->note};
    for (int k = 0; k < 3; k++) {
        const char *v = json_string_value(json_object_get(d, meta[k]));
        snprintf(meta_out[k], meta_size[k], "%s", v ? v : "");
    }
    r->uncalibrated = uncalibrated;
    r->reference_after = json_is_true(json_object_get(d, "reference_after"));
    const char *cal = json_string_value(json_object_get(d, "calibration"));
    if (cal && !control_valid_id(cal)) {
        json_decref(d);
        return gonio_err_set(err, GONIO_EBADDATA, "%s: calibration '%.60s' is no id", path, cal);
    }
    snprintf(r->calibration, sizeof r->calibration, "%s", cal ? cal : "");
    json_decref(d);
    return 0;
}

void control_discard_request(const struct worker_request *r)
{
    char path[2304];
    request_path(r, path, sizeof path);
    unlink(path);
    rmdir(r->dir);
}
