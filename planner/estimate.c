/* The rig-time estimate of a plan in its order (planner/planner.h): the
 * moves from home (or the axes' present positions) through the points with their backlash legs, the settle
 * and the integration of each point. */
#include <math.h>

#include "planner/plan_private.h"

void plan_estimate_from(const struct plan *plan, const struct rig_profile *rig,
                        const struct rig_axes *start, plan_integration_fn integration,
                        void *user, double *point_s, struct plan_estimate *est)
{
    struct rig_axes at = plan->start;
    double rot = 0;
    if (start)
        at = *start;
    est->move_s = est->integration_s = 0;
    for (size_t i = 0; i < plan->n; i++) {
        const struct plan_point *pt = plan_point(plan, i);
        double move = rig_move_time_backlash(rig, &at, &pt->ax);
        if (rig->has_rotation) /* a plan's sample turns (sample_azimuths) */
            move = fmax(move, rig_axis_time(pt->rotation - rot, rig->rotation.speed,
                                            rig->rotation.accel));
        rot = pt->rotation;
        double t = integration ? integration(user, pt) : rig->integration_s;
        est->move_s += move;
        est->integration_s += t;
        if (point_s)
            point_s[i] = move + rig->settle_s + t;
        at = pt->ax;
    }
    est->settle_s = (double)plan->n * rig->settle_s;
    est->total_s = est->move_s + est->settle_s + est->integration_s;
}

void plan_estimate_points(const struct plan *plan, const struct rig_profile *rig,
                          plan_integration_fn integration, void *user, double *point_s,
                          struct plan_estimate *est)
{
    plan_estimate_from(plan, rig, NULL, integration, user, point_s, est);
}

void plan_estimate(const struct plan *plan, const struct rig_profile *rig,
                   struct plan_estimate *est)
{
    plan_estimate_points(plan, rig, NULL, NULL, NULL, est);
}
