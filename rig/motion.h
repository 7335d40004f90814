/* Move times of the rig's axes. One function for everyone: the planner's
 * estimate, the capture engine and the simulator all use it, so a plan's
 * estimate equals the simulated rig clock. */
#ifndef GONIO_RIG_MOTION_H
#define GONIO_RIG_MOTION_H

#include "rig/rig.h"

/* Axis positions, degrees: sample s, arm a, azimuth az (0 when in-plane). */
struct rig_axes {
    double s, a, az;
};

/* Time to travel dist degrees from rest to rest with a trapezoidal velocity
 * profile (accelerate at accel, cruise at speed, decelerate at accel); a
 * move too short to reach speed is triangular. 0 for dist 0. */
double rig_axis_time(double dist_deg, double speed, double accel);

/* Time of a move between two positions: all axes start together, so the
 * move lasts as long as the slowest axis. The same either way: the
 * planner's ordering (tours, bounds) assumes a symmetric cost. */
double rig_move_time(const struct rig_profile *rig, const struct rig_axes *from,
                     const struct rig_axes *to);

/* The move as the drivers make it on the rig's mechanics: an axis with
 * backlash arriving against its approach direction takes the leg beyond
 * the target and the approach leg back (rig.h, struct rig_mechanics),
 * sent as the first leg ends (capture/capture.c, measure_point). What the
 * plan's estimate counts, and the simulated clock on a scene without
 * effects. */
double rig_move_time_backlash(const struct rig_profile *rig, const struct rig_axes *from,
                              const struct rig_axes *to);

#endif
