/* Device drivers behind opaque handles (after libmodbus's backends).
 *
 * Only the constructors depend on the backend; the capture engine uses the
 * generic calls. An axis moves to absolute positions in degrees; several
 * axes started one after the other move together, and waiting for each
 * returns once all are in position. How a drive comes to rest (the
 * mechanics below) is decided here, the same for every backend
 * (drivers/axis_mechanics.c); a backend only moves, reports rest, feedback
 * and alarms, resets, homes and stops. A detector integrates for a given time
 * and returns an RGB reading. The rig clock is the time the rig itself
 * experiences: wall time on hardware, simulated time on a simulator. */
#ifndef GONIO_DRIVERS_DRIVERS_H
#define GONIO_DRIVERS_DRIVERS_H

#include "common/err.h"

typedef struct drv_axis drv_axis;
typedef struct drv_detector drv_detector;
typedef struct drv_clock drv_clock;

/* How an axis's drive comes to rest: its soft limits and the rig
 * profile's mechanics (rig/rig.h struct rig_mechanics, docs/plans.md).
 *
 * A move to a target beyond the limits is refused before anything is sent
 * (-GONIO_EUNREACHABLE). A move is done when the axis rests with its
 * encoder within in_position_deg of the target: a drive's IN-POS is taken
 * for rest, and its encoder compared with the target when the position is
 * asked for (a restarted drive reports IN-POS for its own target). A move
 * to where the axis already rests inside the band sends nothing, and its
 * encoder is read again in drv_axis_wait_leg or drv_axis_wait. With backlash_deg, every
 * target is approached from the reference side (approach +1: from below,
 * -1: from above) through a point backlash_deg beyond it when the axis
 * would arrive from the other side. A drive resting outside the band is
 * re-commanded: it backs off to the reference side (by the backlash, at
 * least twice the band) and comes again. A drive alarm is reset (ALM-RST)
 * and the move retried the same way: 0x10 (excessive position deviation)
 * and 0x30 (overload) leave the position valid; 0x28 (sensor error) puts it
 * in doubt, so the axis is re-homed first; 0x66, 0x70 and unknown codes are
 * not retried (the drive refused the command, or the cause is unknown).
 * Re-commands and alarm recoveries both draw on move_retries. Running out
 * of tries, or a stop (drv_axis_stop), fails with -GONIO_EDEVICE, saying
 * overshoot or short, by how much, and what was tried, e.g. "axis arm
 * (slave 2): stopped at -6.13 deg, 0.13 deg short of -6 deg after 4 tries
 * (re-commanded 3 times)". drv_axis_position answers from the feedback
 * read once the last move ended, while the axis rests: the drivers are
 * the drives' only master. A move the drive reported IN-POS for is done
 * without reading the feedback: the first drv_axis_position reads it, so a
 * caller can do so while the axes settle; outside the band it re-commands
 * the axis and waits (drawing on move_retries), or fails naming the axis,
 * position and target ("axis arm (slave 2): reported IN-POS at 0 deg, 30
 * deg short of 30 deg"). */
struct drv_axis_mechanics {
    double min_deg, max_deg; /* soft limits */
    double in_position_deg;  /* > 0 */
    double backlash_deg;     /* 0: direct moves */
    int approach;            /* -1: from above; otherwise from below */
    int move_retries;
};

int drv_axis_start_move(drv_axis *ax, double target_deg, struct gonio_err *err);
/* Degrees of the leg under way (0 when none): with backlash the first leg
 * of a move can stop beyond its target, and the approach leg follows. */
double drv_axis_leg_deg(const drv_axis *ax);
/* Wait for the leg under way when the approach leg follows it, and send
 * that at once without waiting for it: a caller moving several axes sends
 * each one's approach leg as soon as its first leg ends, taking the axes
 * whose first legs end first first. 0 when no approach leg was pending (an
 * alarm or a stop is left to drv_axis_wait). An axis with no move to make
 * reads its encoder here (while the others move) and comes back to the
 * target if it is not there. */
int drv_axis_wait_leg(drv_axis *ax, struct gonio_err *err);
int drv_axis_wait(drv_axis *ax, struct gonio_err *err);
int drv_axis_position(drv_axis *ax, double *deg, struct gonio_err *err);
/* Rig seconds the axis has rested since its last move or homing ended,
 * as the drive said it: at least that long, never more (a settle timed
 * from it runs whole). 0 while a move is under way or after one failed. */
double drv_axis_rested(const drv_axis *ax);
int drv_axis_home(drv_axis *ax, struct gonio_err *err);
int drv_axis_stop(drv_axis *ax, struct gonio_err *err);
/* Reset a drive alarm (ALM-RST): 0 when it cleared, else -GONIO_EDEVICE
 * naming the code the drive still shows. */
int drv_axis_alarm_reset(drv_axis *ax, struct gonio_err *err);
const char *drv_axis_name(const drv_axis *ax);

/* What a drive says of itself, read from it now (goniod's bring-up and
 * probe): the encoder, the drive's output status (each flag -1 where the
 * backend has none to read, as the in-process rig) and its present alarm
 * (0: none; drv_alarm_name names it). Moves nothing. */
struct drv_axis_state {
    double position_deg;
    int ready, moving, in_pos, home_end, alarm_active;
    unsigned alarm;
};
int drv_axis_state(drv_axis *ax, struct drv_axis_state *out, struct gonio_err *err);
/* The AZ alarm codes' names (docs/protocol-modbus.md): "overload" for
 * 0x30; "unknown alarm" for a code not in the table, "" for 0. */
const char *drv_alarm_name(unsigned code);

/* What the axis's mechanics cost so far: moves sent to the drive (legs,
 * re-commands included), re-commands of a drive that came to rest outside
 * the in-position band, drive alarms reset and the move retried, and
 * re-homings an alarm called for. */
struct drv_axis_stats {
    long moves, recommands, alarms_recovered, rehomes;
};
void drv_axis_stats(const drv_axis *ax, struct drv_axis_stats *out);
void drv_axis_free(drv_axis *ax);

#define DRV_READING_SATURATED 0x1u /* a channel clipped (at full_scale, or the device says so) */

/* What a reading's values are: BRDF from a detector that reduces them itself
 * (the ideal simulated scenes), or counts as a real detector's ADC gives
 * them, dark offset included, which a calibration turns into BRDF. */
enum drv_unit { DRV_UNIT_BRDF = 0, DRV_UNIT_COUNTS = 1 };

struct drv_reading {
    double rgb[3];        /* BRDF 1/sr, or counts (ADU): see unit */
    double integration_s; /* integration time actually used */
    unsigned flags;       /* DRV_READING_* */
    enum drv_unit unit;
    double full_scale;    /* DRV_UNIT_COUNTS: the largest count the ADC gives; else 0 */
    /* DRV_UNIT_COUNTS: the detector's nonlinearity as it states it, k: a
     * signal of x counts above the offset reads x - k x^2 / full_scale
     * (0: linear, or not stated). */
    double nonlinearity;
    double monitor;       /* the lamp monitor's counts over the integration; NAN: no monitor */
    int gain_state;       /* the detector's gain setting, 0 where it has none */
    /* DRV_UNIT_COUNTS from a spectral detector: its n_bands band counts
     * (offset included, as rgb's) at the wavelengths bands_nm, of which
     * rgb holds three bins' means; valid until its next reading. 0: none. */
    int n_bands;
    const double *bands_nm, *bands;
};

/* Zeroes *out (monitor NAN) before the backend fills it. */
int drv_detector_acquire(drv_detector *d, double integration_s, struct drv_reading *out,
                         struct gonio_err *err);
/* Close (closed 1) or open the light path: the shutter in front of the
 * detector, or the lamp switched off, for dark frames. -ENOTSUP (err says
 * so) where the rig has none: the operator is asked to cover it instead. */
int drv_detector_shutter(drv_detector *d, int closed, struct gonio_err *err);
/* Rig seconds that surely pass between a call of drv_detector_acquire and
 * the start of its integration (the trigger's time on a slow line; 0 where
 * nothing bounds it): a caller that must not integrate before a moment
 * may call this much earlier. */
double drv_detector_lag(const drv_detector *d);
void drv_detector_free(drv_detector *d);

/* The rig time, seconds: monotonic by construction (a device's reading
 * that would take it back is held at the last value and counted). */
double drv_clock_now(drv_clock *c);
int drv_clock_sleep(drv_clock *c, double seconds);
/* What a clock read from a device went through: times the rig time would
 * have gone back by more than the device's resolution and was held
 * instead, and restarts of the device seen on its clock (its register
 * going back), across which the rig time carries on. Each is also warned
 * of on stderr (the first few). */
struct drv_clock_stats {
    long backward, restarts;
};
void drv_clock_stats(const drv_clock *c, struct drv_clock_stats *out);
void drv_clock_free(drv_clock *c);

/* Wall time (monotonic, seconds since creation): the clock of hardware
 * whose devices keep no rig time. Its sleeps ask cancelled (with user;
 * NULL: none) every 50 ms and fail with -ECANCELED once it says so. NULL
 * when out of memory. */
drv_clock *drv_clock_new_wall(int (*cancelled)(void *user), void *user);

#endif
