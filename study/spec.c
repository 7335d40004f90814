/* The study's lists, their checks, the job list and its shards. */
#define _XOPEN_SOURCE 700 /* realpath */
#include "study/study.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "brdf/material.h"
#include "common/paths.h"
#include "fit/models.h"
#include "planner/planner.h"
#include "sim/scene.h"
#include "study/study_private.h"

/* The study's plans: a plan file, and the order and stop rule the capture
 * overrides it with. "six-pair" is ds4 (DESIGN.md section 3: "DS4 is the
 * classic one"), so it is not a plan of its own. The adaptive captures
 * with the ABC policy choose from DS1's pairs (docs/study.md measures them
 * against the 1-degree pool inplane-1deg): until the policy says more
 * points would buy too little, within a quarter of DS1's rig time on the
 * default rig (858 s), and
 * within DS4's rig time on the job's scene and material (15 s on
 * the ideal scene, more where the detector integrates longer); the latent
 * policy, best on the 1-degree pool (docs/adaptive.md), within a quarter of
 * DS1's rig time. */
static const struct study_plan plans[] = {
    {"ds1", "ds1", NULL, NULL, 5.0, 0, NULL, NULL},
    {"ds2", "ds2", NULL, NULL, 1.5, 0, NULL, NULL},
    {"ds3", "ds3", NULL, NULL, 1.0, 0, NULL, NULL},
    {"ds4", "ds4", NULL, NULL, 0.8, 0, NULL, NULL},
    {"progressive", "ds1", "progressive", "converge", 4.0, 0, NULL, NULL},
    {"adaptive", "ds1", "adaptive", "converge", 2.0, 858.0 / 4 / 60, NULL, NULL},
    {"adaptive-ds4", "ds1", "adaptive", "all", 1.0, 0, "ds4", NULL},
    {"adaptive-latent", "inplane-1deg", "adaptive", "all", 3.0, 858.0 / 4 / 60, NULL, "latent"},
    {"inplane-full", "inplane-full", NULL, NULL, 8.0, 0, NULL, NULL},
    {"oop200k", "oop200k", NULL, NULL, 30.0, 0, NULL, NULL},
};

static const char *const models[] = {"abc", "abc-prior", "mlp", "latent", "auto"};

static const char *const full_plans =
    "ds1,ds2,ds3,ds4,progressive,adaptive,adaptive-ds4,adaptive-latent,inplane-full,oop200k";
static const char *const full_models = "abc,mlp,latent";
static const char *const full_scenes = "ideal,lab";
static const char *const quick_materials = "nylon,tungsten-carbide,gold-metallic-paint";
static const char *const quick_plans = "ds1,ds2,ds4,progressive,adaptive";
static const char *const quick_models = "abc,latent";

const char *const study_materials_full[STUDY_N_FULL_MATERIALS] = {
    "nylon", "tungsten-carbide", "specular-black-phenolic", "blue-acrylic", "brass",
    "gold-metallic-paint", "white-diffuse-bball", "red-plastic", "alum-bronze", "pearl-paint",
};

int study_plan_of(const struct study_item *it, struct study_plan *out)
{
    for (size_t i = 0; i < sizeof plans / sizeof plans[0]; i++)
        if (!strcmp(plans[i].name, it->name) && !strcmp(it->spec, it->name)) {
            *out = plans[i];
            return 0;
        }
    /* A lab's own plan file: captured as the file declares (its order and
     * stop rule), at the cost of a mid-size plan for scheduling. */
    if (!gonio_ref_is_file(it->spec))
        return -1;
    *out = (struct study_plan){it->name, it->spec, NULL, NULL, 1.5, 0, NULL, NULL};
    return 0;
}

/* An id-safe name: the part after "kind:", its file name without the
 * extension, anything but letters, digits, '-' and '_' turned into '-'. */
static void item_name(const char *token, char *out, size_t size)
{
    const char *s = strchr(token, ':') ? strchr(token, ':') + 1 : token;
    const char *slash = strrchr(s, '/');
    if (slash)
        s = slash + 1;
    size_t n = strlen(s);
    const char *dot = strrchr(s, '.');
    /* a material's parameters (analytic:KIND?ax=0.08&...) are no extension */
    if (dot && dot != s && !strchr(s, '?'))
        n = (size_t)(dot - s);
    size_t k = 0;
    for (size_t i = 0; i < n && k + 1 < size; i++) {
        char c = s[i];
        int ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                 c == '-' || c == '_';
        out[k++] = ok ? c : '-';
    }
    out[k] = '\0';
}

static const char *list_option(enum study_list which)
{
    static const char *const names[] = {"--materials", "--scenes", "--plans", "--models"};
    return names[which];
}

/* Check one entry and fill its item. */
static int item_check(enum study_list which, const char *token, struct study_item *it,
                      struct gonio_err *err)
{
    const char *opt = list_option(which);
    struct gonio_err e = {0};
    if (strlen(token) >= STUDY_SPEC_MAX)
        return gonio_err_set(err, GONIO_EUSAGE, "%s: entry '%.40s...' is too long", opt, token);
    switch (which) {
    case STUDY_MATERIALS: {
        /* A bare NAME is a MERL material of the shared folder. */
        if (!strcmp(token, "default")) {
            snprintf(it->spec, sizeof it->spec, "%s", brdf_material_default_spec());
            snprintf(it->name, sizeof it->name, "default");
            break;
        }
        if (strchr(token, ':'))
            snprintf(it->spec, sizeof it->spec, "%s", token);
        else
            snprintf(it->spec, sizeof it->spec, "nbrdf:%.500s", token);
        item_name(token, it->name, sizeof it->name);
        brdf_material *m = brdf_material_open(it->spec, &e);
        if (!m)
            return gonio_err_set(err, GONIO_EUSAGE, "%s: material '%s': %s%s", opt, token, e.msg,
                                 gonio_shared_dir() ? "" : " (no shared data folder found)");
        brdf_material_free(m);
        break;
    }
    case STUDY_SCENES: {
        struct sim_scene sc;
        if (sim_scene_load(token, &sc, &e) < 0)
            return gonio_err_set(err, GONIO_EUSAGE, "%s: scene '%s': %s", opt, token, e.msg);
        snprintf(it->spec, sizeof it->spec, "%s", token);
        item_name(token, it->name, sizeof it->name);
        break;
    }
    case STUDY_PLANS: {
        struct study_plan sp;
        snprintf(it->spec, sizeof it->spec, "%s", token);
        snprintf(it->name, sizeof it->name, "%s", token);
        if (gonio_ref_is_file(token)) {
            /* Absolute, so shards and merges run from elsewhere agree. */
            char *abs = realpath(token, NULL);
            if (!abs)
                return gonio_err_set(err, GONIO_EUSAGE, "%s: plan file '%s': %s", opt, token,
                                     strerror(errno));
            snprintf(it->spec, sizeof it->spec, "%s", abs);
            free(abs);
            item_name(token, it->name, sizeof it->name);
            struct rig_profile rig;
            struct plan *p;
            rig_profile_default(&rig);
            if (plan_load(it->spec, &rig, &p, &e) < 0)
                return gonio_err_set(err, GONIO_EUSAGE, "%s: plan '%s': %s", opt, token, e.msg);
            plan_free(p);
        } else if (study_plan_of(it, &sp) < 0) {
            return gonio_err_set(err, GONIO_EUSAGE,
                                 "%s: unknown plan '%s' (use %s, or a plan file)", opt, token,
                                 full_plans);
        }
        break;
    }
    case STUDY_MODELS: {
        int known = 0;
        for (size_t i = 0; i < sizeof models / sizeof models[0]; i++)
            known |= !strcmp(models[i], token);
        if (!known || !fit_model_find(token))
            return gonio_err_set(err, GONIO_EUSAGE,
                                 "%s: unknown model '%s' (use abc, abc-prior, mlp, latent, auto)", opt,
                                 token);
        snprintf(it->spec, sizeof it->spec, "%s", token);
        snprintf(it->name, sizeof it->name, "%s", token);
        break;
    }
    }
    if (!it->name[0])
        return gonio_err_set(err, GONIO_EUSAGE, "%s: entry '%s' gives an empty name", opt, token);
    return 0;
}

int study_spec_set(struct study_spec *s, enum study_list which, const char *list,
                   struct gonio_err *err)
{
    struct study_item *items[] = {s->materials, s->scenes, s->plans, s->models};
    size_t *counts[] = {&s->n_materials, &s->n_scenes, &s->n_plans, &s->n_models};
    const char *opt = list_option(which);
    char *copy = strdup(list);
    struct study_item *tmp = calloc(STUDY_MAX_ITEMS, sizeof *tmp);
    if (!copy || !tmp) {
        free(copy);
        free(tmp);
        return gonio_err_set(err, ENOMEM, "out of memory");
    }
    size_t n = 0;
    int rc = 0;
    char *p = copy;
    for (;;) {
        char *comma = strchr(p, ',');
        if (comma)
            *comma = '\0';
        if (!*p) {
            rc = gonio_err_set(err, GONIO_EUSAGE, "%s '%s': empty entry", opt, list);
            break;
        }
        if (n == STUDY_MAX_ITEMS) {
            rc = gonio_err_set(err, GONIO_EUSAGE, "%s: more than %d entries", opt,
                               STUDY_MAX_ITEMS);
            break;
        }
        if ((rc = item_check(which, p, &tmp[n], err)) < 0)
            break;
        for (size_t i = 0; i < n && rc == 0; i++)
            if (!strcmp(tmp[i].name, tmp[n].name))
                rc = gonio_err_set(err, GONIO_EUSAGE, "%s: '%s' is named twice (as '%s')", opt,
                                   p, tmp[n].name);
        if (rc < 0)
            break;
        n++;
        if (!comma)
            break;
        p = comma + 1;
    }
    if (rc == 0) {
        memcpy(items[which], tmp, n * sizeof *tmp);
        *counts[which] = n;
    }
    free(copy);
    free(tmp);
    return rc;
}

int study_spec_default(struct study_spec *s, int quick, struct gonio_err *err)
{
    memset(s, 0, sizeof *s);
    s->quick = quick;
    s->saturated = FIT_SATURATED_DEFAULT;
    s->shard_i = s->shard_n = 1;
    char materials[1024] = "default";
    if (gonio_shared_dir()) {
        if (quick) {
            snprintf(materials, sizeof materials, "%s", quick_materials);
        } else {
            size_t k = 0;
            for (size_t i = 0; i < STUDY_N_FULL_MATERIALS; i++)
                k += (size_t)snprintf(materials + k, sizeof materials - k, "%s%s", i ? "," : "",
                                      study_materials_full[i]);
        }
    }
    int rc;
    if ((rc = study_spec_set(s, STUDY_MATERIALS, materials, err)) < 0 ||
        (rc = study_spec_set(s, STUDY_SCENES, full_scenes, err)) < 0 ||
        (rc = study_spec_set(s, STUDY_PLANS, quick ? quick_plans : full_plans, err)) < 0 ||
        (rc = study_spec_set(s, STUDY_MODELS, quick ? quick_models : full_models, err)) < 0)
        return rc;
    return 0;
}

int study_spec_set_shard(struct study_spec *s, const char *text, struct gonio_err *err)
{
    char *end;
    errno = 0;
    long i = strtol(text, &end, 10), n = 0;
    int ok = end != text && *end == '/' && text[0] != '-' && text[0] != '+' && errno == 0;
    if (ok) {
        const char *q = end + 1;
        n = strtol(q, &end, 10);
        ok = end != q && *end == '\0' && q[0] != '-' && q[0] != '+' && errno == 0;
    }
    if (!ok || i < 1 || n < 1 || i > n || n > 100000)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "--shard '%s': use I/N with 1 <= I <= N <= 100000 (e.g. 2/4)", text);
    s->shard_i = (int)i;
    s->shard_n = (int)n;
    return 0;
}

size_t study_job_count(const struct study_spec *s)
{
    return s->n_materials * s->n_scenes * s->n_plans;
}

void study_job_at(const struct study_spec *s, size_t k, struct study_job *job)
{
    memset(job, 0, sizeof *job);
    job->index = k;
    job->plan = k % s->n_plans;
    job->scene = (k / s->n_plans) % s->n_scenes;
    job->material = k / (s->n_plans * s->n_scenes);
    snprintf(job->id, sizeof job->id, "%s.%s.%s", s->materials[job->material].name,
             s->scenes[job->scene].name, s->plans[job->plan].name);
}

int study_job_in_shard(const struct study_spec *s, size_t k)
{
    return (int)(k % (size_t)s->shard_n) == s->shard_i - 1;
}

double study_job_weight(const struct study_spec *s, const struct study_job *job)
{
    struct study_plan p;
    return (study_plan_of(&s->plans[job->plan], &p) == 0 ? p.weight : 1.0) * (double)s->n_models;
}

void study_row_path(const char *dir, const char *job_id, const char *model, char *out,
                    size_t size)
{
    snprintf(out, size, "%s/jobs/%s/%s.row.json", dir, job_id, model);
}

size_t study_job_rows_done(const struct study_spec *s, const struct study_job *job,
                           const char *dir)
{
    size_t done = 0;
    for (size_t m = 0; m < s->n_models; m++) {
        char path[4096];
        struct stat st;
        study_row_path(dir, job->id, s->models[m].name, path, sizeof path);
        done += stat(path, &st) == 0;
    }
    return done;
}
