/* The generic layer: dispatch to the backend's ops table. */
#include "drivers/drivers_private.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

drv_axis *drv_axis_alloc(const struct drv_axis_ops *ops, void *priv, const char *name)
{
    drv_axis *ax = calloc(1, sizeof *ax);
    if (!ax) {
        if (ops->free_priv)
            ops->free_priv(priv);
        return NULL;
    }
    ax->ops = ops;
    ax->priv = priv;
    snprintf(ax->name, sizeof ax->name, "%s", name);
    return ax;
}

int drv_axis_start_move(drv_axis *ax, double target_deg, struct gonio_err *err)
{
    return ax->ops->start_move(ax->priv, target_deg, err);
}

int drv_axis_wait(drv_axis *ax, struct gonio_err *err)
{
    return ax->ops->wait(ax->priv, err);
}

int drv_axis_position(drv_axis *ax, double *deg, struct gonio_err *err)
{
    return ax->ops->position(ax->priv, deg, err);
}

int drv_axis_home(drv_axis *ax, struct gonio_err *err)
{
    if (!ax->ops->home)
        return gonio_err_set(err, ENOTSUP, "axis %s: homing not supported by %s", ax->name,
                             ax->ops->name);
    return ax->ops->home(ax->priv, err);
}

int drv_axis_stop(drv_axis *ax, struct gonio_err *err)
{
    return ax->ops->stop(ax->priv, err);
}

void drv_axis_stats(const drv_axis *ax, struct drv_axis_stats *out)
{
    memset(out, 0, sizeof *out);
    if (ax && ax->ops->stats)
        ax->ops->stats(ax->priv, out);
}

const char *drv_axis_name(const drv_axis *ax)
{
    return ax->name;
}

void drv_axis_free(drv_axis *ax)
{
    if (!ax)
        return;
    if (ax->ops->free_priv)
        ax->ops->free_priv(ax->priv);
    free(ax);
}

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
    return d->ops->acquire(d->priv, integration_s, out, err);
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

void drv_clock_free(drv_clock *c)
{
    if (!c)
        return;
    if (c->ops->free_priv)
        c->ops->free_priv(c->priv);
    free(c);
}
