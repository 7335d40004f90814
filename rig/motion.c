#include "rig/motion.h"

#include <math.h>

double rig_axis_time(double dist_deg, double speed, double accel)
{
    double d = fabs(dist_deg);
    if (d == 0.0)
        return 0.0;
    /* Accelerating to speed and back down covers speed^2/accel degrees. */
    if (d <= speed * speed / accel)
        return 2.0 * sqrt(d / accel);
    return d / speed + speed / accel;
}

/* One axis from one rest to the next. With backlash (mech != NULL), a
 * move arriving from the side opposite the approach goes first to a point
 * backlash_deg beyond the target (within the limits), then to the target,
 * as the drivers move it (drivers/axis_mechanics.c, send_approach). */
static double axis_move_time(const struct rig_axis *ax, const struct rig_mechanics *mech,
                             double from, double to)
{
    if (mech && mech->backlash_deg > 0) {
        double dir = mech->approach < 0 ? -1.0 : 1.0;
        double via = fmin(fmax(to - dir * mech->backlash_deg, ax->min), ax->max);
        if (dir * (to - from) < 0 && via != to)
            return rig_axis_time(via - from, ax->speed, ax->accel) +
                   rig_axis_time(to - via, ax->speed, ax->accel);
    }
    return rig_axis_time(to - from, ax->speed, ax->accel);
}

static double move_time(const struct rig_profile *rig, const struct rig_mechanics *mech,
                        const struct rig_axes *from, const struct rig_axes *to)
{
    double t = axis_move_time(&rig->sample, mech, from->s, to->s);
    double ta = axis_move_time(&rig->arm, mech, from->a, to->a);
    if (ta > t)
        t = ta;
    if (rig->out_of_plane) {
        double tz = axis_move_time(&rig->azimuth, mech, from->az, to->az);
        if (tz > t)
            t = tz;
    }
    return t;
}

double rig_move_time(const struct rig_profile *rig, const struct rig_axes *from,
                     const struct rig_axes *to)
{
    return move_time(rig, NULL, from, to);
}

double rig_move_time_backlash(const struct rig_profile *rig, const struct rig_axes *from,
                              const struct rig_axes *to)
{
    return move_time(rig, &rig->mech, from, to);
}
