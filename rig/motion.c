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

double plan_move_time(const struct plan_rig *rig, const struct plan_axes *from,
                      const struct plan_axes *to)
{
    double t = plan_axis_time(to->s - from->s, rig->sample.speed, rig->sample.accel);
    double ta = plan_axis_time(to->a - from->a, rig->arm.speed, rig->arm.accel);
    if (ta > t)
        t = ta;
    if (rig->out_of_plane) {
        double tz = plan_axis_time(to->az - from->az, rig->azimuth.speed, rig->azimuth.accel);
        if (tz > t)
            t = tz;
    }
    return t;
}
