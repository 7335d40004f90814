/* The simulated gonioreflectometer core: axes that move with the rig
 * profile's trapezoidal motion on a simulated clock, and a detector that
 * reads the material at the axes' actual positions.
 *
 * The in-process capture and gonio-sim are both built on it. The clock is
 * simulated: nothing here sleeps, so an offline capture of hours of rig time
 * runs in the time its arithmetic takes. */
#ifndef GONIO_SIM_SIM_H
#define GONIO_SIM_SIM_H

#include "brdf/material.h"
#include "common/err.h"
#include "planner/rig.h"

enum sim_axis_id { SIM_AXIS_SAMPLE, SIM_AXIS_ARM, SIM_AXIS_AZIMUTH, SIM_N_AXES };

typedef struct sim_rig sim_rig;

/* The rig keeps pointers to profile and material: both must outlive it. */
sim_rig *sim_rig_new(const struct plan_rig *profile, const brdf_material *material,
                     struct gonio_err *err);
void sim_rig_free(sim_rig *rig);

/* Simulated time, seconds since the rig was created. */
double sim_rig_now(const sim_rig *rig);
void sim_rig_advance(sim_rig *rig, double seconds);

/* Start an absolute move; refused beyond the axis limits. A move started
 * while the axis is still moving starts from where the axis is now. */
int sim_rig_start_move(sim_rig *rig, enum sim_axis_id axis, double target_deg,
                       struct gonio_err *err);

/* sim_rig_start_move at a given speed (deg/s) and acceleration (deg/s^2)
 * instead of the profile's: a drive runs at what it was told. The limits
 * are still the profile's. */
int sim_rig_start_move_at(sim_rig *rig, enum sim_axis_id axis, double target_deg, double speed,
                          double accel, struct gonio_err *err);

/* Time at which the axis will be in position (now when it is at rest). */
double sim_rig_move_end(const sim_rig *rig, enum sim_axis_id axis);

/* Axis position at the current simulated time. */
double sim_rig_position(const sim_rig *rig, enum sim_axis_id axis);

/* Stop an axis where it is now (an emergency stop: no deceleration ramp). */
void sim_rig_stop(sim_rig *rig, enum sim_axis_id axis);

/* Integrate for integration_s at the axes' current positions: the material
 * seen by the detector, in 1/sr. The clock advances by integration_s. */
int sim_rig_measure(sim_rig *rig, double integration_s, double rgb[3], struct gonio_err *err);

/* The material seen by the detector at the axes' positions now, in 1/sr,
 * without advancing the clock: an integration that runs on a clock kept by
 * someone else (gonio-sim's detector is BUSY meanwhile). Returns 0. */
int sim_rig_sample(const sim_rig *rig, double rgb[3]);

#endif
