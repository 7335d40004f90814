#include "daemon/bringup.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

const char *bringup_op_name(enum bringup_op op)
{
    static const char *const names[] = {"where", "home", "move", "limits"};
    return (unsigned)op < 4 ? names[op] : "?";
}

static const struct rig_axis *profile_axis(const struct rig_profile *rig, const char *name)
{
    return !strcmp(name, "sample")    ? &rig->sample
           : !strcmp(name, "arm")     ? &rig->arm
           : !strcmp(name, "rotation") ? &rig->rotation
                                       : &rig->azimuth;
}

int bringup_check(const struct goniod_config *cfg, const struct rig_profile *rig,
                  const struct bringup_job *job, struct gonio_err *err)
{
    const char *op = bringup_op_name(job->op);
    if (cfg->driver == GONIOD_DRIVER_SIM)
        return gonio_err_set(err, GONIO_EUSAGE, "%s: driver 'sim' has no drives to bring up "
                             "(the in-process rig starts at home for every capture)", op);
    if (!job->axis[0])
        return job->op == BRINGUP_MOVE || job->op == BRINGUP_LIMITS
                   ? gonio_err_set(err, GONIO_EUSAGE, "%s: an axis is required", op)
                   : 0;
    if (strcmp(job->axis, "sample") && strcmp(job->axis, "arm") && strcmp(job->axis, "azimuth") &&
        strcmp(job->axis, "rotation"))
        return gonio_err_set(err, GONIO_EUSAGE, "%s: axis '%s': use sample, arm, azimuth or "
                             "rotation", op, job->axis);
    if (!strcmp(job->axis, "azimuth") && !cfg->slaves.azimuth)
        return gonio_err_set(err, GONIO_EUSAGE, "%s: axis 'azimuth': %s has no azimuth drive "
                             "(driver.slaves.azimuth is 0)", op, cfg->path);
    if (!strcmp(job->axis, "rotation") && !cfg->slaves.rotation)
        return gonio_err_set(err, GONIO_EUSAGE, "%s: axis 'rotation': %s has no rotation drive "
                             "(driver.slaves.rotation is 0)", op, cfg->path);
    if (job->op != BRINGUP_MOVE)
        return 0;
    const struct rig_axis *ax = profile_axis(rig, job->axis);
    if (!isfinite(job->deg) || job->deg < ax->min || job->deg > ax->max) {
        int low = !(job->deg >= ax->min);
        return gonio_err_set(err, GONIO_EUSAGE, "move %s %g: beyond the soft limit axes.%s.%s "
                             "%g deg of rig profile '%s' (%g..%g)", job->axis, job->deg,
                             job->axis, low ? "min" : "max", low ? ax->min : ax->max, rig->name,
                             ax->min, ax->max);
    }
    return 0;
}

/* Move one axis to deg and wait for it, reading where it came to rest. */
static int move_to(drv_axis *ax, double deg, double *at, struct gonio_err *err)
{
    int rc = drv_axis_start_move(ax, deg, err);
    if (rc == 0)
        rc = drv_axis_wait(ax, err);
    if (rc == 0)
        rc = drv_axis_position(ax, at, err);
    return rc;
}

/* limits: to the min soft limit, to the max, and back where it started. */
static int run_limits(drv_axis *ax, const struct rig_axis *p, struct bringup_result *out)
{
    double start;
    int rc = drv_axis_position(ax, &start, &out->err);
    if (rc == 0)
        start = fmin(fmax(start, p->min), p->max);
    if (rc == 0)
        rc = move_to(ax, p->min, &out->reached_min, &out->err);
    if (rc == 0)
        rc = move_to(ax, p->max, &out->reached_max, &out->err);
    if (rc == 0)
        rc = move_to(ax, start, &out->back_at, &out->err);
    return rc;
}

static int run_op(struct goniod_axes *axes, const struct rig_profile *rig,
                  const struct bringup_job *job, struct bringup_result *out)
{
    double at;
    for (int i = 0; i < axes->n; i++) {
        if (job->axis[0] && strcmp(job->axis, axes->names[i]))
            continue;
        int rc = 0;
        if (job->op == BRINGUP_HOME)
            rc = drv_axis_home(axes->ax[i], &out->err);
        else if (job->op == BRINGUP_MOVE)
            rc = move_to(axes->ax[i], job->deg, &at, &out->err);
        else if (job->op == BRINGUP_LIMITS)
            rc = run_limits(axes->ax[i], profile_axis(rig, axes->names[i]), out);
        if (rc < 0)
            return rc;
    }
    return 0;
}

void bringup_run(const struct goniod_config *cfg, const struct rig_profile *rig,
                 const struct bringup_job *job, int (*cancelled)(void *user), void *user,
                 struct bringup_result *out)
{
    memset(out, 0, sizeof *out);
    out->reached_min = out->reached_max = out->back_at = NAN;
    struct goniod_axes axes;
    double speed = job->op == BRINGUP_LIMITS ? BRINGUP_LIMITS_SPEED : 1;
    out->rc = goniod_axes_open(cfg, rig, speed, cancelled, user, &axes, &out->err);
    if (out->rc < 0)
        return;
    out->rc = run_op(&axes, rig, job, out);
    /* Cancelled mid-way: a drive still runs its move, which the operator
     * asked to end; STOP goes through although the bus is cancelled. */
    if (out->rc < 0 && cancelled && cancelled(user)) {
        for (int i = 0; i < axes.n; i++)
            drv_axis_stop(axes.ax[i], NULL);
        out->aborted = 1;
        out->rc = gonio_err_set(&out->err, ECANCELED, "%s%s%s: aborted; the axes stopped where "
                                "they stand", bringup_op_name(job->op), job->axis[0] ? " " : "",
                                job->axis);
    }
    /* Where every axis stands now, also after a failure (what the operator
     * needs to see then); the first error is the one reported. */
    for (int i = 0; i < axes.n; i++) {
        struct bringup_axis *b = &out->axes[out->n];
        struct gonio_err e = {0};
        snprintf(b->name, sizeof b->name, "%s", axes.names[i]);
        b->slave = axes.slaves[i];
        int rc = drv_axis_state(axes.ax[i], &b->st, &e);
        if (rc < 0 && out->rc == 0) {
            out->rc = rc;
            out->err = e;
        }
        if (rc == 0)
            out->n++;
    }
    goniod_axes_close(&axes);
}
