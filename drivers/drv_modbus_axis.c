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
    double spd, band, backlash;
    int approach, retries;
    char who[48]; /* "axis arm" */
    /* The leg under way: where it started, its target, when it was sent
     * (wall) and how long the drive needs for it (rig seconds). */
    double leg_from, leg_target, leg_start, leg_time;
    /* The move: its target; a final leg to it still to come (after a leg
     * to the reference side); what it has taken so far (tries beyond the
     * first: re-commands and alarm resets, re-homings, the last alarm). */
    double target;
    int moving, final_pending, stopped;
    int tries, recommands, resets, rehomes;
    unsigned last_alarm;
    /* Where the axis rests, from the encoder at the end of the last move
     * or homing: no need to ask again while it rests (this driver is the
     * bus's only master). */
    int pos_known;
    double pos_deg;
    struct drv_axis_stats stats;
};

/* AZ alarm codes (modbus_map/modbus_map.h, docs/protocol-modbus.md). */
enum { ALM_DEVIATION = MB_ALARM_DEVIATION, ALM_SENSOR = MB_ALARM_SENSOR,
       ALM_OVERLOAD = MB_ALARM_OVERLOAD, ALM_OVERTRAVEL = MB_ALARM_OVERTRAVEL,
       ALM_DATA = MB_ALARM_DATA };

static const char *alarm_name(unsigned code)
{
    switch (code) {
    case ALM_DEVIATION: return "excessive position deviation";
    case ALM_SENSOR: return "sensor error";
    case ALM_OVERLOAD: return "overload";
    case ALM_OVERTRAVEL: return "software overtravel";
    case ALM_DATA: return "abnormal operation data";
    default: return "unknown alarm";
    }
}

/* Status and alarm code in one read of four registers (0x7E-0x81). Four,
 * not two: on RTU an answer carries no request id, and a late answer
 * that slipped past the flush is taken for the next request of the same
 * slave, function and size. The position is read as two registers, so a
 * stale status can never pass for a position (the soak saw a status word
 * 0x4020 read as 164.16 deg); it fails the size check and is retried.
 * The map has no block holding both (0x82-0xCB are unmapped). */
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

static const char *times(int n, char *buf, size_t size)
{
    if (n == 1)
        return "once";
    if (n == 2)
        return "twice";
    snprintf(buf, size, "%d times", n);
    return buf;
}

/* " after 3 tries (re-commanded twice, alarm 0x10 reset once)": what the
 * move took, empty for a first try. */
static void tried(const struct mb_axis *a, char *out, size_t size)
{
    char t1[16], t2[16], t3[16];
    out[0] = '\0';
    if (a->tries == 0)
        return;
    int n = snprintf(out, size, " after %d tries (", a->tries + 1);
    if (a->recommands)
        n += snprintf(out + n, size - (size_t)n, "re-commanded %s",
                      times(a->recommands, t1, sizeof t1));
    if (a->resets)
        n += snprintf(out + n, size - (size_t)n, "%salarm 0x%02x reset %s",
                      a->recommands ? ", " : "", a->last_alarm, times(a->resets, t2, sizeof t2));
    if (a->rehomes)
        n += snprintf(out + n, size - (size_t)n, ", re-homed %s",
                      times(a->rehomes, t3, sizeof t3));
    snprintf(out + n, size - (size_t)n, ")");
}

/* The drive is in alarm and stays so: name the code and what was tried. */
static int alarm_error(struct mb_axis *a, unsigned code, struct gonio_err *err)
{
    char t[128];
    tried(a, t, sizeof t);
    return gonio_err_set(err, GONIO_EDEVICE, "%s (slave %d): drive alarm 0x%02x (%s)%s", a->who,
                         a->slave, code, alarm_name(code), t);
}

/* The drive rests at pos outside the band: overshoot or short (along the
 * last leg), by how much, and what was tried. */
static int miss_error(struct mb_axis *a, double pos, struct gonio_err *err)
{
    char t[128];
    tried(a, t, sizeof t);
    double dir = a->leg_target > a->leg_from   ? 1.0
                 : a->leg_target < a->leg_from ? -1.0
                                               : (double)a->approach;
    double over = (pos - a->target) * dir;
    return gonio_err_set(err, GONIO_EDEVICE, "%s (slave %d): %s at %g deg, %.3g deg %s %g deg%s",
                         a->who, a->slave, a->stopped ? "stopped (STOP)" : "stopped", pos,
                         fabs(over), over > 0 ? "past (overshoot)" : "short of", a->target, t);
}

/* Within the band of the target. Steps in degrees are not exact in
 * binary (12.35 - 12.30 > 0.05): a nanodegree of slack. */
static int in_band(const struct mb_axis *a, double pos)
{
    return fabs(pos - a->target) <= a->band + 1e-9;
}

static int32_t to_steps(double v, double spd)
{
    double s = nearbyint(v * spd);
    return s > 2147483647.0 ? INT32_MAX : s < -2147483648.0 ? INT32_MIN : (int32_t)s;
}

/* Write the direct-data block with the trigger in one transaction: the
 * drive stores the block, then acts on the trigger. The leg's clock
 * starts once the drive has answered: it started no later. */
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
    a->pos_known = 0;
    a->leg_from = from;
    a->leg_target = pos / a->spd;
    a->leg_time = plan_axis_time(fabs(a->leg_target - from), speed / a->spd, accel / a->spd);
    a->stats.moves++;
    int rc = drv_modbus_write(a->bus, a->slave, R_DIRECT, 16, r, a->who, err);
    a->leg_start = gonio_monotonic_s();
    return rc;
}

/* Send the move's next leg from here: straight to the target, or first to
 * a point beyond it on the reference side, when the rig has backlash and
 * the axis would arrive from the other side, or when fresh asks for a new
 * approach (a re-command: a drive told its own target again has nothing
 * to do, so it backs off by the backlash, at least twice the band). */
static int send_approach(struct mb_axis *a, double here, int fresh, struct gonio_err *err)
{
    double back = fresh ? fmax(a->backlash, 2 * a->band) : a->backlash;
    a->final_pending = 0;
    if (back > 0 && (fresh || a->approach * (a->target - here) < 0)) {
        double via = fmin(fmax(a->target - a->approach * back, a->prof.min), a->prof.max);
        if (to_steps(via, a->spd) != to_steps(a->target, a->spd)) {
            a->final_pending = 1;
            return send_leg(a, here, via, err);
        }
    }
    return send_leg(a, here, a->target, err);
}

static int mb_start_move(void *priv, double target, struct gonio_err *err)
{
    struct mb_axis *a = priv;
    if (!isfinite(target) || target < a->prof.min || target > a->prof.max)
        return gonio_err_set(err, GONIO_EUNREACHABLE,
                             "%s: target %g deg beyond its soft limits [%g, %g]", a->who, target,
                             a->prof.min, a->prof.max);
    a->target = target;
    a->tries = a->recommands = a->resets = a->rehomes = 0;
    a->stopped = 0;
    a->final_pending = 0;
    a->moving = 0;
    /* Already resting there: nothing to send, nothing to wait for. */
    if (a->pos_known && in_band(a, a->pos_deg))
        return 0;
    double here = a->pos_deg;
    int rc = a->pos_known ? 0 : read_steps(a, &here, err);
    if (rc < 0)
        return rc;
    a->moving = 1;
    return send_approach(a, here, 0, err);
}

/* Poll the status until the drive rests (MOVE off) or is in alarm,
 * sleeping first until the leg's expected end on the bus's time scale, so
 * a move normally costs one status read. A leg overdue by 0.25 s of rig
 * time is watched for progress on the encoder. */
static int wait_rest(struct mb_axis *a, uint32_t *st, uint32_t *alarm, struct gonio_err *err)
{
    double scale = drv_modbus_time_scale(a->bus);
    double due = a->leg_start + a->leg_time / scale;
    double deadline = due + (0.25 * a->leg_time + 2.0) / scale + 0.5 +
                      4 * drv_modbus_timeout(a->bus);
    double poll = fmin(fmax(0.01 / scale, 0.0002), 0.01);
    double last_pos = NAN, last_change = gonio_monotonic_s();
    drv_modbus_sleep(due - gonio_monotonic_s());
    for (;;) {
        int rc = read_status(a, st, alarm, err);
        if (rc < 0)
            return rc;
        if ((*st & ST_ALM_A) || !(*st & ST_MOVE))
            return 0;
        double now = gonio_monotonic_s(), pos = NAN;
        if ((now - due) * scale > 0.25) {
            if ((rc = read_steps(a, &pos, err)) < 0)
                return rc;
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

/* ALM-RST, then check that the alarm cleared. */
static int reset_alarm(struct mb_axis *a, struct gonio_err *err)
{
    a->pos_known = 0;
    int rc = pulse_input(a, IN_ALM_RST, err);
    uint32_t st = 0, alarm = 0;
    if (rc == 0)
        rc = read_status(a, &st, &alarm, err);
    if (rc == 0 && (st & ST_ALM_A))
        return alarm_error(a, alarm, err);
    return rc;
}

/* ZHOME from here, then wait for HOME-END. */
static int home_from(struct mb_axis *a, double here, struct gonio_err *err)
{
    a->final_pending = 0;
    a->leg_from = here;
    a->leg_target = 0;
    a->leg_time = plan_axis_time(fabs(here), a->prof.speed, a->prof.accel);
    int rc = pulse_input(a, IN_ZHOME, err);
    a->leg_start = gonio_monotonic_s();
    uint32_t st, alarm;
    if (rc == 0)
        rc = wait_rest(a, &st, &alarm, err);
    if (rc == 0 && (st & ST_ALM_A))
        rc = alarm_error(a, alarm, err);
    else if (rc == 0 && !(st & ST_HOME_END))
        rc = gonio_err_set(err, GONIO_EDEVICE, "%s (slave %d): homing ended without HOME-END "
                           "(status 0x%x)", a->who, a->slave, st);
    a->pos_known = rc == 0;
    a->pos_deg = 0;
    return rc;
}

/* The drive is in alarm during a move. Codes the drive recovers from are
 * reset and the move is tried again from where the axis is, through the
 * reference side: 0x10 (excessive position deviation) and 0x30
 * (overload) leave the absolute encoder's position valid, so a reset is
 * enough; 0x28 (sensor error) means the position itself is in doubt, so
 * the axis is re-homed first. 0x66, 0x70 and unknown codes are not
 * retried: the drive refused the command itself, or the cause is unknown. */
static int recover_alarm(struct mb_axis *a, unsigned code, struct gonio_err *err)
{
    int recoverable = code == ALM_DEVIATION || code == ALM_OVERLOAD || code == ALM_SENSOR;
    if (!recoverable || a->tries >= a->retries) {
        a->final_pending = 0;
        return alarm_error(a, code, err);
    }
    a->tries++;
    a->resets++;
    a->last_alarm = code;
    int rc = reset_alarm(a, err);
    a->stats.alarms_recovered += rc == 0;
    double here = 0;
    if (rc == 0 && code == ALM_SENSOR) {
        a->rehomes++;
        a->stats.rehomes++;
        rc = read_steps(a, &here, err);
        if (rc == 0)
            rc = home_from(a, here, err);
        here = 0;
    } else if (rc == 0) {
        rc = read_steps(a, &here, err);
    }
    return rc < 0 ? rc : send_approach(a, here, 1, err);
}

/* Until the move is done: the drive reports IN-POS, or rests inside the
 * band. A drive resting outside is re-commanded, one in alarm recovered,
 * while tries are left. */
static int mb_wait(void *priv, struct gonio_err *err)
{
    struct mb_axis *a = priv;
    if (!a->moving)
        return 0;
    for (;;) {
        uint32_t st, alarm;
        double pos = NAN;
        int rc = wait_rest(a, &st, &alarm, err);
        if (rc == 0 && (st & ST_ALM_A) && !a->stopped) {
            if ((rc = recover_alarm(a, alarm, err)) == 0)
                continue;
        } else if (rc == 0 && (st & ST_ALM_A)) {
            rc = alarm_error(a, alarm, err);
        }
        if (rc == 0 && a->final_pending && !a->stopped) {
            a->final_pending = 0;
            if ((rc = send_leg(a, a->leg_target, a->target, err)) == 0)
                continue;
        }
        if (rc == 0)
            rc = read_steps(a, &pos, err);
        if (rc < 0) {
            a->moving = 0;
            return rc;
        }
        a->pos_deg = pos;
        if ((st & ST_IN_POS) || in_band(a, pos)) {
            a->moving = 0;
            a->pos_known = 1;
            return 0;
        }
        if (a->stopped || a->tries >= a->retries) {
            a->moving = 0;
            return miss_error(a, pos, err);
        }
        a->tries++;
        a->recommands++;
        a->stats.recommands++;
        if ((rc = send_approach(a, pos, 1, err)) < 0) {
            a->moving = 0;
            return rc;
        }
    }
}

static int mb_position(void *priv, double *deg, struct gonio_err *err)
{
    struct mb_axis *a = priv;
    if (a->pos_known) {
        *deg = a->pos_deg;
        return 0;
    }
    return read_steps(a, deg, err);
}

static int mb_home(void *priv, struct gonio_err *err)
{
    struct mb_axis *a = priv;
    double here = 0;
    a->moving = 0;
    int rc = read_steps(a, &here, err);
    return rc < 0 ? rc : home_from(a, here, err);
}

static int mb_stop(void *priv, struct gonio_err *err)
{
    struct mb_axis *a = priv;
    a->final_pending = 0;
    a->pos_known = 0;
    a->stopped = 1;
    return pulse_input(a, IN_STOP, err);
}

static void mb_stats(const void *priv, struct drv_axis_stats *out)
{
    *out = ((const struct mb_axis *)priv)->stats;
}

static const struct drv_axis_ops mb_axis_ops = {
    .name = "modbus",
    .start_move = mb_start_move,
    .wait = mb_wait,
    .position = mb_position,
    .home = mb_home,
    .stop = mb_stop,
    .stats = mb_stats,
    .free_priv = free,
};

int drv_axis_modbus_alarm_reset(drv_axis *ax, struct gonio_err *err)
{
    if (ax->ops != &mb_axis_ops)
        return gonio_err_set(err, EINVAL, "axis %s is not a Modbus axis", ax->name);
    return reset_alarm(ax->priv, err);
}

drv_axis *drv_axis_new_modbus(drv_modbus_bus *bus, int slave, const struct plan_axis *profile,
                              const struct drv_modbus_axis_opts *opts, const char *name,
                              struct gonio_err *err)
{
    static const struct drv_modbus_axis_opts none = {0};
    if (!opts)
        opts = &none;
    double spd = opts->steps_per_deg > 0 ? opts->steps_per_deg : 100.0;
    double band = opts->in_position_deg > 0 ? opts->in_position_deg : 0.5 / spd;
    if (!bus || slave < 1 || slave > 247 || !profile || !(profile->speed > 0) ||
        !(profile->accel > 0) || !isfinite(spd) || !(opts->backlash_deg >= 0) ||
        !isfinite(opts->backlash_deg) || !isfinite(band) || opts->move_retries < 0 ||
        opts->approach < -1 || opts->approach > 1) {
        gonio_err_set(err, EINVAL, "modbus axis %s: slave %d, speed, acceleration, steps per "
                      "degree, in-position band, backlash, approach and retries must be valid",
                      name ? name : "?", slave);
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
    a->band = band;
    a->backlash = opts->backlash_deg;
    a->approach = opts->approach < 0 ? -1 : 1;
    a->retries = opts->move_retries;
    snprintf(a->who, sizeof a->who, "axis %s", name ? name : "?");
    drv_axis *ax = drv_axis_alloc(&mb_axis_ops, a, name ? name : "axis");
    if (!ax) /* drv_axis_alloc freed a */
        gonio_err_set(err, ENOMEM, "modbus axis: out of memory");
    return ax;
}
