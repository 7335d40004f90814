#include "rig/motion.h"

#include <math.h>

double plan_axis_time(double dist_deg, double speed, double accel)
{
    double d = fabs(dist_deg);
    if (d == 0.0)
        return 0.0;
    /* Accelerating to speed and back down covers speed^2/accel degrees. */
    if (d <= speed * speed / accel)
        return 2.0 * sqrt(d / accel);
    return d / speed + speed / accel;
}

/* One axis from one rest to the next: the leg to the target, or with
 * backlash (mech != NULL), a move arriving from the side opposite the
 * approach goes first to a point backlash_deg beyond the target (within
 * the limits), then to the target (*approach, else 0), as the drivers move
 * it (drivers/axis_mechanics.c, send_approach). */
static double axis_legs(const struct plan_axis *ax, const struct plan_mechanics *mech,
                        double from, double to, double *approach)
{
    *approach = 0;
    if (mech && mech->backlash_deg > 0) {
        double dir = mech->approach < 0 ? -1.0 : 1.0;
        double via = fmin(fmax(to - dir * mech->backlash_deg, ax->min), ax->max);
        if (dir * (to - from) < 0 && via != to) {
            *approach = plan_axis_time(to - via, ax->speed, ax->accel);
            return plan_axis_time(via - from, ax->speed, ax->accel);
        }
    }
    return plan_axis_time(to - from, ax->speed, ax->accel);
}

/* All axes start together. The capture waits for them in turn (sample,
 * arm, azimuth: capture/capture.c, measure_point), and an axis's approach
 * leg is sent when its wait finds the first leg done: after the axes
 * before it rest. */
static double move_time(const struct plan_rig *rig, const struct plan_mechanics *mech,
                        const struct plan_axes *from, const struct plan_axes *to)
{
    const struct plan_axis *ax[3] = {&rig->sample, &rig->arm, &rig->azimuth};
    const double a[3] = {from->s, from->a, from->az}, b[3] = {to->s, to->a, to->az};
    double t = 0;
    for (int i = 0; i < (rig->out_of_plane ? 3 : 2); i++) {
        double approach, first = axis_legs(ax[i], mech, a[i], b[i], &approach);
        t = fmax(t, first) + approach;
    }
    return t;
}

double plan_move_time(const struct plan_rig *rig, const struct plan_axes *from,
                      const struct plan_axes *to)
{
    return move_time(rig, NULL, from, to);
}

double plan_move_time_backlash(const struct plan_rig *rig, const struct plan_axes *from,
                               const struct plan_axes *to)
{
    return move_time(rig, &rig->mech, from, to);
}
