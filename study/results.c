/* study.json, and results.csv / results.json gathered from the row files. */
#include "study/study.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <jansson.h>

#include "capture/checks.h"
#include "common/paths.h"
#include "study/study_private.h"

const struct study_col study_cols[] = {
    {"row_id", STUDY_COL_STR},         {"material", STUDY_COL_STR},
    {"material_spec", STUDY_COL_STR},  {"scene", STUDY_COL_STR},
    {"plan", STUDY_COL_STR},           {"model", STUDY_COL_STR},
    {"status", STUDY_COL_STR},         {"samples", STUDY_COL_INT},
    {"plan_points", STUDY_COL_INT},    {"stop_reason", STUDY_COL_STR},
    {"rig_time_s", STUDY_COL_REAL},    {"move_s", STUDY_COL_REAL},
    {"settle_s", STUDY_COL_REAL},      {"integration_s", STUDY_COL_REAL},
    {"calibration_s", STUDY_COL_REAL},
    {"isotropy", STUDY_COL_STR},       {"isotropy_s", STUDY_COL_REAL},
    {"oop", STUDY_COL_STR},            {"oop_s", STUDY_COL_REAL},
    {"fit_wall_s", STUDY_COL_TIME},    {"fit_cpu_s", STUDY_COL_TIME},
    {"fit_converged", STUDY_COL_INT},  {"fit_status", STUDY_COL_STR},
    {"fit_findings", STUDY_COL_STR},   {"fit_geometries", STUDY_COL_INT},
    {"fit_params", STUDY_COL_INT},     {"fit_rank", STUDY_COL_INT},
    {"fit_condition", STUDY_COL_REAL}, {"fit_at_bound", STUDY_COL_STR},
    {"fit_rms_log_insample", STUDY_COL_REAL}, {"fit_rms_log_heldout", STUDY_COL_REAL},
    {"plan_log", STUDY_COL_REAL},
    {"plan_rel_rmse", STUDY_COL_REAL}, {"plan_n", STUDY_COL_INT},
    {"inplane_log", STUDY_COL_REAL},   {"inplane_rel_rmse", STUDY_COL_REAL},
    {"inplane_n", STUDY_COL_INT},      {"full_log", STUDY_COL_REAL},
    {"full_rel_rmse", STUDY_COL_REAL}, {"full_n", STUDY_COL_INT},
    {"full_skipped", STUDY_COL_INT},   {"model_file", STUDY_COL_STR},
    {"samples_file", STUDY_COL_STR},   {"note", STUDY_COL_STR},
};
const size_t study_n_cols = sizeof study_cols / sizeof study_cols[0];

static json_t *real_or_null(double v)
{
    return isfinite(v) ? json_real(v) : json_null();
}

void study_row_status(json_t *row, const struct fit_status *st)
{
    char findings[96] = "";
    if (st)
        fit_status_findings(st, findings, sizeof findings);
    json_object_set_new(row, "fit_status",
                        st ? json_string(fit_status_name(fit_status_code(st))) : json_null());
    json_object_set_new(row, "fit_findings", st ? json_string(findings) : json_null());
    json_object_set_new(row, "fit_geometries",
                        st ? json_integer((json_int_t)st->geometries) : json_null());
    json_object_set_new(row, "fit_params",
                        st && st->params >= 0 ? json_integer(st->params) : json_null());
    json_object_set_new(row, "fit_rank", st && st->rank >= 0 ? json_integer(st->rank) : json_null());
    json_object_set_new(row, "fit_condition", real_or_null(st ? st->cond : NAN));
    json_object_set_new(row, "fit_at_bound", st ? json_string(st->at_bound) : json_null());
    json_object_set_new(row, "fit_rms_log_insample", real_or_null(st ? st->insample : NAN));
    json_object_set_new(row, "fit_rms_log_heldout", real_or_null(st ? st->heldout : NAN));
}

static json_t *items_json(const struct study_item *it, size_t n, int with_spec)
{
    json_t *a = json_array();
    for (size_t i = 0; i < n; i++)
        json_array_append_new(a, with_spec ? json_pack("{s:s,s:s}", "name", it[i].name, "spec",
                                                       it[i].spec)
                                           : json_string(it[i].spec));
    return a;
}

json_t *study_spec_json(const struct study_spec *s, int with_shard)
{
    json_t *o = json_object();
    json_object_set_new(o, "format", json_string(STUDY_FORMAT));
    json_object_set_new(o, "materials", items_json(s->materials, s->n_materials, 1));
    json_object_set_new(o, "scenes", items_json(s->scenes, s->n_scenes, 1));
    json_object_set_new(o, "plans", items_json(s->plans, s->n_plans, 0));
    json_object_set_new(o, "models", items_json(s->models, s->n_models, 0));
    json_object_set_new(o, "saturated", json_string(fit_saturated_name(s->saturated)));
    char checks[64];
    json_object_set_new(o, "checks", json_string(capture_checks_text(s->checks, checks,
                                                                     sizeof checks)));
    json_object_set_new(o, "rig", json_string(s->rig));
    if (with_shard) {
        json_object_set_new(o, "quick", json_boolean(s->quick));
        json_object_set_new(o, "shard", json_pack("[i,i]", s->shard_i, s->shard_n));
        json_object_set_new(o, "jobs", json_integer((json_int_t)study_job_count(s)));
    }
    return o;
}

static int write_text_atomic(const char *path, const char *text, struct gonio_err *err)
{
    return gonio_write_file_atomic(path, text, strlen(text), err);
}

static int write_json_file(const char *path, json_t *o, struct gonio_err *err)
{
    char *text = json_dumps(o, JSON_INDENT(1) | JSON_REAL_PRECISION(17));
    if (!text)
        return gonio_err_set(err, ENOMEM, "out of memory");
    size_t len = strlen(text);
    char *t2 = realloc(text, len + 2);
    if (!t2) {
        free(text);
        return gonio_err_set(err, ENOMEM, "out of memory");
    }
    memcpy(t2 + len, "\n", 2);
    int rc = write_text_atomic(path, t2, err);
    free(t2);
    return rc;
}

/* The lists of a study.json, checked against the format. */
static int items_read(const char *path, json_t *a, const char *key, struct study_item *it,
                      size_t *n, int with_spec, struct gonio_err *err)
{
    if (!json_is_array(a) || json_array_size(a) == 0 || json_array_size(a) > STUDY_MAX_ITEMS)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: key '%s': not a list of 1..%d entries",
                             path, key, STUDY_MAX_ITEMS);
    *n = json_array_size(a);
    for (size_t i = 0; i < *n; i++) {
        json_t *e = json_array_get(a, i);
        const char *name = with_spec ? json_string_value(json_object_get(e, "name"))
                                     : json_string_value(e);
        const char *spec = with_spec ? json_string_value(json_object_get(e, "spec")) : name;
        if (!name || !spec || !*name || strlen(name) >= STUDY_NAME_MAX ||
            strlen(spec) >= STUDY_SPEC_MAX)
            return gonio_err_set(err, GONIO_EBADDATA, "%s: key '%s': entry %zu is not valid",
                                 path, key, i + 1);
        snprintf(it[i].name, sizeof it[i].name, "%s", name);
        snprintf(it[i].spec, sizeof it[i].spec, "%s", spec);
    }
    return 0;
}

int study_spec_read(const char *dir, struct study_spec *s, struct gonio_err *err)
{
    char path[4200];
    snprintf(path, sizeof path, "%.4000s/study.json", dir);
    json_error_t je;
    json_t *root = json_load_file(path, 0, &je);
    if (!root)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: not a study folder (%s)", path, je.text);
    memset(s, 0, sizeof *s);
    int rc = 0;
    const char *fmt = json_string_value(json_object_get(root, "format"));
    if (!fmt || strcmp(fmt, STUDY_FORMAT))
        rc = gonio_err_set(err, GONIO_EBADDATA, "%s: key 'format': '%s', expected '%s'", path,
                           fmt ? fmt : "(missing)", STUDY_FORMAT);
    if (rc == 0)
        rc = items_read(path, json_object_get(root, "materials"), "materials", s->materials,
                        &s->n_materials, 1, err);
    if (rc == 0)
        rc = items_read(path, json_object_get(root, "scenes"), "scenes", s->scenes,
                        &s->n_scenes, 1, err);
    if (rc == 0)
        rc = items_read(path, json_object_get(root, "plans"), "plans", s->plans, &s->n_plans, 0,
                        err);
    if (rc == 0)
        rc = items_read(path, json_object_get(root, "models"), "models", s->models,
                        &s->n_models, 0, err);
    /* Names become folder names: no dots (the id separator), no slashes. */
    for (size_t i = 0; rc == 0 && i < s->n_materials + s->n_scenes; i++) {
        const char *name = i < s->n_materials ? s->materials[i].name
                                              : s->scenes[i - s->n_materials].name;
        if (strpbrk(name, "./"))
            rc = gonio_err_set(err, GONIO_EBADDATA, "%s: name '%s' is not valid", path, name);
    }
    for (size_t i = 0; rc == 0 && i < s->n_plans; i++)
        if (study_plan_of(&s->plans[i], &(struct study_plan){0}) < 0)
            rc = gonio_err_set(err, GONIO_EBADDATA, "%s: unknown plan '%s'", path,
                               s->plans[i].name);
    json_t *shard = json_object_get(root, "shard");
    s->quick = json_is_true(json_object_get(root, "quick"));
    /* studies from before the key fitted the clipped values */
    json_t *sat = json_object_get(root, "saturated");
    s->saturated = FIT_SATURATED_CLIPPED;
    if (rc == 0 && sat &&
        (!json_is_string(sat) || fit_saturated_parse(json_string_value(sat), &s->saturated) < 0))
        rc = gonio_err_set(err, GONIO_EBADDATA,
                           "%s: key 'saturated': '%s', expected default, clipped or censored",
                           path, json_is_string(sat) ? json_string_value(sat) : "(not a string)");
    /* studies from before the keys made no check, on the default rig */
    json_t *checks = json_object_get(root, "checks"), *rig = json_object_get(root, "rig");
    s->checks = 0;
    if (rc == 0 && checks && (!json_is_string(checks) ||
                              (json_string_value(checks)[0] &&
                               capture_checks_parse("checks", json_string_value(checks),
                                                    &s->checks, err) < 0)))
        rc = gonio_err_set(err, GONIO_EBADDATA, "%s: key 'checks': not a list of checks", path);
    snprintf(s->rig, sizeof s->rig, "%s", json_is_string(rig) ? json_string_value(rig) : "");
    s->shard_i = (int)json_integer_value(json_array_get(shard, 0));
    s->shard_n = (int)json_integer_value(json_array_get(shard, 1));
    if (rc == 0 && (s->shard_n < 1 || s->shard_i < 1 || s->shard_i > s->shard_n))
        rc = gonio_err_set(err, GONIO_EBADDATA, "%s: key 'shard': not [I, N] with 1 <= I <= N",
                           path);
    json_decref(root);
    return rc;
}

int study_dir_prepare(const struct study_spec *s, const char *dir, struct gonio_err *err)
{
    int rc = gonio_mkdir_p(dir, err);
    if (rc < 0)
        return rc;
    char path[4200];
    snprintf(path, sizeof path, "%.4000s/study.json", dir);
    json_t *mine = study_spec_json(s, 1);
    json_t *theirs = json_load_file(path, 0, NULL);
    if (theirs) {
        /* The same study (lists and shard) may be resumed; another may not. */
        json_t *a = study_spec_json(s, 0);
        json_t *shard = json_object_get(theirs, "shard");
        int same_shard = json_equal(shard, json_object_get(mine, "shard"));
        json_object_del(theirs, "quick");
        if (!json_object_get(theirs, "saturated")) /* from before the key: clipped */
            json_object_set_new(theirs, "saturated", json_string("clipped"));
        if (!json_object_get(theirs, "checks")) /* from before the key: none */
            json_object_set_new(theirs, "checks", json_string(""));
        if (!json_object_get(theirs, "rig"))
            json_object_set_new(theirs, "rig", json_string(""));
        json_object_del(theirs, "shard");
        json_object_del(theirs, "jobs");
        int same = json_equal(a, theirs);
        json_decref(a);
        json_decref(theirs);
        json_decref(mine);
        if (!same || !same_shard)
            return gonio_err_set(err, GONIO_EUSAGE,
                                 "%s: holds a study with other %s; rerun with its lists or "
                                 "choose a new --out",
                                 path,
                                 same ? "--shard"
                                      : "materials, scenes, plans, models, checks or rig");
        return 0;
    }
    rc = write_json_file(path, mine, err);
    json_decref(mine);
    return rc;
}

/* One CSV field of a row object. */
static void csv_field(FILE *f, json_t *v, enum study_col_type type)
{
    if (!v || json_is_null(v))
        return;
    switch (type) {
    case STUDY_COL_STR: /* lists (fit_findings, fit_at_bound) are ';'-separated here */
        for (const char *c = json_string_value(v) ? json_string_value(v) : ""; *c; c++)
            fputc(*c == ',' ? ';' : *c, f);
        break;
    case STUDY_COL_INT: fprintf(f, "%lld", (long long)json_integer_value(v)); break;
    case STUDY_COL_REAL: fprintf(f, "%.6g", json_number_value(v)); break;
    case STUDY_COL_TIME: fprintf(f, "%.3f", json_number_value(v)); break;
    }
}

int study_results_write(const struct study_spec *s, const char *dir, size_t *missing,
                        struct gonio_err *err)
{
    char *csv = NULL;
    size_t csv_len = 0;
    FILE *f = open_memstream(&csv, &csv_len);
    if (!f)
        return gonio_err_set(err, ENOMEM, "out of memory");
    for (size_t c = 0; c < study_n_cols; c++)
        fprintf(f, "%s%s", c ? "," : "", study_cols[c].name);
    fputc('\n', f);
    json_t *rows = json_array(), *miss = json_array();
    int rc = 0;
    size_t n_missing = 0;
    for (size_t k = 0; rc == 0 && k < study_job_count(s); k++) {
        if (!study_job_in_shard(s, k))
            continue;
        struct study_job job;
        study_job_at(s, k, &job);
        for (size_t m = 0; rc == 0 && m < s->n_models; m++) {
            char path[4200];
            study_row_path(dir, job.id, s->models[m].name, path, sizeof path);
            json_error_t je;
            json_t *row = json_load_file(path, 0, &je);
            if (!row) {
                if (access(path, F_OK) == 0) {
                    rc = gonio_err_set(err, GONIO_EBADDATA, "%s: %s", path, je.text);
                    break;
                }
                char id[512];
                snprintf(id, sizeof id, "%s.%s", job.id, s->models[m].name);
                json_array_append_new(miss, json_string(id));
                n_missing++;
                continue;
            }
            if (!json_is_object(row)) {
                json_decref(row);
                rc = gonio_err_set(err, GONIO_EBADDATA, "%s: not a row object", path);
                break;
            }
            for (size_t c = 0; c < study_n_cols; c++) {
                if (c)
                    fputc(',', f);
                csv_field(f, json_object_get(row, study_cols[c].name), study_cols[c].type);
            }
            fputc('\n', f);
            json_array_append_new(rows, row);
        }
    }
    fclose(f);
    if (rc == 0) {
        char path[4200];
        snprintf(path, sizeof path, "%.4000s/results.csv", dir);
        rc = write_text_atomic(path, csv, err);
        json_t *root = json_object();
        json_object_set_new(root, "format", json_string(STUDY_FORMAT));
        json_object_set_new(root, "study", study_spec_json(s, 1));
        json_object_set_new(root, "complete", json_boolean(n_missing == 0));
        json_object_set_new(root, "missing", json_incref(miss));
        json_object_set_new(root, "rows", json_incref(rows));
        snprintf(path, sizeof path, "%.4000s/results.json", dir);
        if (rc == 0)
            rc = write_json_file(path, root, err);
        json_decref(root);
    }
    json_decref(rows);
    json_decref(miss);
    free(csv);
    if (missing)
        *missing = n_missing;
    return rc;
}
