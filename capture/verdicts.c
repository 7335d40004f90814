/* The premise checks' verdicts and --model auto's choice as JSON, once
 * (capture/verdicts.h). */
#include "capture/verdicts.h"

#include <stdio.h>
#include <string.h>

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

void capture_verdicts_read(const char *dir, struct capture_verdicts *out)
{
    memset(out, 0, sizeof *out);
    char path[4200];
    snprintf(path, sizeof path, "%.4000s/results.json", dir);
    json_t *root = json_load_file(path, 0, NULL);
    json_t *checks = json_object_get(root, "checks"), *auto_doc = json_object_get(root, "auto");
    const char *iso = json_string_value(
        json_object_get(json_object_get(checks, "isotropy"), "verdict"));
    out->isotropy = fit_auto_isotropy_of(iso);
    out->found = iso != NULL;
    /* the check of the model fitted last, as it said (also "undetermined") */
    json_t *last = json_is_object(auto_doc) ? json_object_get(auto_doc, "chosen")
                                            : json_object_get(root, "model");
    add_oop(out, json_string_value(last),
            json_string_value(
                json_object_get(json_object_get(checks, "out_of_plane"), "verdict")));
    /* the candidates judged before it: only ever insufficient ones */
    const char *model;
    json_t *verdict;
    json_object_foreach(json_object_get(auto_doc, "out_of_plane"), model, verdict)
        if (!strcmp(json_string_value(verdict) ? json_string_value(verdict) : "", "insufficient"))
            add_oop(out, model, "insufficient");
    json_decref(root);
}

const char *capture_verdicts_oop(const struct capture_verdicts *v, const char *model)
{
    for (size_t k = 0; k < v->n; k++)
        if (!strcmp(v->model[k], model))
            return v->verdict[k];
    return "";
}
