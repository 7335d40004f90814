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
#include "rig/rig.h"
#include "sim/effects_detector.h"
#include "sim/effects_faults.h"
#include "sim/scene.h"

/* SIM_AXIS_ROTATION turns the sample about its own normal (a rig profile's
 * optional axes.rotation): the material is read in the turned sample's
 * frame (brdf_pair_rotate). The Modbus server serves each axis the profile
 * has as a drive of its own (docs/protocol-modbus.md), on this same rig: a
 * turn commanded over the bus reads the material turned as in-process. */
enum sim_axis_id { SIM_AXIS_SAMPLE, SIM_AXIS_ARM, SIM_AXIS_AZIMUTH, SIM_AXIS_ROTATION, SIM_N_AXES };

/* The pair the optics see with the axes at s, a, az (the planner's mapping
 * inverted), and the cosine of the source's incidence on the sample
 * (floored: a grazing source still lights a little, and the exposure stays
 * finite). */
void sim_axes_optics(double s, double a, double az, struct brdf_pair *p, double *cos_i);

typedef struct sim_rig sim_rig;

/* The rig keeps pointers to profile and material: both must outlive it.
 * A rig of no scene: the material's exact values, fixed integration. */
sim_rig *sim_rig_new(const struct rig_profile *profile, const brdf_material *material,
                     struct gonio_err *err);
void sim_rig_free(sim_rig *rig);

/* A rig simulating a scene (scene NULL: no effects): the scene's effects
 * built once into a pipeline (sim/effects.h), a detector of the scene's
 * kind, and with out_dir (may be NULL) a spectral detector's spectra
 * appended to out_dir/spectra.csv. Profile and material must outlive the
 * rig; the scene is copied. */
sim_rig *sim_rig_new_scene(const struct rig_profile *profile, const brdf_material *material,
                           const struct sim_scene *scene, const char *out_dir,
                           struct gonio_err *err);

/* Another material in the sample's place, as a sample changer swaps it:
 * the rig's clock, axes and effects go on (sim_detector_mount). scene: the
 * rig's (NULL: none). The material is borrowed. */
int sim_rig_mount(sim_rig *rig, const brdf_material *material, const struct sim_scene *scene,
                  struct gonio_err *err);

/* 1 when the rig's detector gives counts (the scene has an adc effect). */
int sim_rig_counts(const sim_rig *rig);

/* The rig profile the rig runs (its axes and mechanics). */
const struct rig_profile *sim_rig_profile(const sim_rig *rig);

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

/* Advance the clock to the end of the axis's move. Fails with GONIO_EDEVICE
 * naming the alarm code when the move raised an alarm (stall, alarm
 * effects); the axis then stays in alarm, refusing moves, until reset. */
int sim_rig_wait(sim_rig *rig, enum sim_axis_id axis, struct gonio_err *err);

/* The axis's present alarm code (0 none), and the alarm reset (ALM-RST). */
int sim_rig_alarm(const sim_rig *rig, enum sim_axis_id axis);
void sim_rig_reset_alarm(sim_rig *rig, enum sim_axis_id axis);

/* The scene's communication-fault decisions for transports (NULL when the
 * scene has none): see sim/effects_faults.h. */
sim_faults *sim_rig_faults(sim_rig *rig);

/* Axis position at the current simulated time, as the motor's encoder
 * reports it (backlash slack is not seen; jitter is). */
double sim_rig_position(const sim_rig *rig, enum sim_axis_id axis);

/* Stop an axis where it is now (an emergency stop: no deceleration ramp). */
void sim_rig_stop(sim_rig *rig, enum sim_axis_id axis);

/* sim_rig_acquire's RGB only: with no effects, the material seen by the
 * detector at the axes' positions, in 1/sr, after integration_s. */
int sim_rig_measure(sim_rig *rig, double integration_s, double rgb[3], struct gonio_err *err);

/* The material seen by the detector at the axes' positions now, in 1/sr,
 * without advancing the clock: an integration that runs on a clock kept by
 * someone else (gonio-sim's detector is BUSY meanwhile). Returns 0. */
int sim_rig_sample(const sim_rig *rig, double rgb[3]);

/* The scene's detector at the axes' load positions now: the reading with
 * the scene's effects, the integration it chose (auto-exposure when the
 * scene has noise, integration_s otherwise) and its flags, without
 * advancing the clock (gonio-sim keeps its own). Needs sim_rig_new_scene. */
int sim_rig_read(sim_rig *rig, double integration_s, struct sim_reading *out,
                 struct gonio_err *err);

/* Close (1) or open (0) the detector's shutter (sim_detector_shutter):
 * closed, readings hold its dark signal and offset only. */
void sim_rig_shutter(sim_rig *rig, int closed);

/* sim_rig_read, then the clock advances by the integration used. */
int sim_rig_acquire(sim_rig *rig, double integration_s, struct sim_reading *out,
                    struct gonio_err *err);

#endif
