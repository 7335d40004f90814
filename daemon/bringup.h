/* Bring-up on a new rig (docs/goniod.md, "Bring-up"): home, move, where
 * and limits on the drives goniod's configuration wires, one at a time,
 * in the capture worker's thread (daemon/worker.h) so the control socket
 * never waits on a drive. Refused while a capture runs, and a capture
 * request is refused while one runs. */
#ifndef GONIO_DAEMON_BRINGUP_H
#define GONIO_DAEMON_BRINGUP_H

#include "common/err.h"
#include "daemon/config.h"
#include "daemon/devices.h"
#include "drivers/drivers.h"
#include "rig/rig.h"

enum bringup_op { BRINGUP_WHERE, BRINGUP_HOME, BRINGUP_MOVE, BRINGUP_LIMITS };

/* Limits runs drive at this fraction of the profile's speed and
 * acceleration: slowly enough to stop short of a misplaced end stop. */
#define BRINGUP_LIMITS_SPEED 0.25

struct bringup_job {
    enum bringup_op op;
    char axis[16]; /* "sample", "arm", "azimuth", "rotation"; "" all (where, home) */
    double deg;    /* move's target */
};

struct bringup_axis {
    char name[16];
    int slave;
    struct drv_axis_state st;
};

struct bringup_result {
    int rc;
    struct gonio_err err;
    int aborted; /* cancelled (gonio abort, shutdown): the axes were stopped */
    int n;
    struct bringup_axis axes[GONIOD_AXES_MAX]; /* where every axis stands at the end */
    /* limits: where the axis reached its min and max soft limits, and came back to */
    double reached_min, reached_max, back_at;
};

/* The op's name on the wire ("where", "home", "move", "limits"). */
const char *bringup_op_name(enum bringup_op op);

/* Check job against the configuration and rig profile before it runs: an
 * axis the configuration wires, a move within the axis's soft limits
 * (the message names the limit: "axes.arm.max 170 deg of rig profile
 * 'default'"). 0, or GONIO_EUSAGE with err filled. */
int bringup_check(const struct goniod_config *cfg, const struct rig_profile *rig,
                  const struct bringup_job *job, struct gonio_err *err);

/* Run job on the configured drives (opened and closed here); cancelled
 * (with user) ends a wait under way (abort, shutdown): every axis is then
 * told to stop, and out says aborted with rc -ECANCELED. */
void bringup_run(const struct goniod_config *cfg, const struct rig_profile *rig,
                 const struct bringup_job *job, int (*cancelled)(void *user), void *user,
                 struct bringup_result *out);

#endif
