/* An AZ-style axis drive on a Modbus bus (docs/protocol-modbus.md): direct
 * data operation for moves, input commands for homing, stop and alarm
 * reset, the output status for progress. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "drivers/drivers_private.h"
#include "drivers/drv_modbus_private.h"
#include "planner/motion.h"

/* The register map (modbus_map/modbus_map.h) under this file's names. */
enum { R_DIRECT = MB_AX_DATA_NO, R_INPUT = MB_AX_INPUT, R_STATUS = MB_AX_STATUS,
       R_ALARM = MB_AX_ALARM, R_FEEDBACK = MB_AX_FEEDBACK };
enum { IN_ZHOME = MB_IN_ZHOME, IN_STOP = MB_IN_STOP, IN_ALM_RST = MB_IN_ALM_RST };
enum { ST_HOME_END = MB_ST_HOME_END, ST_READY = MB_ST_READY, ST_ALM_A = MB_ST_ALM_A,
       ST_MOVE = MB_ST_MOVE, ST_IN_POS = MB_ST_IN_POS };

struct mb_axis {
    drv_modbus_bus *bus;
    int slave;
    struct plan_axis prof;
    double spd, backlash;
    char who[48]; /* "axis arm" */
    /* The leg under way: target, when it started (wall) and how long the
     * drive needs for it (rig seconds); then the final approach, if the
     * leg is a backlash overshoot. */
    double leg_target, leg_start, leg_time;
    int final_pending;
    double final_target;
    /* Where the axis is, known without asking after a completed move or
     * homing (this driver is the bus's only master), so a move costs one
     * transaction less. */
    int pos_known;
    double pos_deg;
};

static const char *alarm_name(unsigned code)
{
    switch (code) {
    case 0x10: return "excessive position deviation";
    case 0x30: return "overload";
    case 0x28: return "position deviation";
    case 0x66: return "software overtravel";
    case 0x70: return "abnormal operation data";
    default: return "unknown alarm";
    }
}

/* Status and alarm code in one read of four registers (0x7E-0x81). Four,
 * not two: on RTU an answer carries no request id, and a late answer
 * that slipped past the flush is taken for the next request of the same
 * slave, function and size. The position is read as two registers, so a
 * stale status can never pass for a position (the soak saw a status word
 * 0x4020 read as 164.16 deg); it fails the size check and is retried. */
static int read_status(struct mb_axis *a, uint32_t *st, uint32_t *alarm,
                       struct gonio_err *err)
{
    uint16_t r[4];
    int rc = drv_modbus_read(a->bus, a->slave, R_STATUS, 4, r, a->who, err);
    *st = drv_modbus_get32(r);
    *alarm = drv_modbus_get32(r + 2);
    return rc;
}

static int read_steps(struct mb_axis *a, double *deg, struct gonio_err *err)
{
    uint16_t r[2];
    int rc = drv_modbus_read(a->bus, a->slave, R_FEEDBACK, 2, r, a->who, err);
    if (rc == 0)
        *deg = (double)(int32_t)drv_modbus_get32(r) / a->spd;
    return rc;
}

/* The drive is in alarm: name the code. */
static int alarm_error(struct mb_axis *a, unsigned code, struct gonio_err *err)
{
    return gonio_err_set(err, GONIO_EDEVICE, "%s (slave %d): drive alarm 0x%02x (%s)", a->who,
                         a->slave, code, alarm_name(code));
}

static int32_t to_steps(double v, double spd)
{
    double s = nearbyint(v * spd);
    return s > 2147483647.0 ? INT32_MAX : s < -2147483648.0 ? INT32_MIN : (int32_t)s;
}

/* Write the direct-data block with the trigger in one transaction: the
 * drive stores the block, then acts on the trigger. */
static int send_leg(struct mb_axis *a, double from, double to, struct gonio_err *err)
{
    int32_t pos = to_steps(to, a->spd), speed = to_steps(a->prof.speed, a->spd),
            accel = to_steps(a->prof.accel, a->spd);
    if (speed < 1 || accel < 1)
        return gonio_err_set(err, EINVAL, "%s: speed %g deg/s, acceleration %g deg/s^2 round to "
                             "no steps at %g steps/deg", a->who, a->prof.speed, a->prof.accel,
                             a->spd);
    uint16_t r[16];
    uint32_t v[8] = {0, 1, (uint32_t)pos, (uint32_t)speed, (uint32_t)accel, (uint32_t)accel,
                     1000, 1};
    for (int i = 0; i < 8; i++)
        drv_modbus_put32(r + 2 * i, v[i]);
    a->leg_target = pos / a->spd;
    a->leg_time = plan_axis_time(fabs(a->leg_target - from), speed / a->spd, accel / a->spd);
    a->leg_start = gonio_monotonic_s();
    return drv_modbus_write(a->bus, a->slave, R_DIRECT, 16, r, a->who, err);
}

static int mb_start_move(void *priv, double target, struct gonio_err *err)
{
    struct mb_axis *a = priv;
    if (!isfinite(target) || target < a->prof.min || target > a->prof.max)
        return gonio_err_set(err, GONIO_EUNREACHABLE,
                             "%s: target %g deg beyond its soft limits [%g, %g]", a->who, target,
                             a->prof.min, a->prof.max);
    double here = a->pos_deg;
    int rc = a->pos_known ? 0 : read_steps(a, &here, err);
    if (rc < 0)
        return rc;
    a->pos_known = 0;
    a->final_pending = 0;
    /* Approach from below: arriving from above, overshoot below first. */
    if (a->backlash > 0 && target < here) {
        double below = fmax(target - a->backlash, a->prof.min);
        if (below < target) {
            a->final_pending = 1;
            a->final_target = target;
            return send_leg(a, here, below, err);
        }
    }
    return send_leg(a, here, target, err);
}

/* Poll the status until want is set with the drive at rest, pacing the
 * polls by the leg's expected time on the bus's time scale. */
static int wait_for(struct mb_axis *a, uint32_t want, struct gonio_err *err)
{
    double scale = drv_modbus_time_scale(a->bus);
    double due = a->leg_start + a->leg_time / scale;
    double deadline = due + (0.25 * a->leg_time + 2.0) / scale + 0.5 +
                      4 * drv_modbus_timeout(a->bus);
    double poll = fmin(fmax(0.01 / scale, 0.0002), 0.01);
    double last_pos = NAN, last_change = gonio_monotonic_s();
    drv_modbus_sleep(due - gonio_monotonic_s());
    for (;;) {
        uint32_t st, alarm;
        int rc = read_status(a, &st, &alarm, err);
        if (rc < 0)
            return rc;
        if (st & ST_ALM_A)
            return alarm_error(a, alarm, err);
        if ((st & want) == want && !(st & ST_MOVE))
            return 0;
        double now = gonio_monotonic_s(), pos = NAN;
        if (!(st & ST_MOVE) || (now - due) * scale > 0.25) {
            if ((rc = read_steps(a, &pos, err)) < 0)
                return rc;
            if (!(st & ST_MOVE))
                return gonio_err_set(err, GONIO_EDEVICE,
                                     "%s (slave %d): stopped at %g deg short of %g deg", a->who,
                                     a->slave, pos, a->leg_target);
            if (pos != last_pos) {
                last_pos = pos;
                last_change = now;
            } else if ((now - last_change) * scale > 0.5) {
                return gonio_err_set(err, GONIO_EDEVICE,
                                     "%s (slave %d): no progress at %g deg for 0.5 s (stall), "
                                     "target %g deg", a->who, a->slave, pos, a->leg_target);
            }
        }
        if (now > deadline)
            return gonio_err_set(err, GONIO_EDEVICE,
                                 "%s (slave %d): not in position %.3g s (rig) after the move "
                                 "started, expected %.3g s", a->who, a->slave,
                                 (now - a->leg_start) * scale, a->leg_time);
        drv_modbus_sleep(poll);
    }
}

static int mb_wait(void *priv, struct gonio_err *err)
{
    struct mb_axis *a = priv;
    int rc = wait_for(a, ST_IN_POS, err);
    if (rc == 0 && a->final_pending) {
        a->final_pending = 0;
        rc = send_leg(a, a->leg_target, a->final_target, err);
        if (rc == 0)
            rc = wait_for(a, ST_IN_POS, err);
    }
    a->pos_known = rc == 0;
    a->pos_deg = a->leg_target;
    return rc;
}

static int mb_position(void *priv, double *deg, struct gonio_err *err)
{
    return read_steps(priv, deg, err);
}

/* Input commands act on a rising edge: raise the bit, then release it. */
static int pulse_input(struct mb_axis *a, uint32_t bit, struct gonio_err *err)
{
    uint16_t r[2];
    drv_modbus_put32(r, bit);
    int rc = drv_modbus_write(a->bus, a->slave, R_INPUT, 2, r, a->who, err);
    drv_modbus_put32(r, 0);
    int rc2 = drv_modbus_write(a->bus, a->slave, R_INPUT, 2, r, a->who, rc < 0 ? NULL : err);
    return rc < 0 ? rc : rc2;
}

static int mb_home(void *priv, struct gonio_err *err)
{
    struct mb_axis *a = priv;
    double here = 0;
    int rc = read_steps(a, &here, err);
    if (rc < 0)
        return rc;
    a->pos_known = 0;
    a->final_pending = 0;
    a->leg_target = 0;
    a->leg_time = plan_axis_time(fabs(here), a->prof.speed, a->prof.accel);
    a->leg_start = gonio_monotonic_s();
    if ((rc = pulse_input(a, IN_ZHOME, err)) < 0)
        return rc;
    rc = wait_for(a, ST_HOME_END, err);
    a->pos_known = rc == 0;
    a->pos_deg = 0;
    return rc;
}

static int mb_stop(void *priv, struct gonio_err *err)
{
    struct mb_axis *a = priv;
    a->final_pending = 0;
    a->pos_known = 0;
    return pulse_input(a, IN_STOP, err);
}

static const struct drv_axis_ops mb_axis_ops = {
    .name = "modbus",
    .start_move = mb_start_move,
    .wait = mb_wait,
    .position = mb_position,
    .home = mb_home,
    .stop = mb_stop,
    .free_priv = free,
};

int drv_axis_modbus_alarm_reset(drv_axis *ax, struct gonio_err *err)
{
    if (ax->ops != &mb_axis_ops)
        return gonio_err_set(err, EINVAL, "axis %s is not a Modbus axis", ax->name);
    struct mb_axis *a = ax->priv;
    a->pos_known = 0;
    int rc = pulse_input(a, IN_ALM_RST, err);
    uint32_t st = 0, alarm = 0;
    if (rc == 0)
        rc = read_status(a, &st, &alarm, err);
    if (rc == 0 && (st & ST_ALM_A))
        return alarm_error(a, alarm, err);
    return rc;
}

drv_axis *drv_axis_new_modbus(drv_modbus_bus *bus, int slave, const struct plan_axis *profile,
                              const struct drv_modbus_axis_opts *opts, const char *name,
                              struct gonio_err *err)
{
    double spd = opts && opts->steps_per_deg > 0 ? opts->steps_per_deg : 100.0;
    double backlash = opts ? opts->backlash_deg : 0.0;
    if (!bus || slave < 1 || slave > 247 || !profile || !(profile->speed > 0) ||
        !(profile->accel > 0) || !isfinite(spd) || !(backlash >= 0) || !isfinite(backlash)) {
        gonio_err_set(err, EINVAL, "modbus axis %s: slave %d, speed, acceleration, steps per "
                      "degree and backlash must be valid", name ? name : "?", slave);
        return NULL;
    }
    struct mb_axis *a = calloc(1, sizeof *a);
    if (!a) {
        gonio_err_set(err, ENOMEM, "modbus axis: out of memory");
        return NULL;
    }
    a->bus = bus;
    a->slave = slave;
    a->prof = *profile;
    a->spd = spd;
    a->backlash = backlash;
    snprintf(a->who, sizeof a->who, "axis %s", name ? name : "?");
    drv_axis *ax = drv_axis_alloc(&mb_axis_ops, a, name ? name : "axis");
    if (!ax) /* drv_axis_alloc freed a */
        gonio_err_set(err, ENOMEM, "modbus axis: out of memory");
    return ax;
}
