#include "daemon/capture_files.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <jansson.h>

#include "common/paths.h"

static int write_json(const char *dir, const char *name, json_t *root, struct gonio_err *err)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    char *text = root ? json_dumps(root, JSON_INDENT(2) | JSON_REAL_PRECISION(12)) : NULL;
    json_decref(root);
    if (!text)
        return gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    size_t len = strlen(text);
    text[len] = '\n'; /* json_dumps leaves room for the NUL we replace */
    int rc = gonio_write_file_atomic(path, text, len + 1, err);
    free(text);
    return rc;
}

/* Read a whole small file; NULL (errno set) when it is not there. */
static char *slurp(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    char *buf = NULL;
    size_t len = 0, cap = 0;
    for (;;) {
        if (len + 4096 + 1 > cap) {
            cap = cap ? 2 * cap : 65536;
            char *grown = realloc(buf, cap);
            if (!grown) {
                free(buf);
                fclose(f);
                return NULL;
            }
            buf = grown;
        }
        size_t r = fread(buf + len, 1, cap - len - 1, f);
        len += r;
        if (r == 0)
            break;
    }
    fclose(f);
    buf[len] = '\0';
    return buf;
}

static json_t *axis_json(const struct plan_axis *ax)
{
    return json_pack("{s:f,s:f,s:f,s:f}", "speed", ax->speed, "accel", ax->accel, "min",
                     ax->min, "max", ax->max);
}

static json_t *setup_json(const struct plan_rig *rig, const struct sim_scene *scene,
                          const char *material)
{
    return json_pack("{s:{s:s,s:s,s:s,s:s,s:I,s:i},s:s,s:{s:s,s:{s:o,s:o,s:o},s:b,s:f,s:f,"
                     "s:f,s:f,s:f}}",
                     "scene", "name", scene->name, "path", scene->path, "material",
                     scene->material, "detector",
                     scene->detector == SIM_DETECTOR_RGB ? "rgb" : "spectral", "seed",
                     (json_int_t)scene->seed, "effects", scene->n_effects, "material",
                     material, "rig", "name", rig->name, "axes", "sample",
                     axis_json(&rig->sample), "arm", axis_json(&rig->arm), "azimuth",
                     axis_json(&rig->azimuth), "out_of_plane", rig->out_of_plane, "blind_deg",
                     rig->blind_deg, "settle_s", rig->settle_s, "integration_s",
                     rig->integration_s, "auto_min_s", rig->auto_min_s, "auto_max_s",
                     rig->auto_max_s);
}

int capture_files_prepare(const char *dir, const struct plan *plan, const struct plan_rig *rig,
                          const struct sim_scene *scene, const char *material,
                          struct gonio_err *err)
{
    struct plan_estimate est;
    plan_estimate(plan, rig, &est);
    char *text = plan_json_text(plan, &est);
    if (!text)
        return gonio_err_set(err, ENOMEM, "out of memory");

    char path[4096];
    snprintf(path, sizeof path, "%s/plan.json", dir);
    char *existing = slurp(path);
    int rc = 0;
    if (existing) {
        if (strcmp(existing, text) != 0)
            rc = gonio_err_set(err, GONIO_EUSAGE,
                               "%s: holds a capture of another plan or order (plan.json "
                               "differs); choose a new --out directory",
                               dir);
        free(existing);
        free(text);
        return rc; /* resuming: the directory is already set up */
    }
    snprintf(path, sizeof path, "%s/samples.csv", dir);
    struct stat st;
    if (stat(path, &st) == 0) {
        free(text);
        return gonio_err_set(err, GONIO_EUSAGE,
                             "%s: has samples.csv but no plan.json; not a gonio capture to "
                             "resume, choose a new --out directory",
                             dir);
    }
    if ((rc = gonio_mkdir_p(dir, err)) < 0) {
        free(text);
        return rc;
    }
    snprintf(path, sizeof path, "%s/plan.json", dir);
    rc = gonio_write_file_atomic(path, text, strlen(text), err);
    free(text);
    if (rc < 0)
        return rc;
    return write_json(dir, "setup.json", setup_json(rig, scene, material), err);
}

static json_t *errors_json(const struct brdf_errors *e)
{
    /* NaN is not JSON: a domain with no usable pair reports null. */
    json_t *log = isfinite(e->log) ? json_real(e->log) : json_null();
    json_t *rel = isfinite(e->rel_rmse) ? json_real(e->rel_rmse) : json_null();
    return json_pack("{s:o,s:o,s:I}", "log", log, "rel_rmse", rel, "n",
                     (json_int_t)e->n_used);
}

static json_t *rgb_json(const double v[3])
{
    return json_pack("[f,f,f]", v[0], v[1], v[2]);
}

static json_t *num_or_null(double v)
{
    return isfinite(v) ? json_real(v) : json_null();
}

static json_t *uncertainty_json(const struct fit_uncertainty *u, const char *warning)
{
    json_t *o = json_object();
    json_t *kd = json_array(), *a = json_array();
    for (int c = 0; c < 3; c++) {
        json_array_append_new(kd, num_or_null(u->log_kd[c]));
        json_array_append_new(a, num_or_null(u->log_A[c]));
    }
    json_object_set_new(o, "sd_log_kd", kd);
    json_object_set_new(o, "sd_log_A", a);
    json_object_set_new(o, "sd_log_B", num_or_null(u->log_B));
    json_object_set_new(o, "sd_log_C", num_or_null(u->log_C));
    json_object_set_new(o, "sd_eta", num_or_null(u->eta));
    json_object_set_new(o, "sd_pred_log", num_or_null(u->pred_log));
    if (warning && warning[0])
        json_object_set_new(o, "warning", json_string(warning));
    return o;
}

/* The final fit's status and the figures behind it (fit/fit_status.h,
 * docs/fitting.md "Fit status"); null for a figure not computed. */
static json_t *status_json(const struct fit_status *st)
{
    char findings[96];
    fit_status_findings(st, findings, sizeof findings);
    json_t *o = json_object();
    json_object_set_new(o, "status", json_string(fit_status_name(fit_status_code(st))));
    json_object_set_new(o, "findings", json_string(findings));
    json_object_set_new(o, "geometries", json_integer((json_int_t)st->geometries));
    json_object_set_new(o, "params", st->params >= 0 ? json_integer(st->params) : json_null());
    json_object_set_new(o, "rank", st->rank >= 0 ? json_integer(st->rank) : json_null());
    json_object_set_new(o, "condition", num_or_null(st->cond));
    json_object_set_new(o, "at_bound", json_string(st->at_bound));
    json_object_set_new(o, "rms_log_insample", num_or_null(st->insample));
    json_object_set_new(o, "rms_log_heldout", num_or_null(st->heldout));
    return o;
}

int capture_files_results(const char *dir, const struct capture_summary *s,
                          struct gonio_err *err)
{
    json_t *errors = json_pack("{s:o}", "plan", errors_json(&s->err_plan));
    if (errors && s->has_truth) {
        json_object_set_new(errors, "inplane", errors_json(&s->err_inplane));
        json_object_set_new(errors, "full", errors_json(&s->err_full));
    }
    /* ABC's parameters and their sds (also in its model file); null for the
     * other models, whose parameters are only in their model file
     * (docs/formats.md). */
    json_t *params = s->has_params
                         ? json_pack("{s:o,s:o,s:f,s:f,s:f,s:s}", "kd", rgb_json(s->params.kd),
                                     "A", rgb_json(s->params.A), "B", s->params.B, "C",
                                     s->params.C, "eta", s->params.eta, "convention",
                                     "A without the 1/pi of the published MERL fits "
                                     "(docs/fitting.md)")
                         : json_null();
    json_t *root = json_pack("{s:s,s:s,s:s,s:I,s:f,s:{s:f,s:f,s:f},s:f,s:b,s:o,s:o}", "plan",
                             s->plan, "material", s->material, "model", s->model, "samples",
                             (json_int_t)s->samples, "rig_time_s", s->rig_time_s, "rig_time",
                             "move_s", s->move_s, "settle_s", s->settle_s, "integration_s",
                             s->integration_s, "fit_time_s", s->fit_time_s, "converged",
                             s->converged, "params", params, "errors", errors);
    if (root)
        json_object_set_new(root, "model_file", s->model_file[0] ? json_string(s->model_file)
                                                                  : json_null());
    if (root)
        json_object_set_new(root, "saturated", json_integer((json_int_t)s->saturated));
    if (root) /* parameter sds from the fit's Jacobian, natural units (fit/fit.h) */
        json_object_set_new(root, "uncertainty", s->has_params
                                                     ? uncertainty_json(&s->sd, s->warning)
                                                     : json_null());
    if (root)
        json_object_set_new(root, "fit_status", status_json(&s->status));
    return write_json(dir, "results.json", root, err);
}
