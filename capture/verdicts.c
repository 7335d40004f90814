/* The premise checks' verdicts and --model auto's choice as JSON, once
 * (capture/verdicts.h). */
#include "capture/verdicts.h"

#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "capture/capture_files.h"

static const char *const isotropy_text[] = {"unknown", "isotropic", "anisotropic"};
static const char *const oop_text[] = {"unchecked", "sufficient", "insufficient"};

json_t *capture_verdicts_auto(const struct capture_summary *s)
{
    if (!s->auto_chosen[0])
        return json_null();
    const struct fit_auto_evidence *ev = &s->auto_evidence;
    json_t *checked = json_object();
    for (size_t k = 0; k < FIT_AUTO_MAX_CANDIDATES && ev->oop[k].model[0]; k++)
        json_object_set_new(checked, ev->oop[k].model, json_string(oop_text[ev->oop[k].verdict]));
    return json_pack("{s:s,s:s,s:s,s:o}", "chosen", s->auto_chosen, "why", s->auto_why,
                     "isotropy", isotropy_text[ev->isotropy], "out_of_plane", checked);
}

/* o's members into data as PREFIX_KEY, an object's members one level down. */
static void flatten(const char *prefix, json_t *o, json_t *data)
{
    const char *k;
    json_t *v;
    json_object_foreach(o, k, v) {
        char key[128];
        snprintf(key, sizeof key, "%s_%s", prefix, k);
        if (json_is_object(v))
            flatten(key, v, data);
        else
            json_object_set(data, key, v);
    }
}

void capture_verdicts_flat(json_t *checks, json_t *auto_doc, json_t *data)
{
    flatten("isotropy", json_object_get(checks, "isotropy"), data);
    flatten("oop", json_object_get(checks, "out_of_plane"), data);
    if (!json_is_object(auto_doc))
        return;
    static const char *const scalars[] = {"chosen", "why", "isotropy"};
    for (size_t i = 0; i < 3; i++) {
        char key[32];
        snprintf(key, sizeof key, "auto_%s", scalars[i]);
        json_object_set(data, key, json_object_get(auto_doc, scalars[i]));
    }
    flatten("auto_oop", json_object_get(auto_doc, "out_of_plane"), data);
}

static void add_oop(struct capture_verdicts *v, const char *model, const char *verdict)
{
    if (!model || !verdict || v->n == FIT_AUTO_MAX_CANDIDATES ||
        capture_verdicts_oop(v, model)[0])
        return;
    snprintf(v->model[v->n], sizeof v->model[v->n], "%s", model);
    snprintf(v->verdict[v->n++], sizeof *v->verdict, "%s", verdict);
    v->found = 1;
}

/* json's member key, when present, as a JSON value of the wanted type
 * (json_is_object or json_is_string), else an error naming path and field. */
static int member(const char *path, const char *field, json_t *json, const char *key,
                  int (*is)(const json_t *), const char *what, json_t **out,
                  struct gonio_err *err)
{
    *out = json_object_get(json, key);
    if (*out && !json_is_null(*out) && !is(*out))
        return gonio_err_set(err, GONIO_EBADDATA, "%s: %s: not %s", path, field, what);
    if (json_is_null(*out))
        *out = NULL;
    return 0;
}

static int is_object(const json_t *j) { return json_is_object(j); }
static int is_string(const json_t *j) { return json_is_string(j); }

int capture_verdicts_read(const char *dir, struct capture_verdicts *out, struct gonio_err *err)
{
    memset(out, 0, sizeof *out);
    char path[4200];
    snprintf(path, sizeof path, "%.4000s/results.json", dir);
    struct stat st;
    if (stat(path, &st) != 0)
        return 0; /* no results.json: no evidence */
    json_error_t je;
    json_t *root = json_load_file(path, 0, &je);
    if (!root)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: line %d: %s", path, je.line, je.text);
    json_t *checks = NULL, *auto_doc = NULL, *iso_doc = NULL, *iso = NULL, *oop_doc = NULL,
           *oop = NULL, *last = NULL, *auto_oop = NULL;
    int rc = json_is_object(root) ? 0
             : gonio_err_set(err, GONIO_EBADDATA, "%s: not a JSON object", path);
    if (!rc)
        rc = member(path, "checks", root, "checks", is_object, "an object", &checks, err);
    if (!rc)
        rc = member(path, "auto", root, "auto", is_object, "an object or null", &auto_doc, err);
    if (!rc)
        rc = member(path, "checks.isotropy", checks, "isotropy", is_object, "an object",
                    &iso_doc, err);
    if (!rc)
        rc = member(path, "checks.isotropy.verdict", iso_doc, "verdict", is_string, "a string",
                    &iso, err);
    if (!rc)
        rc = member(path, "checks.out_of_plane", checks, "out_of_plane", is_object, "an object",
                    &oop_doc, err);
    if (!rc)
        rc = member(path, "checks.out_of_plane.verdict", oop_doc, "verdict", is_string,
                    "a string", &oop, err);
    if (!rc) /* the check of the model fitted last, as it said (also "undetermined") */
        rc = auto_doc ? member(path, "auto.chosen", auto_doc, "chosen", is_string, "a string",
                               &last, err)
                      : member(path, "model", root, "model", is_string, "a string", &last, err);
    if (!rc)
        rc = member(path, "auto.out_of_plane", auto_doc, "out_of_plane", is_object, "an object",
                    &auto_oop, err);
    if (rc) {
        json_decref(root);
        return rc;
    }
    out->isotropy = fit_auto_isotropy_of(json_string_value(iso));
    out->found = iso != NULL;
    add_oop(out, json_string_value(last), json_string_value(oop));
    /* the candidates judged before it: only ever insufficient ones */
    const char *model;
    json_t *verdict;
    json_object_foreach(auto_oop, model, verdict)
        if (!strcmp(json_string_value(verdict) ? json_string_value(verdict) : "", "insufficient"))
            add_oop(out, model, "insufficient");
    json_decref(root);
    return 0;
}

const char *capture_verdicts_oop(const struct capture_verdicts *v, const char *model)
{
    for (size_t k = 0; k < v->n; k++)
        if (!strcmp(v->model[k], model))
            return v->verdict[k];
    return "";
}
