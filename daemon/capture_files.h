/* The files of a capture directory (DESIGN.md section 7, docs/formats.md):
 * plan.json (the resolved plan in execution order), setup.json (scene, rig
 * profile and material as resolved), samples.csv (the journal) and
 * results.json. Every file but the journal is written atomically. */
#ifndef GONIO_DAEMON_CAPTURE_FILES_H
#define GONIO_DAEMON_CAPTURE_FILES_H

#include "daemon/capture.h"
#include "planner/planner.h"
#include "sim/scene.h"

/* Create dir (or accept it for a resume: its plan.json must be this plan's,
 * byte for byte) and write plan.json and setup.json. */
int capture_files_prepare(const char *dir, const struct plan *plan, const struct plan_rig *rig,
                          const struct sim_scene *scene, const char *material,
                          struct gonio_err *err);

/* Write results.json from a finished capture. */
int capture_files_results(const char *dir, const struct capture_summary *s,
                          struct gonio_err *err);

#endif
