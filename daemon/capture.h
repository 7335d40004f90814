/* The capture engine: runs a plan on a rig, journals every sample, fits the
 * model and writes the capture directory (DESIGN.md sections 7 and 8).
 *
 * The same engine serves `gonio capture --offline` (in-process simulated
 * rig) and goniod. Everything a capture reads (scene, rig profile, plan,
 * material) is validated before anything is written, so bad input leaves
 * no directory behind. */
#ifndef GONIO_DAEMON_CAPTURE_H
#define GONIO_DAEMON_CAPTURE_H

#include <stddef.h>

#include "brdf/abc.h"
#include "brdf/metrics.h"
#include "common/err.h"

struct capture_config {
    const char *plan;     /* name (ds2) or path */
    const char *scene;    /* name or path */
    const char *material; /* overrides the scene's material, or NULL */
    const char *rig;      /* overrides the scene's rig profile, or NULL */
    const char *model;    /* "abc" */
    const char *out_dir;  /* the capture directory */
    const char *order;    /* overrides the plan's ordering, or NULL */
    int quiet;            /* no progress lines on stderr */
};

struct capture_summary {
    char plan[128], material[512], model[32];
    size_t samples;
    double rig_time_s, move_s, settle_s, integration_s;
    double fit_time_s;
    int converged;
    struct brdf_abc params;
    struct brdf_errors err_plan, err_inplane, err_full;
    int has_truth; /* inplane/full errors computed against the known material */
};

/* Run an offline capture against the in-process simulated rig. Returns 0,
 * or a negative code with err filled (see gonio_exit_status). */
int capture_run_offline(const struct capture_config *cfg, struct capture_summary *out,
                        struct gonio_err *err);

#endif
