#include "sim/estimate.h"

#include <errno.h>
#include <stdlib.h>

#include "sim/effects.h"
#include "sim/effects_detector.h"
#include "sim/sim.h"

/* The detector's choice at the pair the planned axes give. */
static double point_integration(void *user, const struct plan_point *pt)
{
    struct brdf_pair p;
    double cos_i;
    sim_axes_optics(pt->ax.s, pt->ax.a, pt->ax.az, &p, &cos_i);
    return sim_detector_meter(user, &p, cos_i);
}

int sim_estimate_plan(const struct sim_scene *scene, const brdf_material *material,
                      const struct plan *plan, const struct rig_profile *rig, double *point_s,
                      double *integration_s, struct plan_estimate *est, struct gonio_err *err)
{
    sim_effects *fx = sim_effects_new(scene, err);
    sim_detector *det = fx ? sim_detector_new(rig, material, scene, fx, NULL, err) : NULL;
    if (det)
        plan_estimate_points(plan, rig, point_integration, det, point_s, est);
    for (size_t i = 0; det && integration_s && i < plan_count(plan); i++)
        integration_s[i] = point_integration(det, plan_point(plan, i));
    int rc = det ? 0 : -abs(err ? err->code : ENOMEM);
    sim_detector_free(det);
    sim_effects_free(fx);
    return rc;
}
