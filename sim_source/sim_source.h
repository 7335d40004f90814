/* The in-process simulated rig as a capture's rig source (capture/capture.h
 * struct capture_rig): what `gonio capture --offline`, `gonio plan
 * --scene`, the study, goniod's sim driver and the tests hand the engine.
 * The source loads the scene, opens the material the rig measures (the
 * scene's, or the host's override) and meters the integration the scene's
 * detector will choose (sim/effects_detector.h); each capture's devices
 * are a fresh sim_rig over them (drivers/drv_sim.h), continued on a resume
 * where the interrupted run left its axes and clock. */
#ifndef GONIO_SIM_SOURCE_SIM_SOURCE_H
#define GONIO_SIM_SOURCE_SIM_SOURCE_H

#include "capture/capture.h"
#include "common/err.h"

typedef struct sim_source sim_source;

/* The simulator of scene (name or path), measuring material (a material
 * spec, "default", or NULL: the scene's), on the rig profile rig (name or
 * path, NULL: the scene's). NULL with err on a bad scene, material or rig
 * (GONIO_EUSAGE when scene is NULL). */
sim_source *sim_source_new(const char *scene, const char *material, const char *rig,
                           struct gonio_err *err);

/* A scene's description alone, for a host whose devices are elsewhere
 * (goniod on a Modbus rig that a scene describes): its rig profile,
 * detector and setup.json's "scene" member; no simulator, no material. */
sim_source *sim_source_describe(const char *scene, struct gonio_err *err);

void sim_source_free(sim_source *src);

/* The source as the engine takes it; valid while src lives. A description
 * (sim_source_describe) fills only profile, detector and setup_json. */
void sim_source_rig(sim_source *src, struct capture_rig *out);

/* capture_run and capture_check on the in-process simulated rig of scene,
 * cfg->material and cfg->rig (hooks may be NULL). */
int sim_source_capture(const char *scene, const struct capture_config *cfg,
                       const struct capture_hooks *hooks, struct capture_summary *out,
                       struct gonio_err *err);
int sim_source_check(const char *scene, const struct capture_config *cfg,
                     struct plan_estimate *est, struct gonio_err *err);

#endif
