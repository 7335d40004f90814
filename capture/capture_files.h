/* The files of a capture directory (DESIGN.md section 7, docs/formats.md):
 * plan.json (the resolved plan in execution order), setup.json (what is
 * known of the rig: driver, detector, rig profile, what its source adds
 * (the simulator's scene) and the material when given), samples.csv (the journal) and results.json. Every file but
 * the journal is written atomically. */
#ifndef GONIO_CAPTURE_CAPTURE_FILES_H
#define GONIO_CAPTURE_CAPTURE_FILES_H

#include <jansson.h>

#include "capture/capture.h"
#include "planner/planner.h"

/* What setup.json records; source (the rig source's further members, a
 * JSON object's text) and material may be NULL (not given), policy is the
 * adaptive order's options (NULL in other orders). */
struct capture_setup {
    const struct plan *plan;
    const struct rig_profile *rig;
    const char *source;
    const char *material;
    const char *driver, *detector;
    const struct adaptive_options *policy;
    /* A detector of counts: its ADC (capture_rig.counts_*) and the
     * integrations auto-ranging may use; ladder NULL for none. */
    double full_scale, nonlinearity;
    const double *ladder;
    size_t n_ladder;
    const char *calibration; /* the calibration's id counts are reduced with, or NULL */
    const char *sample, *operator_name, *note; /* the operator's metadata, NULL: not given */
};

/* Create dir (or accept it for a resume), take its lock (*lock_fd, for
 * capture_files_unlock) and write plan.json and setup.json. A resume must
 * be of the same capture: its plan.json this plan's byte for byte, its
 * setup.json the same source members, material, rig, detector, calibration and adaptive policy
 * options (model, budget, target, stop rule); otherwise, or
 * when another process holds the directory, an error names what differs
 * (or the pid) and nothing is written. */
/* Where the order recorded in dir/plan.json starts: 1 with *start set when
 * it names a start (an order from where the capture found the axes), 0
 * when it does not or there is no plan.json (home). */
int capture_files_plan_start(const char *dir, struct rig_axes *start);

/* Write dir/plan.json again for plan in its present order (a new capture
 * ordered again from where it found the axes, before its first record). */
int capture_files_plan_rewrite(const char *dir, const struct plan *plan,
                               const struct rig_profile *rig, struct gonio_err *err);

int capture_files_prepare(const char *dir, const struct capture_setup *setup, int *lock_fd,
                          struct gonio_err *err);

/* Release the directory's lock. */
void capture_files_unlock(int lock_fd);

/* Write results.json from a finished capture, with the operator's
 * metadata (sample, operator, note) setup.json holds. */
int capture_files_results(const char *dir, const struct capture_summary *s,
                          struct gonio_err *err);

/* results.json's checks: an object with a member per check that ran (the
 * isotropy check's verdict, evidence and rig time), empty when none did;
 * NULL when out of memory. */
json_t *capture_files_checks(const struct capture_summary *s);

#endif
