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
#include "rig/motion.h"

/* The register map (modbus_map/modbus_map.h) under this file's names. */
enum { R_DIRECT = MB_AX_DATA_NO, R_POSITION = MB_AX_POSITION, R_TRIGGER = MB_AX_TRIGGER,
       R_INPUT = MB_AX_INPUT, R_STATUS = MB_AX_STATUS, R_ALARM = MB_AX_ALARM,
       R_FEEDBACK = MB_AX_FEEDBACK };
enum { IN_ZHOME = MB_IN_ZHOME, IN_STOP = MB_IN_STOP, IN_ALM_RST = MB_IN_ALM_RST };
enum { ST_HOME_END = MB_ST_HOME_END, ST_READY = MB_ST_READY, ST_ALM_A = MB_ST_ALM_A,
       ST_MOVE = MB_ST_MOVE, ST_IN_POS = MB_ST_IN_POS };

/* The drive's state for its primitives: the mechanics are the generic
 * layer's (axis_mechanics.c). */
struct mb_axis {
    drv_modbus_bus *bus;
    int slave;
    struct rig_axis prof;
    double spd;
    char who[48]; /* "axis arm" */
    /* The leg under way: its target, when the drive likely started it
     * (wall) and how long it needs for it (rig seconds): when to look at
     * the drive. */
    double leg_target, leg_start, leg_time;
    /* When the drive last said it rests, at the latest (wall; 0: never),
     * and on a simulated clock the line's rig time by then
     * (drv_modbus_line_rig): what has passed since on the rig. */
    double rest_wall, rest_line;
    /* What the drive holds of the direct-data block as we wrote it: all
     * but the position (block), and a position stored for the next leg
     * while the one under way runs (staged). Cleared by anything that may
     * have left the drive otherwise. */
    int block, staged;
    int32_t staged_pos;
    long block_faults; /* drv_modbus_faults when the block was written */
    /* The leg after the one under way (mb_next_leg): to stage. */
    int next;
    int32_t next_pos;
};

/* Status and alarm code in one read of four registers (0x7E-0x81). Four,
 * not two: on RTU an answer carries no request id, and a late answer
 * that slipped past the flush is taken for the next request of the same
 * slave, function and size. The position is read as two registers, so a
 * stale status can never pass for a position (the soak saw a status word
 * 0x4020 read as 164.16 deg); it fails the size check and is retried.
 * The map has no block holding both (0x82-0xCB are unmapped). */
static int pulse_input(struct mb_axis *a, uint32_t bit, struct gonio_err *err);

static int read_status(struct mb_axis *a, uint32_t *st, uint32_t *alarm,
                       struct gonio_err *err)
{
    uint16_t r[4];
    int rc = drv_modbus_read(a->bus, a->slave, R_STATUS, 4, r, a->who, err);
    if (rc < 0) /* a failed read leaves r as it was: report nothing from it */
        return rc;
    *st = drv_modbus_get32(r);
    *alarm = drv_modbus_get32(r + 2);
    return 0;
}

static int mb_feedback(void *priv, double *deg, struct gonio_err *err)
{
    struct mb_axis *a = priv;
    uint16_t r[2];
    int rc = drv_modbus_read(a->bus, a->slave, R_FEEDBACK, 2, r, a->who, err);
    if (rc == 0)
        *deg = (double)(int32_t)drv_modbus_get32(r) / a->spd;
    return rc;
}

static int32_t to_steps(double v, double spd)
{
    double s = nearbyint(v * spd);
    return s > 2147483647.0 ? INT32_MAX : s < -2147483648.0 ? INT32_MIN : (int32_t)s;
}

/* The drive goes to whole steps. */
static double mb_resolve(const void *priv, double deg)
{
    const struct mb_axis *a = priv;
    return to_steps(deg, a->spd) / a->spd;
}

/* The drive likely started the leg when it acted on the last write, a
 * frame's silence before it answered (drv_modbus_gap_s): the status read
 * is timed from there. */
static void leg_started(struct mb_axis *a)
{
    double lo, hi;
    drv_modbus_acted(a->bus, &lo, &hi);
    a->leg_start = fmax(lo, hi - drv_modbus_gap_s(a->bus));
}

/* A part of the block went out through a failed attempt: a drive that
 * restarted across it took the part as a whole block with no speed and
 * raised alarm 0x70 (abnormal operation data), which only that part can
 * have raised. Reset it, and write the block whole. */
static int rewrite_block(struct mb_axis *a, const uint16_t *r, struct gonio_err *err)
{
    uint32_t st = 0, code = 0;
    int rc = read_status(a, &st, &code, err);
    if (rc == 0 && (st & ST_ALM_A) && code == MB_ALARM_DATA)
        rc = pulse_input(a, IN_ALM_RST, err);
    return rc < 0 ? rc : drv_modbus_write(a->bus, a->slave, R_DIRECT, 16, r, a->who, err);
}

/* Write the direct-data block with the trigger in one transaction: the
 * drive stores the block, then acts on the trigger. Only the position
 * changes from leg to leg: once the drive holds the rest of the block, a
 * leg writes from the position to the trigger (12 registers, not 16), and
 * a leg whose position is staged already (mb_next_leg) the trigger alone
 * (its lower register, FC 0x06: the upper one reads 0). The leg's clock
 * starts when the drive likely took the write (leg_started). */
static int mb_start_leg(void *priv, double from, double to, struct gonio_err *err)
{
    struct mb_axis *a = priv;
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
    a->leg_time = rig_axis_time(fabs(a->leg_target - from), speed / a->spd, accel / a->spd);
    if (a->block && a->block_faults != drv_modbus_faults(a->bus))
        a->block = 0; /* the drive may have restarted since: write it all */
    int rc, head = a->block ? R_POSITION - R_DIRECT : 0;
    long faults = drv_modbus_faults(a->bus);
    if (a->block && a->staged && a->staged_pos == pos)
        rc = drv_modbus_write(a->bus, a->slave, R_TRIGGER + 1, 1, r + 15, a->who, err);
    else
        rc = drv_modbus_write(a->bus, a->slave, R_DIRECT + head, 16 - head, r + head, a->who,
                              err);
    if (rc == 0 && a->block && drv_modbus_faults(a->bus) != faults)
        rc = rewrite_block(a, r, err);
    a->block = rc == 0;
    a->block_faults = drv_modbus_faults(a->bus);
    a->staged = a->next = 0;
    leg_started(a);
    return rc;
}

/* The leg after this one goes to `to`: stored on the drive while this one
 * runs (wait_status), its start then costs a trigger. */
static void mb_next_leg(void *priv, double to)
{
    struct mb_axis *a = priv;
    a->next = 1;
    a->next_pos = to_steps(to, a->spd);
}

/* Store the next leg's position while the drive has this one to run for
 * longer than the write takes twice over (the position registers are
 * data: the drive acts on them only with the trigger). Only where the line
 * charges the frames' time: elsewhere the full write costs no more. */
static int stage_next(struct mb_axis *a, double due, struct gonio_err *err)
{
    double line = drv_modbus_request_s(a->bus, 1, 2), left = due - gonio_monotonic_s();
    if (drv_modbus_simulated_clock(a->bus)) { /* the leg's time on the rig, whole */
        line = drv_modbus_request_rig_s(a->bus, 1, 2);
        left = a->leg_time;
    }
    if (!a->next || !a->block || !(line > 0) || left < 2 * (2 * line + 0.001))
        return 0;
    uint16_t r[2];
    drv_modbus_put32(r, (uint32_t)a->next_pos);
    int rc = drv_modbus_write(a->bus, a->slave, R_POSITION, 2, r, a->who, err);
    a->staged = rc == 0;
    a->staged_pos = a->next_pos;
    a->next = 0;
    return rc;
}

/* Poll the status until the drive rests (MOVE off) or is in alarm,
 * sending the first read so that it reaches the drive at the leg's
 * expected end on the bus's time scale, so a move normally costs one
 * status read. The read that sees the drive rest dates the rest (at the
 * latest when the drive took its registers: the settle counts from
 * there). A leg overdue by 0.25 s of rig time is watched for progress on
 * the encoder. On a simulated clock the first read goes at once: it finds
 * the move ended, the clock moved on to its end. */
static int wait_status(struct mb_axis *a, uint32_t *st, uint32_t *alarm, struct gonio_err *err)
{
    double scale = drv_modbus_time_scale(a->bus);
    /* On a simulated clock the leg takes no wall time: overdue at once. */
    double due = a->leg_start + (drv_modbus_simulated_clock(a->bus) ? 0 : a->leg_time / scale);
    double deadline = due + (0.25 * a->leg_time + 2.0) / scale + 0.5 +
                      4 * drv_modbus_timeout(a->bus);
    double poll = fmin(fmax(0.01 / scale, 0.0002), 0.01);
    double last_pos = NAN, last_change = gonio_monotonic_s();
    int rc = stage_next(a, due, err);
    if (rc < 0)
        return rc;
    if (!drv_modbus_simulated_clock(a->bus))
        rc = drv_modbus_sleep(a->bus, due - drv_modbus_request_s(a->bus, 0, 4) -
                                          drv_modbus_gap_s(a->bus) - gonio_monotonic_s(),
                              a->who, err);
    while (rc == 0) {
        if ((rc = read_status(a, st, alarm, err)) < 0)
            return rc;
        if (*st & ST_ALM_A)
            return 0;
        if (!(*st & ST_MOVE)) {
            double lo;
            drv_modbus_acted(a->bus, &lo, &a->rest_wall);
            drv_modbus_line_rig(a->bus, &a->rest_line, &lo);
            return 0;
        }
        double now = gonio_monotonic_s(), pos = NAN;
        if ((now - due) * scale > 0.25) {
            if ((rc = mb_feedback(a, &pos, err)) < 0)
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
        rc = drv_modbus_sleep(a->bus, poll, a->who, err);
    }
    return rc;
}

/* Rig seconds since the drive last said it rests (the generic layer asks
 * only while it does). On a simulated clock only the line's time has
 * passed on the rig since (the exchanges after the one that saw the rest;
 * at the configured rate, which charges no more than the simulator does). */
static double mb_rested(const void *priv)
{
    const struct mb_axis *a = priv;
    if (drv_modbus_simulated_clock(a->bus)) {
        double acted, total;
        drv_modbus_line_rig(a->bus, &acted, &total);
        return total - a->rest_line;
    }
    return (gonio_monotonic_s() - a->rest_wall) * drv_modbus_time_scale(a->bus);
}

static int mb_wait_rest(void *priv, int *in_pos, unsigned *alarm, struct gonio_err *err)
{
    uint32_t st = 0, code = 0;
    int rc = wait_status(priv, &st, &code, err);
    *in_pos = (st & ST_IN_POS) != 0;
    *alarm = (st & ST_ALM_A) ? code : 0;
    return rc;
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

/* ALM-RST, then read whether the alarm cleared. */
static int mb_reset_alarm(void *priv, unsigned *still, struct gonio_err *err)
{
    struct mb_axis *a = priv;
    uint32_t st = 0, code = 0;
    a->block = a->staged = 0; /* whatever the alarm did, the next leg writes it all */
    int rc = pulse_input(a, IN_ALM_RST, err);
    if (rc == 0)
        rc = read_status(a, &st, &code, err);
    *still = (st & ST_ALM_A) ? code : 0;
    return rc;
}

/* ZHOME from here, then wait for HOME-END. */
static int mb_home(void *priv, double here, unsigned *alarm, struct gonio_err *err)
{
    struct mb_axis *a = priv;
    a->leg_target = 0;
    a->leg_time = rig_axis_time(fabs(here), a->prof.speed, a->prof.accel);
    a->block = a->staged = 0;
    int rc = pulse_input(a, IN_ZHOME, err);
    leg_started(a);
    uint32_t st = 0, code = 0;
    if (rc == 0)
        rc = wait_status(a, &st, &code, err);
    *alarm = (st & ST_ALM_A) ? code : 0;
    if (rc == 0 && !*alarm && !(st & ST_HOME_END))
        rc = gonio_err_set(err, GONIO_EDEVICE, "%s (slave %d): homing ended without HOME-END "
                           "(status 0x%x)", a->who, a->slave, st);
    return rc;
}

static int mb_stop(void *priv, struct gonio_err *err)
{
    struct mb_axis *a = priv;
    a->block = a->staged = 0;
    return pulse_input(a, IN_STOP, err);
}

static int mb_status(void *priv, struct drv_axis_state *out, struct gonio_err *err)
{
    uint32_t st, alarm;
    int rc = read_status(priv, &st, &alarm, err);
    if (rc < 0)
        return rc;
    out->ready = !!(st & ST_READY);
    out->moving = !!(st & ST_MOVE);
    out->in_pos = !!(st & ST_IN_POS);
    out->home_end = !!(st & ST_HOME_END);
    out->alarm_active = !!(st & ST_ALM_A);
    out->alarm = alarm;
    return 0;
}

static const struct drv_axis_ops mb_axis_ops = {
    .name = "modbus",
    .start_leg = mb_start_leg,
    .next_leg = mb_next_leg,
    .wait_rest = mb_wait_rest,
    .rested = mb_rested,
    .feedback = mb_feedback,
    .reset_alarm = mb_reset_alarm,
    .home = mb_home,
    .stop = mb_stop,
    .resolve = mb_resolve,
    .status = mb_status,
    .free_priv = free,
};

drv_axis *drv_axis_new_modbus(drv_modbus_bus *bus, int slave, const struct rig_axis *profile,
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
    snprintf(a->who, sizeof a->who, "axis %s", name ? name : "?");
    char who[64];
    snprintf(who, sizeof who, "%s (slave %d)", a->who, slave);
    const struct drv_axis_mechanics mech = {
        .min_deg = profile->min, .max_deg = profile->max, .in_position_deg = band,
        .backlash_deg = opts->backlash_deg, .approach = opts->approach,
        .move_retries = opts->move_retries};
    drv_axis *ax = drv_axis_alloc(&mb_axis_ops, a, name ? name : "axis", who, &mech);
    if (!ax) /* drv_axis_alloc freed a */
        gonio_err_set(err, ENOMEM, "modbus axis: out of memory");
    return ax;
}
