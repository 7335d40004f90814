/* For driver backends only: each backend file defines one const ops table
 * per device kind, with its state behind priv. */
#ifndef GONIO_DRIVERS_PRIVATE_H
#define GONIO_DRIVERS_PRIVATE_H

#include "drivers/drivers.h"

struct drv_axis_ops {
    const char *name;
    int (*start_move)(void *priv, double target_deg, struct gonio_err *err);
    int (*wait)(void *priv, struct gonio_err *err);
    int (*position)(void *priv, double *deg, struct gonio_err *err);
    int (*home)(void *priv, struct gonio_err *err);
    int (*stop)(void *priv, struct gonio_err *err);
    void (*stats)(const void *priv, struct drv_axis_stats *out); /* NULL: all zero */
    void (*free_priv)(void *priv);
};

struct drv_axis {
    const struct drv_axis_ops *ops;
    void *priv;
    char name[32];
};

struct drv_detector_ops {
    const char *name;
    int (*acquire)(void *priv, double integration_s, struct drv_reading *out,
                   struct gonio_err *err);
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
    void (*free_priv)(void *priv);
};

struct drv_clock {
    const struct drv_clock_ops *ops;
    void *priv;
};

drv_axis *drv_axis_alloc(const struct drv_axis_ops *ops, void *priv, const char *name);
drv_detector *drv_detector_alloc(const struct drv_detector_ops *ops, void *priv);
drv_clock *drv_clock_alloc(const struct drv_clock_ops *ops, void *priv);

#endif
