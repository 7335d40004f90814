/* gonio study: materials x scenes x plans x models on the in-process
 * simulated rig, one result row per combination (docs/study.md).
 *
 * A study is a list of independent jobs, one per (material, scene, plan):
 * a job captures once and fits every model to the same samples. Jobs are
 * numbered in a fixed order that depends on the lists only, so `--shard I/N`
 * shares are disjoint and study_merge joins them into what one run writes.
 * Every finished row is its own file, written atomically: that file is the
 * unit of resumption. */
#ifndef GONIO_STUDY_STUDY_H
#define GONIO_STUDY_STUDY_H

#include <stddef.h>

#include "common/err.h"
#include "fit/models.h"

#define STUDY_MAX_ITEMS 128
#define STUDY_NAME_MAX 64
#define STUDY_SPEC_MAX 512

struct study_item {
    char name[STUDY_NAME_MAX]; /* in ids and tables: nylon, ideal, ds1, abc */
    char spec[STUDY_SPEC_MAX]; /* what is opened: nbrdf:nylon, a scene file... */
};

struct study_spec {
    struct study_item materials[STUDY_MAX_ITEMS], scenes[STUDY_MAX_ITEMS],
        plans[STUDY_MAX_ITEMS], models[STUDY_MAX_ITEMS];
    size_t n_materials, n_scenes, n_plans, n_models;
    int quick;
    enum fit_saturated saturated; /* how the fits take saturated readings: each model's
                                     default (fit_model_censors), or `--saturated` */
    /* The premise checks each job's capture makes (CAPTURE_CHECK_*,
     * `--check`), on the rig profile rig ("" the default; `--rig`): the
     * rows' isotropy and oop columns (docs/study.md). */
    unsigned checks;
    char rig[STUDY_SPEC_MAX];
    int shard_i, shard_n; /* 1-based share of the job list: jobs k with k mod n == i - 1 */
};

enum study_list { STUDY_MATERIALS, STUDY_SCENES, STUDY_PLANS, STUDY_MODELS };

/* The full study (quick = 0) or the quick one, shard 1/1. Materials come
 * from the shared data folder when there is one, else the embedded default. */
int study_spec_default(struct study_spec *s, int quick, struct gonio_err *err);

/* Replace one list by a comma-separated LIST, each entry checked (a
 * material or scene is opened, a plan and model looked up): unknown names,
 * empty or repeated entries are GONIO_EUSAGE naming the option and value. */
int study_spec_set(struct study_spec *s, enum study_list which, const char *list,
                   struct gonio_err *err);

/* Parse "I/N" (1 <= I <= N <= 100000) into the spec. */
int study_spec_set_shard(struct study_spec *s, const char *text, struct gonio_err *err);

/* The jobs of the whole study, and the k-th of them (0-based, k < count). */
size_t study_job_count(const struct study_spec *s);
struct study_job {
    size_t index;                  /* position in the whole job list */
    size_t material, scene, plan;  /* indices into the spec's lists */
    char id[3 * STUDY_NAME_MAX + 4]; /* MATERIAL.SCENE.PLAN */
};
void study_job_at(const struct study_spec *s, size_t k, struct study_job *job);

/* Whether job k belongs to the spec's shard. */
int study_job_in_shard(const struct study_spec *s, size_t k);

/* A relative cost, for running the big jobs first. */
double study_job_weight(const struct study_spec *s, const struct study_job *job);

/* How many of the job's rows (one per model) have their row file in dir. */
size_t study_job_rows_done(const struct study_spec *s, const struct study_job *job,
                           const char *dir);

/* Run one job into dir/jobs/ID: capture (or resume the capture), then fit
 * and assess every model whose row file is missing. Takes a lock on the job
 * folder, so two processes never run the same job. stop (may be NULL) is
 * asked at every point boundary of the capture: nonzero ends the job there,
 * its journal whole for a rerun to resume, with -EINTR. Returns the number
 * of rows written, or a negative code with err filled. */
int study_job_run(const struct study_spec *s, const struct study_job *job, const char *dir,
                  int (*stop)(void), struct gonio_err *err);

/* dir/study.json: write it, or when it exists check that it holds the same
 * lists (GONIO_EUSAGE otherwise: rows of two studies would mix). */
int study_dir_prepare(const struct study_spec *s, const char *dir, struct gonio_err *err);

/* Read dir/study.json into s. */
int study_spec_read(const char *dir, struct study_spec *s, struct gonio_err *err);

/* Rewrite dir/results.csv and dir/results.json from the row files of the
 * shard's jobs. *missing (may be NULL) gets the number of rows without a
 * file. */
int study_results_write(const struct study_spec *s, const char *dir, size_t *missing,
                        struct gonio_err *err);

/* Join the shard folders dirs[0..n) (one study, same lists) into out.
 * Returns the number of missing rows (>= 0), or a negative code. */
int study_merge(const char *const *dirs, size_t n, const char *out, struct gonio_err *err);

#endif
