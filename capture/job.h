/* Inside capture/: a prepared capture (capture_prepare). What it reads is
 * resolved and validated once, before anything is written: the check a
 * host makes before it answers and the run that follows share it. */
#ifndef GONIO_CAPTURE_JOB_H
#define GONIO_CAPTURE_JOB_H

#include "adaptive/adaptive.h"
#include "brdf/material.h"
#include "capture/calibration.h"
#include "capture/capture.h"
#include "fit/models.h"
#include "planner/planner.h"
#include "rig/rig.h"

struct capture_job {
    /* The host's configuration, its strings copied (text owns them). */
    struct capture_config cfg;
    char *text;
    const struct capture_rig *src; /* the host's rig source, borrowed */
    struct rig_profile rig;
    struct plan *plan;
    brdf_material *truth_own; /* a named reference (cfg.truth), opened here */
    const brdf_material *truth; /* the truth errors' reference, NULL: none */
    char material_name[512]; /* what was measured, as a label; "" when unknown */
    char truth_name[512];
    const struct fit_model_kind *model; /* the final fit's (fit/models.h) */
    int adaptive; /* the plan's order is adaptive: the policy's options */
    struct adaptive_options policy;
    /* The rig time the capture will take: with the integration the rig
     * source says its detector will choose, else the rig's fixed one. */
    struct plan_estimate est;
    /* Each point's integration as the rig source knows it, for the
     * adaptive policy's costs and the ETA; NULL when it does not (both
     * learn it from the journal). */
    double *integration_s;
    /* Points measured first to meter the material (capture/sequence.h). */
    size_t prescan;
    int ran; /* capture_job_run was called: a job runs once */
    struct cal_loaded *cal; /* the calibration counts are reduced with, or NULL */
};

/* The capture's stop rule: the plan's, or cfg->stop. */
enum plan_stop_kind capture_stop_kind(const struct capture_config *cfg, const struct plan *plan);

/* Tell the host the engine enters phase ph (capture_hooks.on_phase). */
void capture_phase_enter(const struct capture_hooks *hooks, enum capture_phase ph, int point);

#endif
