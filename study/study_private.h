/* Inside study/: the plan table, file names, and the row columns shared by
 * the job (which writes rows), the results writer and merge. */
#ifndef GONIO_STUDY_PRIVATE_H
#define GONIO_STUDY_PRIVATE_H

#include <stddef.h>

#include <jansson.h>

#include "fit/fit_status.h"
#include "study/study.h"

#define STUDY_FORMAT "gonio-study-1"
#define STUDY_N_FULL_MATERIALS 10

extern const char *const study_materials_full[STUDY_N_FULL_MATERIALS];

struct study_plan {
    const char *name;  /* study plan name */
    const char *file;  /* plan name for plan_load */
    const char *order; /* capture order override, or NULL */
    const char *stop;  /* capture stop override, or NULL */
    double weight;     /* relative cost of a job, for scheduling */
    double budget_min; /* the adaptive order's rig-time budget, 0: none */
    /* or that budget is this plan's estimated rig time on the job's scene
     * and material (NULL: budget_min) */
    const char *budget_of;
    const char *model; /* the adaptive policy's model (the capture's), NULL: abc */
};

/* The plan of a --plans entry: a built-in study plan by name, or a plan
 * file (spec is its absolute path). Returns 0, or -1 for neither. */
int study_plan_of(const struct study_item *it, struct study_plan *out);

/* dir/jobs/JOB_ID/MODEL.row.json */
void study_row_path(const char *dir, const char *job_id, const char *model, char *out,
                    size_t size);

/* The columns of results.csv, in order, and the keys of a row object. */
enum study_col_type { STUDY_COL_STR, STUDY_COL_INT, STUDY_COL_REAL, STUDY_COL_TIME };
struct study_col {
    const char *name;
    enum study_col_type type;
};
extern const struct study_col study_cols[];
extern const size_t study_n_cols;

/* The fit_status ... fit_rms_log_heldout columns of a row object from a
 * fit's status (fit/fit_status.h); st NULL (the fit failed): empty. */
void study_row_status(json_t *row, const struct fit_status *st);

/* Calibrate a job on scene whose detector gives counts (study/calibrate.c):
 * a dark, then the standard at plan's points, into root (JOBDIR/
 * calibrations, kept for a rerun), their rig time into *rig_time_s. root
 * is "" when the detector reports BRDF itself (nothing to calibrate). */
int study_calibrate(const char *scene, const char *plan, const char *jobdir, char *root,
                    size_t size, double *rig_time_s, struct gonio_err *err);

/* study.json's content (without shard when shard is 0: for comparisons). */
json_t *study_spec_json(const struct study_spec *s, int with_shard);

#endif
