/* A capture's rig time before it runs, on a simulated scene: the planner's
 * moves and settle (planner/planner.h) with each point's integration as the
 * scene's detector will choose it. An auto-exposing detector integrates
 * longer where the material is dark, which the rig's fixed integration
 * does not know (a DS1 capture on the lab scene takes 1.4x the fixed
 * estimate); this is the estimate gonio plan --scene and every ETA give. */
#ifndef GONIO_SIM_ESTIMATE_H
#define GONIO_SIM_ESTIMATE_H

#include "brdf/material.h"
#include "common/err.h"
#include "planner/planner.h"
#include "sim/scene.h"

/* Estimate plan on rig for scene measuring material (borrowed). point_s
 * (plan_count entries, or NULL) receives each point's share, integration_s
 * (the same, or NULL) each point's integration (the adaptive policy's
 * cost of a point in any order). Returns 0, or
 * a negative code with err (out of memory; a spectral material outside the
 * detector's bands). */
int sim_estimate_plan(const struct sim_scene *scene, const brdf_material *material,
                      const struct plan *plan, const struct rig_profile *rig, double *point_s,
                      double *integration_s, struct plan_estimate *est, struct gonio_err *err);

#endif
