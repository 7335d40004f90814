/* The generic axis: how a drive comes to rest (drivers.h, struct
 * drv_axis_mechanics), decided once for every backend, so the in-process
 * rig and a Modbus drive take the same legs, tries and recoveries and say
 * the same things. The backends provide the primitives (drivers_private.h). */
#include "drivers/drivers_private.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "modbus_map/modbus_map.h"

struct drv_axis {
    const struct drv_axis_ops *ops;
    void *priv;
    char name[32];
    char who[64]; /* "axis arm (slave 2)" */
    struct drv_axis_mechanics mech;
    /* The leg under way: where it started and its target (as the drive
     * resolves it). */
    double leg_from, leg_target;
    /* The move: its target; a final leg to it still to come (after a leg
     * to the reference side); what it has taken so far (tries beyond the
     * first: re-commands and alarm resets, re-homings, the last alarm). */
    double target;
    int moving, final_pending, stopped;
    int tries, recommands, resets, rehomes;
    unsigned last_alarm;
    /* The last move or homing ended with the axis at rest (at_rest), and
     * where, from the feedback (rest_known): nothing moves it meanwhile
     * (the drivers are the only master). A move the drive reported IN-POS
     * for is done without the feedback, which drv_axis_position reads
     * when asked: while the axes settle, not before the settle starts. */
    int at_rest, rest_known;
    double rest_deg;
    /* The move ended on the drive's IN-POS, its encoder not yet compared
     * with the target (drv_axis_position does). */
    int unverified;
    struct drv_axis_stats stats;
};

/* AZ alarm codes (modbus_map/modbus_map.h, docs/protocol-modbus.md); the
 * in-process rig raises the same. */
enum { ALM_DEVIATION = MB_ALARM_DEVIATION, ALM_SENSOR = MB_ALARM_SENSOR,
       ALM_OVERLOAD = MB_ALARM_OVERLOAD, ALM_OVERTRAVEL = MB_ALARM_OVERTRAVEL,
       ALM_DATA = MB_ALARM_DATA };

const char *drv_alarm_name(unsigned code)
{
    switch (code) {
    case 0: return "";
    case ALM_DEVIATION: return "excessive position deviation";
    case ALM_SENSOR: return "sensor error";
    case ALM_OVERLOAD: return "overload";
    case ALM_OVERTRAVEL: return "software overtravel";
    case ALM_DATA: return "abnormal operation data";
    default: return "unknown alarm";
    }
}

drv_axis *drv_axis_alloc(const struct drv_axis_ops *ops, void *priv, const char *name,
                         const char *who, const struct drv_axis_mechanics *mech)
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
    snprintf(ax->who, sizeof ax->who, "%s", who);
    ax->mech = *mech;
    ax->mech.approach = mech->approach < 0 ? -1 : 1;
    return ax;
}

const char *drv_axis_name(const drv_axis *ax)
{
    return ax->name;
}

void drv_axis_stats(const drv_axis *ax, struct drv_axis_stats *out)
{
    memset(out, 0, sizeof *out);
    if (ax)
        *out = ax->stats;
}

void drv_axis_free(drv_axis *ax)
{
    if (!ax)
        return;
    if (ax->ops->free_priv)
        ax->ops->free_priv(ax->priv);
    free(ax);
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
static void tried(const drv_axis *ax, char *out, size_t size)
{
    char t1[16], t2[16], t3[16];
    out[0] = '\0';
    if (ax->tries == 0)
        return;
    int n = snprintf(out, size, " after %d tries (", ax->tries + 1);
    if (ax->recommands)
        n += snprintf(out + n, size - (size_t)n, "re-commanded %s",
                      times(ax->recommands, t1, sizeof t1));
    if (ax->resets)
        n += snprintf(out + n, size - (size_t)n, "%salarm 0x%02x reset %s",
                      ax->recommands ? ", " : "", ax->last_alarm,
                      times(ax->resets, t2, sizeof t2));
    if (ax->rehomes)
        n += snprintf(out + n, size - (size_t)n, ", re-homed %s",
                      times(ax->rehomes, t3, sizeof t3));
    snprintf(out + n, size - (size_t)n, ")");
}

/* The drive is in alarm and stays so: name the code and what was tried. */
static int alarm_error(const drv_axis *ax, unsigned code, struct gonio_err *err)
{
    char t[128];
    tried(ax, t, sizeof t);
    return gonio_err_set(err, GONIO_EDEVICE, "%s: drive alarm 0x%02x (%s)%s", ax->who, code,
                         drv_alarm_name(code), t);
}

/* The drive rests at pos outside the band: overshoot or short (along the
 * last leg), by how much, and what was tried; in_pos: though it reported
 * IN-POS. */
static int miss_error(const drv_axis *ax, double pos, int in_pos, struct gonio_err *err)
{
    char t[128];
    tried(ax, t, sizeof t);
    double dir = ax->leg_target > ax->leg_from   ? 1.0
                 : ax->leg_target < ax->leg_from ? -1.0
                                                 : (double)ax->mech.approach;
    double over = (pos - ax->target) * dir;
    return gonio_err_set(err, GONIO_EDEVICE, "%s: %s at %g deg, %.3g deg %s %g deg%s", ax->who,
                         ax->stopped ? "stopped (STOP)" : in_pos ? "reported IN-POS" : "stopped", pos, fabs(over),
                         over > 0 ? "past (overshoot)" : "short of", ax->target, t);
}

/* Within the band of the target. Steps in degrees are not exact in
 * binary (12.35 - 12.30 > 0.05): a nanodegree of slack. */
static int in_band(const drv_axis *ax, double pos)
{
    return fabs(pos - ax->target) <= ax->mech.in_position_deg + 1e-9;
}

static double resolve(const drv_axis *ax, double deg)
{
    return ax->ops->resolve ? ax->ops->resolve(ax->priv, deg) : deg;
}

static int send_leg(drv_axis *ax, double from, double to, struct gonio_err *err)
{
    ax->at_rest = ax->rest_known = 0;
    ax->leg_from = from;
    ax->leg_target = resolve(ax, to);
    ax->stats.moves++;
    return ax->ops->start_leg(ax->priv, from, to, err);
}

/* Send the move's next leg from here: straight to the target, or first to
 * a point beyond it on the reference side, when the rig has backlash and
 * the axis would arrive from the other side, or when fresh asks for a new
 * approach (a re-command: a drive told its own target again has nothing
 * to do, so it backs off by the backlash, at least twice the band). */
static int send_approach(drv_axis *ax, double here, int fresh, struct gonio_err *err)
{
    const struct drv_axis_mechanics *m = &ax->mech;
    double back = fresh ? fmax(m->backlash_deg, 2 * m->in_position_deg) : m->backlash_deg;
    ax->final_pending = 0;
    if (back > 0 && (fresh || m->approach * (ax->target - here) < 0)) {
        double via = fmin(fmax(ax->target - m->approach * back, m->min_deg), m->max_deg);
        if (resolve(ax, via) != resolve(ax, ax->target)) {
            ax->final_pending = 1;
            int rc = send_leg(ax, here, via, err);
            if (rc == 0 && ax->ops->next_leg)
                ax->ops->next_leg(ax->priv, ax->target);
            return rc;
        }
    }
    return send_leg(ax, here, ax->target, err);
}

int drv_axis_start_move(drv_axis *ax, double target_deg, struct gonio_err *err)
{
    if (!isfinite(target_deg) || target_deg < ax->mech.min_deg || target_deg > ax->mech.max_deg)
        return gonio_err_set(err, GONIO_EUNREACHABLE,
                             "%s: target %g deg beyond its soft limits [%g, %g]", ax->who,
                             target_deg, ax->mech.min_deg, ax->mech.max_deg);
    ax->target = target_deg;
    ax->tries = ax->recommands = ax->resets = ax->rehomes = 0;
    ax->stopped = ax->final_pending = ax->moving = ax->unverified = 0;
    double here;
    int rc = drv_axis_position(ax, &here, err);
    if (rc < 0)
        return rc;
    /* Already resting there: nothing to send, nothing to wait for; but
     * the encoder is read again when the position is asked for (a drive
     * that restarted since the last move has lost it), and the move made
     * then if it is not there. */
    if (ax->at_rest && in_band(ax, here)) {
        ax->rest_known = 0;
        ax->unverified = 1;
        return 0;
    }
    ax->moving = 1;
    return send_approach(ax, here, 0, err);
}

/* ALM-RST, then check that the alarm cleared. */
static int reset_alarm(drv_axis *ax, struct gonio_err *err)
{
    unsigned still = 0;
    ax->at_rest = ax->rest_known = 0;
    int rc = ax->ops->reset_alarm(ax->priv, &still, err);
    return rc == 0 && still ? alarm_error(ax, still, err) : rc;
}

int drv_axis_alarm_reset(drv_axis *ax, struct gonio_err *err)
{
    return reset_alarm(ax, err);
}

/* Home from here to 0: where the axis then rests. */
static int home_from(drv_axis *ax, double here, struct gonio_err *err)
{
    unsigned alarm = 0;
    ax->final_pending = 0;
    ax->leg_from = here;
    ax->leg_target = 0;
    int rc = ax->ops->home(ax->priv, here, &alarm, err);
    if (rc == 0 && alarm)
        rc = alarm_error(ax, alarm, err);
    ax->at_rest = ax->rest_known = rc == 0;
    ax->rest_deg = 0;
    return rc;
}

/* The drive is in alarm during a move: recover where the code allows
 * (drivers.h) and tries are left, then try again from where the axis is,
 * through the reference side. */
static int recover_alarm(drv_axis *ax, unsigned code, struct gonio_err *err)
{
    int recoverable = code == ALM_DEVIATION || code == ALM_OVERLOAD || code == ALM_SENSOR;
    if (!recoverable || ax->tries >= ax->mech.move_retries) {
        ax->final_pending = 0;
        return alarm_error(ax, code, err);
    }
    ax->tries++;
    ax->resets++;
    ax->last_alarm = code;
    int rc = reset_alarm(ax, err);
    ax->stats.alarms_recovered += rc == 0;
    double here = 0;
    if (rc == 0)
        rc = ax->ops->feedback(ax->priv, &here, err);
    if (rc == 0 && code == ALM_SENSOR) {
        ax->rehomes++;
        ax->stats.rehomes++;
        rc = home_from(ax, here, err);
        here = 0;
    }
    return rc < 0 ? rc : send_approach(ax, here, 1, err);
}

/* The drive rests at pos outside the band: come again while tries are
 * left. */
static int recommand(drv_axis *ax, double pos, int in_pos, struct gonio_err *err)
{
    if (ax->stopped || ax->tries >= ax->mech.move_retries)
        return miss_error(ax, pos, in_pos, err);
    ax->tries++;
    ax->recommands++;
    ax->stats.recommands++;
    return send_approach(ax, pos, 1, err);
}

/* Until the move is done: the drive reports IN-POS (the feedback can
 * wait: drv_axis_position), or rests inside the band. A drive resting
 * outside is re-commanded, one in alarm recovered, while tries are left. */
static int come_to_rest(drv_axis *ax, struct gonio_err *err)
{
    for (;;) {
        int in_pos = 0;
        unsigned alarm = 0;
        double pos = NAN;
        int rc = ax->ops->wait_rest(ax->priv, &in_pos, &alarm, err);
        if (rc < 0)
            return rc;
        if (alarm && ax->stopped)
            return alarm_error(ax, alarm, err);
        if (alarm) {
            if ((rc = recover_alarm(ax, alarm, err)) < 0)
                return rc;
            continue;
        }
        if (ax->final_pending && !ax->stopped) {
            ax->final_pending = 0;
            if ((rc = send_leg(ax, ax->leg_target, ax->target, err)) < 0)
                return rc;
            continue;
        }
        if (in_pos) {
            ax->at_rest = ax->unverified = 1;
            return 0;
        }
        if ((rc = ax->ops->feedback(ax->priv, &pos, err)) < 0)
            return rc;
        if (in_band(ax, pos)) {
            ax->at_rest = ax->rest_known = 1;
            ax->rest_deg = pos;
            return 0;
        }
        if ((rc = recommand(ax, pos, 0, err)) < 0)
            return rc;
    }
}

double drv_axis_leg_deg(const drv_axis *ax)
{
    return ax->moving ? fabs(ax->leg_target - ax->leg_from) : 0;
}

/* An axis that had no move to make: its encoder, read while the others
 * still move (the caller waits for their legs after its, drivers.h). */
static int verify_resting(drv_axis *ax, struct gonio_err *err)
{
    double deg;
    return !ax->moving && ax->unverified ? drv_axis_position(ax, &deg, err) : 0;
}

int drv_axis_wait_leg(drv_axis *ax, struct gonio_err *err)
{
    if (!ax->moving)
        return verify_resting(ax, err);
    if (!ax->final_pending)
        return 0;
    int in_pos = 0;
    unsigned alarm = 0;
    int rc = ax->ops->wait_rest(ax->priv, &in_pos, &alarm, err);
    if (rc < 0) {
        ax->moving = 0;
        return rc;
    }
    if (alarm || ax->stopped)
        return 0;
    ax->final_pending = 0;
    return send_leg(ax, ax->leg_target, ax->target, err);
}

int drv_axis_wait(drv_axis *ax, struct gonio_err *err)
{
    if (!ax->moving)
        return verify_resting(ax, err);
    int rc = come_to_rest(ax, err);
    ax->moving = 0;
    return rc;
}

/* The encoder of a move that ended on IN-POS is outside the band (a
 * drive that restarted reports IN-POS for its own target, not ours):
 * re-command, wait, and read the encoder again, while tries are left. */
static int verify(drv_axis *ax, double *deg, struct gonio_err *err)
{
    int rc = 0;
    while (rc == 0 && ax->at_rest && !in_band(ax, *deg)) {
        if ((rc = recommand(ax, *deg, 1, err)) < 0 || (rc = come_to_rest(ax, err)) < 0)
            break;
        ax->unverified = 0;
        if (!ax->rest_known && (rc = ax->ops->feedback(ax->priv, deg, err)) == 0) {
            ax->rest_known = 1;
            ax->rest_deg = *deg;
        }
        *deg = ax->rest_deg;
    }
    return rc;
}

int drv_axis_position(drv_axis *ax, double *deg, struct gonio_err *err)
{
    if (ax->rest_known) {
        *deg = ax->rest_deg;
        return 0;
    }
    int rc = ax->ops->feedback(ax->priv, deg, err);
    if (rc == 0 && ax->at_rest) {
        ax->rest_known = 1;
        ax->rest_deg = *deg;
    }
    if (rc == 0 && ax->unverified) {
        ax->unverified = 0;
        if ((rc = verify(ax, deg, err)) < 0)
            ax->at_rest = ax->rest_known = 0;
    }
    return rc;
}

double drv_axis_rested(const drv_axis *ax)
{
    return ax->at_rest ? ax->ops->rested(ax->priv) : 0;
}

int drv_axis_home(drv_axis *ax, struct gonio_err *err)
{
    double here = 0;
    ax->moving = 0;
    ax->tries = ax->recommands = ax->resets = ax->rehomes = 0;
    int rc = ax->ops->feedback(ax->priv, &here, err);
    return rc < 0 ? rc : home_from(ax, here, err);
}

int drv_axis_stop(drv_axis *ax, struct gonio_err *err)
{
    ax->final_pending = 0;
    ax->at_rest = ax->rest_known = 0;
    ax->stopped = 1;
    return ax->ops->stop(ax->priv, err);
}

int drv_axis_state(drv_axis *ax, struct drv_axis_state *out, struct gonio_err *err)
{
    *out = (struct drv_axis_state){.ready = -1, .moving = -1, .in_pos = -1, .home_end = -1,
                                   .alarm_active = -1};
    int rc = ax->ops->status ? ax->ops->status(ax->priv, out, err) : 0;
    return rc < 0 ? rc : ax->ops->feedback(ax->priv, &out->position_deg, err);
}
