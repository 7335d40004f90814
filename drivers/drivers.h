/* Device drivers behind opaque handles (after libmodbus's backends).
 *
 * Only the constructors depend on the backend; the capture engine uses the
 * generic calls. An axis moves to absolute positions in degrees; several
 * axes started one after the other move together, and waiting for each
 * returns once all are in position. A detector integrates for a given time
 * and returns an RGB reading. The rig clock is the time the rig itself
 * experiences: wall time on hardware, simulated time on a simulator. */
#ifndef GONIO_DRIVERS_DRIVERS_H
#define GONIO_DRIVERS_DRIVERS_H

#include "common/err.h"

typedef struct drv_axis drv_axis;
typedef struct drv_detector drv_detector;
typedef struct drv_clock drv_clock;

int drv_axis_start_move(drv_axis *ax, double target_deg, struct gonio_err *err);
int drv_axis_wait(drv_axis *ax, struct gonio_err *err);
int drv_axis_position(drv_axis *ax, double *deg, struct gonio_err *err);
int drv_axis_home(drv_axis *ax, struct gonio_err *err);
int drv_axis_stop(drv_axis *ax, struct gonio_err *err);
const char *drv_axis_name(const drv_axis *ax);

/* What the axis's mechanics cost so far: moves sent to the drive (legs,
 * re-commands included), re-commands of a drive that came to rest outside
 * the in-position band, drive alarms reset and the move retried, and
 * re-homings an alarm called for. All zero for a backend that does not
 * recover (the in-process simulator). */
struct drv_axis_stats {
    long moves, recommands, alarms_recovered, rehomes;
};
void drv_axis_stats(const drv_axis *ax, struct drv_axis_stats *out);
void drv_axis_free(drv_axis *ax);

#define DRV_READING_SATURATED 0x1u

struct drv_reading {
    double rgb[3];        /* BRDF, 1/sr (calibrated) */
    double integration_s; /* integration time actually used */
    unsigned flags;       /* DRV_READING_* */
};

int drv_detector_acquire(drv_detector *d, double integration_s, struct drv_reading *out,
                         struct gonio_err *err);
void drv_detector_free(drv_detector *d);

double drv_clock_now(drv_clock *c);
int drv_clock_sleep(drv_clock *c, double seconds);
void drv_clock_free(drv_clock *c);

/* Wall time (monotonic, seconds since creation): the clock of hardware
 * whose devices keep no rig time. NULL when out of memory. */
drv_clock *drv_clock_new_wall(void);

#endif
