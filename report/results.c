/* Reading a study's results.json (results.h). */
#include "report/results.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

const char *report_domain_name(enum report_domain d)
{
    static const char *names[] = {"plan points", "in-plane", "full out-of-plane"};
    return d < REPORT_N_DOMAINS ? names[d] : "?";
}

const char *report_metric_name(enum report_metric m)
{
    return m == REPORT_LOG ? "log error" : "relative RMSE";
}

static int get_string(json_t *row, const char *key, char *out, size_t cap, int required,
                      const char *path, size_t i, struct gonio_err *err)
{
    json_t *v = json_object_get(row, key);
    if (!v || json_is_null(v)) {
        if (required)
            return gonio_err_set(err, GONIO_EBADDATA, "%s: row %zu: field '%s' is missing",
                                 path, i, key);
        out[0] = '\0';
        return 0;
    }
    if (!json_is_string(v))
        return gonio_err_set(err, GONIO_EBADDATA, "%s: row %zu: field '%s' is not a string",
                             path, i, key);
    if (strlen(json_string_value(v)) >= cap)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: row %zu: field '%s' is too long (%zu)",
                             path, i, key, strlen(json_string_value(v)));
    snprintf(out, cap, "%s", json_string_value(v));
    return 0;
}

/* A number, or NAN for null / absent; anything else is an error. */
static int get_number(json_t *row, const char *key, double *out, const char *path, size_t i,
                      struct gonio_err *err)
{
    json_t *v = json_object_get(row, key);
    *out = NAN;
    if (!v || json_is_null(v))
        return 0;
    if (!json_is_number(v))
        return gonio_err_set(err, GONIO_EBADDATA, "%s: row %zu: field '%s' is not a number",
                             path, i, key);
    *out = json_number_value(v);
    if (!isfinite(*out) || *out < 0)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: row %zu: field '%s' = %g is not a "
                             "non-negative number", path, i, key, *out);
    return 0;
}

static void list_add(struct report_list *l, const char *name)
{
    for (size_t i = 0; i < l->n; i++)
        if (!strcmp(l->name[i], name))
            return;
    if (l->n < REPORT_LIST_MAX)
        snprintf(l->name[l->n++], REPORT_NAME_MAX, "%s", name);
}

/* The study's own list: names, or objects with a "name". */
static void list_from_study(struct report_list *l, json_t *study, const char *key)
{
    json_t *a = json_object_get(study, key), *v;
    size_t i;
    json_array_foreach(a, i, v)
    {
        json_t *name = json_is_object(v) ? json_object_get(v, "name") : v;
        if (json_is_string(name) && strlen(json_string_value(name)) < REPORT_NAME_MAX)
            list_add(l, json_string_value(name));
    }
}

static int read_row(json_t *o, struct report_row *r, const char *path, size_t i,
                    struct gonio_err *err)
{
    static const char *dom[] = {"plan", "inplane", "full"};
    static const char *met[] = {"log", "rel_rmse"};
    if (!json_is_object(o))
        return gonio_err_set(err, GONIO_EBADDATA, "%s: row %zu is not an object", path, i);
    int rc = 0;
    if ((rc = get_string(o, "row_id", r->row_id, sizeof r->row_id, 0, path, i, err)) ||
        (rc = get_string(o, "material", r->material, sizeof r->material, 1, path, i, err)) ||
        (rc = get_string(o, "scene", r->scene, sizeof r->scene, 1, path, i, err)) ||
        (rc = get_string(o, "plan", r->plan, sizeof r->plan, 1, path, i, err)) ||
        (rc = get_string(o, "model", r->model, sizeof r->model, 1, path, i, err)) ||
        (rc = get_string(o, "status", r->status, sizeof r->status, 0, path, i, err)) ||
        (rc = get_string(o, "material_spec", r->material_spec, sizeof r->material_spec, 0,
                         path, i, err)) ||
        (rc = get_string(o, "model_file", r->model_file, sizeof r->model_file, 0, path, i,
                         err)) ||
        (rc = get_string(o, "samples_file", r->samples_file, sizeof r->samples_file, 0, path,
                         i, err)) ||
        (rc = get_number(o, "samples", &r->samples, path, i, err)) ||
        (rc = get_number(o, "plan_points", &r->plan_points, path, i, err)) ||
        (rc = get_number(o, "rig_time_s", &r->rig_time_s, path, i, err)) ||
        (rc = get_number(o, "move_s", &r->move_s, path, i, err)) ||
        (rc = get_number(o, "settle_s", &r->settle_s, path, i, err)) ||
        (rc = get_number(o, "integration_s", &r->integration_s, path, i, err)) ||
        (rc = get_number(o, "fit_wall_s", &r->fit_wall_s, path, i, err)) ||
        (rc = get_number(o, "fit_cpu_s", &r->fit_cpu_s, path, i, err)) ||
        (rc = get_string(o, "isotropy", r->isotropy, sizeof r->isotropy, 0, path, i, err)) ||
        (rc = get_string(o, "oop", r->oop, sizeof r->oop, 0, path, i, err)) ||
        (rc = get_number(o, "isotropy_s", &r->isotropy_s, path, i, err)) ||
        (rc = get_number(o, "oop_s", &r->oop_s, path, i, err)))
        return rc;
    for (int d = 0; d < REPORT_N_DOMAINS; d++)
        for (int m = 0; m < REPORT_N_METRICS; m++) {
            char key[32];
            snprintf(key, sizeof key, "%s_%s", dom[d], met[m]);
            if ((rc = get_number(o, key, &r->err[d][m], path, i, err)))
                return rc;
        }
    if (!r->row_id[0])
        snprintf(r->row_id, sizeof r->row_id, "%s.%s.%s.%s", r->material, r->scene, r->plan,
                 r->model);
    return 0;
}

int report_results_read(const char *dir, struct report_results *r, struct gonio_err *err)
{
    memset(r, 0, sizeof *r);
    char path[4200];
    snprintf(path, sizeof path, "%.4000s/results.json", dir);
    json_error_t je;
    json_t *root = json_load_file(path, 0, &je);
    if (!root) {
        FILE *f = fopen(path, "r");
        if (!f)
            return gonio_err_set(err, GONIO_ENOTFOUND, "%s: not found (is %s a study "
                                 "directory? docs/study.md)", path, dir);
        fclose(f);
        return gonio_err_set(err, GONIO_EBADDATA, "%s: line %d: %s", path, je.line, je.text);
    }
    int rc = 0;
    json_t *rows = json_object_get(root, "rows");
    json_t *format = json_object_get(root, "format");
    if (!json_is_object(root) || !json_is_array(rows)) {
        rc = gonio_err_set(err, GONIO_EBADDATA, "%s: field 'rows' is missing or not an array",
                           path);
        goto out;
    }
    if (format && (!json_is_string(format) ||
                   strncmp(json_string_value(format), "gonio-study-", 12))) {
        rc = gonio_err_set(err, GONIO_EBADDATA, "%s: field 'format' is not gonio-study-N",
                           path);
        goto out;
    }
    size_t n = json_array_size(rows);
    r->rows = calloc(n ? n : 1, sizeof *r->rows);
    if (!r->rows) {
        rc = gonio_err_set(err, GONIO_EBADDATA, "%s: out of memory", path);
        goto out;
    }
    for (size_t i = 0; i < n; i++) {
        if ((rc = read_row(json_array_get(rows, i), &r->rows[i], path, i, err)))
            goto out;
        r->n_rows++;
    }
    json_t *study = json_object_get(root, "study");
    list_from_study(&r->materials, study, "materials");
    list_from_study(&r->scenes, study, "scenes");
    list_from_study(&r->plans, study, "plans");
    list_from_study(&r->models, study, "models");
    for (size_t i = 0; i < r->n_rows; i++) {
        list_add(&r->materials, r->rows[i].material);
        list_add(&r->scenes, r->rows[i].scene);
        list_add(&r->plans, r->rows[i].plan);
        list_add(&r->models, r->rows[i].model);
    }
    json_t *complete = json_object_get(root, "complete");
    r->complete = !complete || json_is_true(complete);
    r->n_missing = json_array_size(json_object_get(root, "missing"));
out:
    json_decref(root);
    if (rc)
        report_results_free(r);
    return rc;
}

void report_results_free(struct report_results *r)
{
    free(r->rows);
    r->rows = NULL;
    r->n_rows = 0;
}

const struct report_row *report_results_find(const struct report_results *r,
                                             const char *material, const char *scene,
                                             const char *plan, const char *model)
{
    for (size_t i = 0; i < r->n_rows; i++) {
        const struct report_row *w = &r->rows[i];
        if (!strcmp(w->material, material) && !strcmp(w->scene, scene) &&
            !strcmp(w->plan, plan) && !strcmp(w->model, model))
            return w;
    }
    return NULL;
}
