#include "render/study.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "brdf/material.h"
#include "fit/model_file.h"
#include "render/output.h"

/* A row's string field, or NULL (the caller names the missing field). */
static const char *str(json_t *row, const char *key)
{
    return json_string_value(json_object_get(row, key));
}

/* A name used as a folder: no path, not hidden. */
static int plain_name(const char *s)
{
    return s && *s && s[0] != '.' && !strchr(s, '/');
}

/* model_file must stay inside the study directory. */
static int inside(const char *rel)
{
    return rel && *rel && rel[0] != '/' && !strstr(rel, "..");
}

static int add_cell(struct render_study_material *m, const char *label, const char *spec)
{
    struct render_study_cell *c = realloc(m->cells, (size_t)(m->n + 1) * sizeof *c);
    if (!c)
        return -1;
    m->cells = c;
    snprintf(c[m->n].label, sizeof c[m->n].label, "%s", label);
    snprintf(c[m->n].spec, sizeof c[m->n].spec, "%s", spec);
    m->n++;
    return 0;
}

int render_study_read(const char *dir, const char *scene, struct render_study_material **out,
                      int *n_out, struct gonio_err *err)
{
    char path[4096];
    if (snprintf(path, sizeof path, "%s/results.json", dir) >= (int)sizeof path)
        return gonio_err_set(err, ENAMETOOLONG, "%s: path too long", dir);
    json_error_t jerr;
    json_t *root = json_load_file(path, 0, &jerr);
    if (!root) {
        FILE *f = fopen(path, "r");
        if (!f)
            return gonio_err_set(err, GONIO_ENOTFOUND, "%s: no study results (%s)", path,
                                 strerror(errno));
        fclose(f);
        return gonio_err_set(err, GONIO_EBADDATA, "%s:%d:%d: %s", path, jerr.line, jerr.column,
                             jerr.text);
    }
    int rc = 0;
    struct render_study_material *mats = NULL;
    int n = 0;
    json_t *rows = json_object_get(root, "rows");
    if (!scene) /* the study's first scene: study.scenes[0].name (docs/study.md) */
        scene = str(json_array_get(json_object_get(json_object_get(root, "study"), "scenes"), 0),
                    "name");
    if (!json_is_array(rows) || !scene) {
        rc = gonio_err_set(err, GONIO_EBADDATA, "%s: field '%s' missing (not a gonio study?)",
                           path, json_is_array(rows) ? "study.scenes[0].name" : "rows");
        goto done;
    }
    size_t i;
    json_t *row;
    json_array_foreach(rows, i, row) {
        static const char *const need[] = {"material", "material_spec", "scene", "plan",
                                           "model",    "status"};
        for (size_t k = 0; k < sizeof need / sizeof need[0]; k++)
            if (!str(row, need[k])) {
                rc = gonio_err_set(err, GONIO_EBADDATA, "%s: row %zu: field '%s' missing or "
                                   "not a string", path, i + 1, need[k]);
                goto done;
            }
        const char *name = str(row, "material");
        if (!plain_name(name)) {
            rc = gonio_err_set(err, GONIO_EBADDATA, "%s: row %zu: field 'material': '%s' is not "
                               "a plain name", path, i + 1, name);
            goto done;
        }
        if (strcmp(str(row, "scene"), scene) || strcmp(str(row, "status"), "ok"))
            continue;
        json_t *skipped = json_object_get(row, "full_skipped");
        if (json_is_number(skipped) && json_number_value(skipped) > 0)
            continue; /* in-plane only: a black sphere */
        const char *file = str(row, "model_file");
        if (!inside(file)) {
            rc = gonio_err_set(err, GONIO_EBADDATA, "%s: row %zu: field 'model_file': '%s' is "
                               "not a path inside the study", path, i + 1, file ? file : "null");
            goto done;
        }
        int m = 0;
        while (m < n && strcmp(mats[m].name, name))
            m++;
        if (m == n) {
            struct render_study_material *p = realloc(mats, (size_t)(n + 1) * sizeof *p);
            if (!p) {
                rc = gonio_err_set(err, ENOMEM, "%s: out of memory", path);
                goto done;
            }
            mats = p;
            memset(&mats[n], 0, sizeof mats[n]);
            snprintf(mats[n].name, sizeof mats[n].name, "%s", name);
            snprintf(mats[n].truth, sizeof mats[n].truth, "%s", str(row, "material_spec"));
            n++;
        }
        char label[128], spec[4200];
        snprintf(label, sizeof label, "%.60s/%.60s", str(row, "plan"), str(row, "model"));
        snprintf(spec, sizeof spec, "model:%.2000s/%.2000s", dir, file);
        if (add_cell(&mats[m], label, spec) < 0) {
            rc = gonio_err_set(err, ENOMEM, "%s: out of memory", path);
            goto done;
        }
    }
    if (!n)
        rc = gonio_err_set(err, GONIO_EBADDATA, "%s: no finished row of scene '%s' with a model "
                           "that predicts out of plane", path, scene);
done:
    json_decref(root);
    if (rc < 0) {
        render_study_free(mats, n);
        return rc;
    }
    *out = mats;
    *n_out = n;
    return 0;
}

void render_study_free(struct render_study_material *m, int n)
{
    for (int i = 0; m && i < n; i++)
        free(m[i].cells);
    free(m);
}

int render_study_write(const char *dir, const char *scene, const struct render_scene *sc,
                       int size, int columns, void (*progress)(void *user, int done, int total),
                       void *user, struct gonio_err *err)
{
    struct render_study_material *mats;
    int n;
    int rc = render_study_read(dir, scene, &mats, &n, err);
    if (rc < 0)
        return rc;
    int total = 0;
    for (int i = 0; i < n; i++)
        total += 1 + mats[i].n;
    brdf_material **opened = calloc((size_t)total, sizeof *opened);
    struct render_item *items = calloc((size_t)total, sizeof *items);
    if (!opened || !items)
        rc = gonio_err_set(err, ENOMEM, "out of memory");
    for (int i = 0, k = 0; rc == 0 && i < n; i++)
        for (int c = -1; rc == 0 && c < mats[i].n; c++, k++) {
            const char *spec = c < 0 ? mats[i].truth : mats[i].cells[c].spec;
            if (!(opened[k] = fit_material_open(spec, err))) {
                char msg[GONIO_ERR_MSG_MAX];
                snprintf(msg, sizeof msg, "%s", err->msg);
                rc = gonio_err_set(err, err->code ? err->code : GONIO_EBADDATA, "%s: %s",
                                   mats[i].name, msg);
                break;
            }
            items[k] = (struct render_item){spec, c < 0 ? "truth" : mats[i].cells[c].label,
                                            opened[k]};
        }
    if (rc == 0 && progress)
        progress(user, 0, total);
    for (int i = 0, k = 0; rc == 0 && i < n; k += 1 + mats[i].n, i++) {
        char out[4400];
        snprintf(out, sizeof out, "%s/renders/%s", dir, mats[i].name);
        int cols = columns ? columns : (1 + mats[i].n < 6 ? 1 + mats[i].n : 6);
        struct render_set_options o = {size, 1, cols, NULL};
        rc = render_write_set(out, sc, items + k, 1 + mats[i].n, &o, err);
        if (rc == 0 && progress)
            progress(user, k + 1 + mats[i].n, total);
    }
    for (int k = 0; opened && k < total; k++)
        brdf_material_free(opened[k]);
    free(opened);
    free(items);
    render_study_free(mats, n);
    return rc < 0 ? rc : 0;
}
