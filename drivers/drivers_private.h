/* For driver backends only: each backend file defines one const ops table
 * per device kind, with its state behind priv. */
#ifndef GONIO_DRIVERS_PRIVATE_H
#define GONIO_DRIVERS_PRIVATE_H

#include "drivers/drivers.h"

/* An axis backend's primitives: the generic layer (axis_mechanics.c)
 * decides what to do with them. Every one is required but next_leg,
 * resolve and free_priv. */
struct drv_axis_ops {
    const char *name;
    /* Send one absolute move (a leg) from where the axis rests to a target
     * within the limits, and return once the drive has it. */
    int (*start_leg)(void *priv, double from_deg, double target_deg, struct gonio_err *err);
    /* Optional: the leg after the one just sent goes to target_deg (once
     * this one has come to rest), so that the backend may store it on the
     * drive meanwhile and start it at less cost. */
    void (*next_leg)(void *priv, double target_deg);
    /* Wait until the drive rests or is in alarm, and say which: IN-POS as
     * the drive reports it (0 for a drive that does not), the alarm code
     * (0 none). Fails only when the drive cannot be heard or makes no
     * progress without raising an alarm. */
    int (*wait_rest)(void *priv, int *in_pos, unsigned *alarm, struct gonio_err *err);
    /* Rig seconds since the drive came to rest, after a wait_rest or home
     * that found it resting: at least that long (never more). */
    double (*rested)(const void *priv);
    /* The encoder's position, degrees. */
    int (*feedback)(void *priv, double *deg, struct gonio_err *err);
    /* ALM-RST; *alarm: the code the drive still shows after it (0: cleared). */
    int (*reset_alarm)(void *priv, unsigned *alarm, struct gonio_err *err);
    /* Home from from_deg to 0 and wait; *alarm as wait_rest's. */
    int (*home)(void *priv, double from_deg, unsigned *alarm, struct gonio_err *err);
    int (*stop)(void *priv, struct gonio_err *err);
    /* Optional (NULL: the drive has no status to read): its output status
     * as drv_axis_state's flags, and its present alarm code. */
    int (*status)(void *priv, struct drv_axis_state *st, struct gonio_err *err);
    /* Where the drive goes when told deg (its nearest step); NULL: exactly there. */
    double (*resolve)(const void *priv, double deg);
    void (*free_priv)(void *priv);
};

struct drv_detector_ops {
    const char *name;
    int (*acquire)(void *priv, double integration_s, struct drv_reading *out,
                   struct gonio_err *err);
    /* Optional (NULL: 0): drv_detector_lag's figure. */
    double (*lag)(const void *priv);
    /* Optional (NULL: no shutter, -ENOTSUP): drv_detector_shutter. */
    int (*shutter)(void *priv, int closed, struct gonio_err *err);
    void (*free_priv)(void *priv);
};

struct drv_detector {
    const struct drv_detector_ops *ops;
    void *priv;
};

struct drv_clock_ops {
    const char *name;
    double (*now)(void *priv);
    int (*sleep)(void *priv, double seconds);
    /* Optional (NULL: nothing to count): drv_clock_stats's figures. */
    void (*stats)(const void *priv, struct drv_clock_stats *out);
    void (*free_priv)(void *priv);
};

struct drv_clock {
    const struct drv_clock_ops *ops;
    void *priv;
};

/* An axis of the backend ops with state priv (freed with free_priv, also
 * when the allocation fails: NULL). name ("arm") is the axis's, who names
 * it in messages ("axis arm (slave 2)"); mech is copied. */
drv_axis *drv_axis_alloc(const struct drv_axis_ops *ops, void *priv, const char *name,
                         const char *who, const struct drv_axis_mechanics *mech);
drv_detector *drv_detector_alloc(const struct drv_detector_ops *ops, void *priv);
drv_clock *drv_clock_alloc(const struct drv_clock_ops *ops, void *priv);

#endif
