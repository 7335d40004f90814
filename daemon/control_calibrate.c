/* The calibrate command (docs/protocol.md, "calibrate"): a dark, stray or
 * reference calibration checked, given its directory in goniod's
 * calibration root with the request recorded there, and handed to the
 * worker (worker_calibrate); and `resume ID` of a calibration that did not
 * finish, from that record. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "capture/calibration.h"
#include "common/paths.h"
#include "daemon/control_private.h"

static const char record_file[] = "request.json";

static const char *jstr(json_t *req, const char *key)
{
    return json_string_value(json_object_get(req, key));
}

/* A request's (or its record's) fields as a run: references resolved as a
 * capture's are, each wrong value refused naming its field. The record
 * keeps the request's own words, so a resume resolves them again. */
static int from_request(control *c, json_t *req, struct worker_calibration *k,
                        struct gonio_err *err)
{
    const char *kind = jstr(req, "kind"), *plan = jstr(req, "plan"), *rig = jstr(req, "rig"),
               *standard = jstr(req, "standard"), *dark = jstr(req, "dark"),
               *spot = jstr(req, "spot"), *stray = jstr(req, "stray");
    json_t *frames = json_object_get(req, "frames"), *repeats = json_object_get(req, "repeats"),
           *integ = json_object_get(req, "integration"), *valid = json_object_get(req, "valid"),
           *ladder = json_object_get(req, "ladder");
    if (!kind || cal_kind_parse(kind) < 0)
        return gonio_err_set(err, GONIO_EUSAGE, "calibrate: field 'kind' '%.40s': dark, "
                             "stray or reference", kind ? kind : "");
    k->kind = cal_kind_parse(kind);
    if (k->kind == CAL_BEAM) /* the absolute method is measured offline only */
        return gonio_err_set(err, GONIO_EUSAGE, "calibrate: field 'kind' 'beam': goniod takes "
                             "dark, stray or reference (gonio calibrate beam --offline)");
    /* the fields each kind takes: a dark's frames, the others' points */
    const char *dark_only = frames ? "frames" : integ ? "integration" : ladder ? "ladder" : NULL;
    const char *other = k->kind == CAL_DARK
                            ? (plan ? "plan" : repeats ? "repeats" : standard ? "standard"
                               : dark ? "dark" : spot ? "spot" : stray ? "stray" : NULL)
                        : k->kind == CAL_STRAY
                            ? (dark_only ? dark_only : standard ? "standard" : spot ? "spot"
                               : stray ? "stray" : NULL)
                            : dark_only;
    if (other)
        return gonio_err_set(err, GONIO_EUSAGE, "calibrate: field '%s' is not a %s "
                             "calibration's", other, kind);
    int rc;
    if (k->kind != CAL_DARK && !plan)
        return gonio_err_set(err, GONIO_EUSAGE, "calibrate: field 'plan' is required for a "
                             "%s", kind);
    if (plan && (rc = control_resolve_ref(c, "plan", plan, k->plan, sizeof k->plan, err)) < 0)
        return rc;
    if (rig && (rc = control_resolve_ref(c, "rig", rig, k->rig, sizeof k->rig, err)) < 0)
        return rc;
    if (!rig) /* goniod's own, resolved as its config was loaded */
        snprintf(k->rig, sizeof k->rig, "%s", c->cfg->rig);
    if ((rc = goniod_config_rig_check(c->cfg, k->rig, err)) < 0)
        return rc;
    if ((rc = control_resolve_ref(c, "standard", standard ? standard : "spectralon-99",
                                  k->standard, sizeof k->standard, err)) < 0)
        return rc;
    if (strlen(k->standard) >= sizeof ((struct cal_meta *)0)->standard)
        return gonio_err_set(err, GONIO_EUSAGE, "calibrate: field 'standard' '%.60s...': a "
                             "path of at most %zu characters once resolved", k->standard,
                             sizeof ((struct cal_meta *)0)->standard - 1);
    if (dark && !control_valid_id(dark))
        return gonio_err_set(err, GONIO_EUSAGE, "calibrate: field 'dark' '%.60s': not a "
                             "calibration id", dark);
    snprintf(k->dark, sizeof k->dark, "%s", dark ? dark : "");
    if (stray && (!control_valid_id(stray) || strlen(stray) >= sizeof k->stray))
        return gonio_err_set(err, GONIO_EUSAGE, "calibrate: field 'stray' '%.60s': not a "
                             "calibration id or newest", stray);
    snprintf(k->stray, sizeof k->stray, "%s", stray ? stray : "");
    if (spot && strcmp(spot, "overfilled") && strcmp(spot, "underfilled"))
        return gonio_err_set(err, GONIO_EUSAGE, "calibrate: field 'spot' '%.40s': overfilled "
                             "or underfilled", spot);
    k->underfilled = spot && !strcmp(spot, "underfilled");
    k->per_point = (int)json_integer_value(k->kind == CAL_DARK ? frames : repeats);
    if (!k->per_point)
        k->per_point = k->kind == CAL_DARK ? 16 : 4;
    k->integration_s = integ ? json_number_value(integ) : 0;
    k->ladder = json_is_true(ladder);
    k->valid_s = 60 * (valid ? json_number_value(valid) : k->kind == CAL_DARK ? 60 : 480);
    return 0;
}

/* dir/request.json: the request as given, with its id and creation time. */
static int save_record(const struct worker_calibration *k, json_t *req, struct gonio_err *err)
{
    json_t *d = json_deep_copy(req);
    if (d) {
        json_object_del(d, "cmd");
        json_object_del(d, "id");
        json_object_del(d, "name");
        json_object_set_new(d, "calibration_id", json_string(k->id));
        json_object_set_new(d, "created", json_integer(k->created));
        if (k->dark[0]) /* the dark it was checked with, for good */
            json_object_set_new(d, "dark", json_string(k->dark));
        if (k->stray[0]) /* and the stray light, "newest" resolved */
            json_object_set_new(d, "stray", json_string(k->stray));
        /* what it is of, for gonio list before calibration.json says */
        json_object_set_new(d, "rig_name", json_string(k->rig_name));
        json_object_set_new(d, "detector", json_string(k->detector));
    }
    char *text = d ? control_json_text(d) : NULL;
    if (!text)
        return gonio_err_set(err, ENOMEM, "out of memory");
    char path[2304];
    snprintf(path, sizeof path, "%s/%s", k->dir, record_file);
    int rc = gonio_write_file_atomic(path, text, strlen(text), err);
    free(text);
    return rc;
}

int control_cmd_calibrate(control *c, json_t *req, json_t *reply, const char **code,
                          struct gonio_err *err)
{
    struct worker_calibration k;
    memset(&k, 0, sizeof k);
    *code = "bad-value";
    int rc = from_request(c, req, &k, err);
    if (rc < 0 || (rc = worker_calibrate_check(c->w, &k, err)) < 0)
        return rc;
    const char *root = c->cfg->calibration_root, *name = jstr(req, "name");
    k.created = (long long)time(NULL);
    if (name && (!control_valid_id(name) || strlen(name) >= sizeof k.id))
        return gonio_err_set(err, GONIO_EUSAGE, "calibrate: field 'name' '%.70s': an id is "
                             "1..%zu letters, digits, '.', '_' or '-'", name, sizeof k.id - 1);
    if (name)
        snprintf(k.id, sizeof k.id, "%s", name);
    else
        cal_new_id(root, (enum cal_kind)k.kind, (time_t)k.created, k.id, sizeof k.id);
    snprintf(k.dir, sizeof k.dir, "%s/%s", root, k.id);
    if ((rc = gonio_mkdir_p(root, err)) < 0) {
        *code = "io";
        return rc;
    }
    if (mkdir(k.dir, 0755) < 0) {
        *code = errno == EEXIST ? "exists" : "io";
        return gonio_err_set(err, errno == EEXIST ? GONIO_EUSAGE : errno,
                             errno == EEXIST ? "calibration '%s' exists; resume it (gonio "
                             "resume %s) or choose another name"
                                             : "calibration '%s': cannot create its "
                                               "directory (%s)", k.id,
                             errno == EEXIST ? k.id : strerror(errno));
    }
    if ((rc = save_record(&k, req, err)) < 0 || (rc = worker_calibrate(c->w, &k, err)) < 0) {
        char path[2304];
        snprintf(path, sizeof path, "%s/%s", k.dir, record_file);
        unlink(path);
        rmdir(k.dir);
        *code = "busy";
        return rc;
    }
    fprintf(stderr, "goniod: calibration %s started\n", k.id);
    json_object_set_new(reply, "capture_id", json_string(k.id));
    json_object_set_new(reply, "dir", json_string(k.dir));
    json_object_set_new(reply, "calibration",
                        json_string(cal_kind_name((enum cal_kind)k.kind)));
    return 0;
}

int control_is_calibration(const control *c, const char *id)
{
    char path[2304];
    struct stat sb;
    snprintf(path, sizeof path, "%s/%s/%s", c->cfg->calibration_root, id, record_file);
    return lstat(path, &sb) == 0 && S_ISREG(sb.st_mode);
}

int control_resume_calibration(control *c, const char *id, json_t *reply, const char **code,
                               struct gonio_err *err)
{
    struct worker_calibration k;
    memset(&k, 0, sizeof k);
    snprintf(k.id, sizeof k.id, "%s", id);
    snprintf(k.dir, sizeof k.dir, "%s/%s", c->cfg->calibration_root, id);
    char path[2304];
    struct stat sb;
    snprintf(path, sizeof path, "%s/calibration.json", k.dir);
    if (stat(path, &sb) == 0) {
        *code = "complete";
        return gonio_err_set(err, GONIO_EUSAGE, "calibration '%s' is complete; nothing was "
                             "changed", id);
    }
    snprintf(path, sizeof path, "%s/%s", k.dir, record_file);
    json_error_t je;
    json_t *d = json_load_file(path, JSON_REJECT_DUPLICATES, &je);
    json_t *created = json_object_get(d, "created");
    *code = "bad-value";
    int rc = d && json_is_integer(created)
                 ? 0
                 : gonio_err_set(err, GONIO_EBADDATA, "%s: not a calibration's record (%s)",
                                 path, d ? "no created" : je.text);
    if (rc == 0)
        rc = from_request(c, d, &k, err);
    if (rc == 0) {
        k.created = json_integer_value(created);
        rc = worker_calibrate_check(c->w, &k, err);
    }
    json_decref(d);
    if (rc < 0)
        return rc;
    *code = "busy";
    if ((rc = worker_calibrate(c->w, &k, err)) < 0)
        return rc;
    fprintf(stderr, "goniod: calibration %s resumed\n", id);
    json_object_set_new(reply, "capture_id", json_string(id));
    json_object_set_new(reply, "dir", json_string(k.dir));
    json_object_set_new(reply, "calibration",
                        json_string(cal_kind_name((enum cal_kind)k.kind)));
    return 0;
}
