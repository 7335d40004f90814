/* The generic layer of detectors and clocks: dispatch to the backend's ops
 * table (axes: axis_mechanics.c). */
#include "drivers/drivers_private.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

drv_detector *drv_detector_alloc(const struct drv_detector_ops *ops, void *priv)
{
    drv_detector *d = calloc(1, sizeof *d);
    if (!d) {
        if (ops->free_priv)
            ops->free_priv(priv);
        return NULL;
    }
    d->ops = ops;
    d->priv = priv;
    return d;
}

int drv_detector_acquire(drv_detector *d, double integration_s, struct drv_reading *out,
                         struct gonio_err *err)
{
    memset(out, 0, sizeof *out);
    out->monitor = NAN;
    return d->ops->acquire(d->priv, integration_s, out, err);
}

int drv_detector_shutter(drv_detector *d, int closed, struct gonio_err *err)
{
    if (!d->ops->shutter)
        return gonio_err_set(err, ENOTSUP, "detector %s has no shutter", d->ops->name);
    return d->ops->shutter(d->priv, closed, err);
}

double drv_detector_lag(const drv_detector *d)
{
    return d->ops->lag ? d->ops->lag(d->priv) : 0;
}

void drv_detector_free(drv_detector *d)
{
    if (!d)
        return;
    if (d->ops->free_priv)
        d->ops->free_priv(d->priv);
    free(d);
}

drv_clock *drv_clock_alloc(const struct drv_clock_ops *ops, void *priv)
{
    drv_clock *c = calloc(1, sizeof *c);
    if (!c) {
        if (ops->free_priv)
            ops->free_priv(priv);
        return NULL;
    }
    c->ops = ops;
    c->priv = priv;
    return c;
}

double drv_clock_now(drv_clock *c)
{
    return c->ops->now(c->priv);
}

int drv_clock_sleep(drv_clock *c, double seconds)
{
    return c->ops->sleep(c->priv, seconds);
}

void drv_clock_stats(const drv_clock *c, struct drv_clock_stats *out)
{
    memset(out, 0, sizeof *out);
    if (c && c->ops->stats)
        c->ops->stats(c->priv, out);
}

void drv_clock_free(drv_clock *c)
{
    if (!c)
        return;
    if (c->ops->free_priv)
        c->ops->free_priv(c->priv);
    free(c);
}
