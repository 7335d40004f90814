/* Inside capture/: one point measured on the capture's devices, and the
 * rig clock its time is read from. The capture's points and the premise
 * checks' readings are measured the same way: the axes moved together and
 * settled, the detector auto-ranged, the dark frames it takes journalled,
 * and the sample recorded where the axes actually were. */
#ifndef GONIO_CAPTURE_MEASURE_H
#define GONIO_CAPTURE_MEASURE_H

#include <stddef.h>

#include "capture/autorange.h"
#include "capture/capture.h"
#include "capture/capture_bands.h"
#include "common/err.h"
#include "drivers/drivers.h"
#include "journal/journal.h"
#include "planner/planner.h"
#include "rig/rig.h"

/* The rig time a capture reports. A resumed run continues from the last
 * journalled sample (base) by what the rig clock measured since its devices
 * opened (t0), on every driver; clock that ran while the host held the
 * capture paused is kept apart (paused), not counted as rig time. */
struct capture_clock {
    drv_clock *clock;
    double base, t0, last, paused;
};

/* Start at base (the rig time the journal reached) on clock. */
void capture_clock_start(struct capture_clock *rc, drv_clock *clock, double base);

/* The rig time now, less the time the host held the capture paused. */
double capture_clock_now(struct capture_clock *rc);

/* The host held the capture paused since the last reading. */
void capture_clock_paused(struct capture_clock *rc);

/* Auto-ranging across a run's points, and where its dark frames go: the
 * journal, as records of the point being measured (at). */
struct capture_ranging {
    struct autorange ar;
    journal *j;
    struct capture_clock *clk;
    const struct journal_sample *at;
    size_t darks; /* journalled by this run */
    struct capture_bands_reading bands; /* the kept reading's (a spectral detector's) */
};

/* Measure pt on d with the sample turned rotation_deg into *s (index: the
 * plan point, -1 for a check's reading; the host's phase events name it),
 * its dark frames journalled through rg. On failure an axis may be left
 * moving: the caller stops them (capture_axes_stop). */
int capture_measure_point(struct capture_devices *d, struct capture_clock *clk,
                          const struct capture_hooks *hooks, const struct rig_profile *rig,
                          const struct plan_point *pt, double rotation_deg, int index,
                          struct capture_ranging *rg, struct journal_sample *s,
                          struct gonio_err *err);

/* What the axes' mechanics cost (re-commands, alarms, re-homes), added
 * to *sum. */
void capture_axis_stats_add(const struct capture_devices *d, struct drv_axis_stats *sum);

/* Stop every axis d has, ignoring errors: nothing is left moving. */
void capture_axes_stop(struct capture_devices *d);

#endif
