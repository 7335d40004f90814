/* A study's results as the report reads them: DIR/results.json of
 * `gonio study` (docs/study.md), one row per (material, scene, plan,
 * model). Read with jansson by column name, so columns added later do not
 * break the report. */
#ifndef GONIO_REPORT_RESULTS_H
#define GONIO_REPORT_RESULTS_H

#include <stddef.h>

#include "common/err.h"

#define REPORT_NAME_MAX 64
#define REPORT_PATH_MAX 512
#define REPORT_LIST_MAX 128

enum report_domain { REPORT_PLAN, REPORT_INPLANE, REPORT_FULL, REPORT_N_DOMAINS };
enum report_metric { REPORT_LOG, REPORT_RRMSE, REPORT_N_METRICS };

struct report_row {
    char row_id[4 * REPORT_NAME_MAX];
    char material[REPORT_NAME_MAX], scene[REPORT_NAME_MAX], plan[REPORT_NAME_MAX],
        model[REPORT_NAME_MAX], status[REPORT_NAME_MAX];
    char material_spec[REPORT_PATH_MAX];
    double samples, plan_points;
    double rig_time_s, move_s, settle_s, integration_s;
    double fit_wall_s, fit_cpu_s;
    /* The premise checks' verdicts ("" when not made) and their rig time
     * (NAN), the study's isotropy and oop columns (docs/checks.md). */
    char isotropy[REPORT_NAME_MAX], oop[REPORT_NAME_MAX];
    double isotropy_s, oop_s;
    double err[REPORT_N_DOMAINS][REPORT_N_METRICS]; /* NAN: not available */
    char model_file[REPORT_PATH_MAX], samples_file[REPORT_PATH_MAX]; /* relative to DIR */
};

struct report_list {
    char name[REPORT_LIST_MAX][REPORT_NAME_MAX];
    size_t n;
};

struct report_results {
    struct report_row *rows;
    size_t n_rows;
    /* The study's lists in its order (study object of results.json, else
     * the order of first appearance in the rows). */
    struct report_list materials, scenes, plans, models;
    int complete;
    size_t n_missing;
};

/* Read DIR/results.json. Bad files are GONIO_EBADDATA naming the file, the
 * row and the field; a missing file is GONIO_ENOTFOUND. */
int report_results_read(const char *dir, struct report_results *r, struct gonio_err *err);

void report_results_free(struct report_results *r);

/* The row of (material, scene, plan, model), or NULL. */
const struct report_row *report_results_find(const struct report_results *r,
                                             const char *material, const char *scene,
                                             const char *plan, const char *model);

/* Names for tables and axis titles. */
const char *report_domain_name(enum report_domain d);  /* "plan points", "in-plane", ... */
const char *report_metric_name(enum report_metric m);  /* "log error", "relative RMSE" */

#endif
