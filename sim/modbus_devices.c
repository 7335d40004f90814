/* gonio-sim's devices: the drives' and the detector's state machines
 * behind their register banks (docs/protocol-modbus.md), the faults that
 * can be injected into them, and what they saw (msim_write_stats). */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "common/clock.h"
#include "sim/effects_detector.h"
#include "sim/effects_faults.h"
#include "sim/modbus_server_private.h"
#include "sim/scene.h"
#include "sim/sim.h"

/* ---- The devices' state machines ---------------------------------------- */

void msim_sync_clock(msim *m)
{
    if (m->cfg.simulated_clock)
        return; /* host time is never rig time */
    double target = (gonio_monotonic_s() - m->wall0) * m->cfg.time_scale;
    sim_rig_advance(m->rig, target - sim_rig_now(m->rig));
}

/* Sleep for wall seconds, whatever signal arrives meanwhile. */
static void wait_wall(double s)
{
    if (!(s > 0))
        return;
    struct timespec ts = {.tv_sec = (time_t)s, .tv_nsec = (long)((s - (double)(time_t)s) * 1e9)};
    while (nanosleep(&ts, &ts) < 0 && errno == EINTR)
        ;
}

void msim_bus_time(msim *m, double seconds)
{
    if (!(seconds > 0))
        return;
    if (m->cfg.simulated_clock)
        sim_rig_advance(m->rig, seconds);
    else
        wait_wall(seconds / m->cfg.time_scale);
}

void msim_wait_late(msim *m, double seconds)
{
    if (!(seconds > 0))
        return;
    wait_wall(seconds);
    if (m->cfg.simulated_clock)
        sim_rig_advance(m->rig, seconds);
}

static int axis_moving(const msim *m, const struct msim_axis *ax)
{
    return sim_rig_move_end(m->rig, ax->id) > sim_rig_now(m->rig);
}

static int covers(int addr, int n, int reg)
{
    return addr <= reg + 1 && reg < addr + n;
}

/* What the master waits for has happened by the time it looks: the clock
 * passes to the end of the move (the halt at a jam, which a stalled drive
 * then sits at, MOVE on, without the clock running on) or of the
 * integration. The other axes move on meanwhile, as they would. */
void msim_poll_jump(msim *m, struct msim_axis *ax, int addr, int n)
{
    if (!m->cfg.simulated_clock)
        return;
    double now = sim_rig_now(m->rig), end = now;
    if (ax && covers(addr, n, AX_STATUS) && axis_moving(m, ax))
        end = sim_rig_move_end(m->rig, ax->id);
    else if (!ax && covers(addr, n, DET_STATUS) && m->det.busy)
        end = m->det.busy_until;
    if (end > now)
        sim_rig_advance(m->rig, end - now);
}

void msim_det_wait(msim *m)
{
    uint16_t *r = m->det.map->tab_registers;
    sim_rig_advance(m->rig, get32(r, DET_WAIT) * 1e-6);
    put32(r, DET_WAIT, 0);
}

/* Refresh the read-only registers from the simulation. */
void msim_axis_refresh(msim *m, struct msim_axis *ax)
{
    uint16_t *r = ax->map->tab_registers;
    double pos = sim_rig_position(m->rig, ax->id);
    int moving = axis_moving(m, ax);
    /* A scene's move effects (stall) raise the core's alarm; the drive
     * shows it once the move has come to its end. */
    if (!moving && !ax->alarm && sim_rig_alarm(m->rig, ax->id)) {
        ax->alarm = sim_rig_alarm(m->rig, ax->id);
        ax->alarms++;
    }
    if (ax->jammed && !moving) {
        if (ax->jam == MSIM_JAM_OVERLOAD) { /* the drive gives up at once */
            ax->jammed = 0;
            ax->homing = 0;
            ax->alarm = MSIM_ALARM_OVERLOAD;
            ax->alarms++;
        } else { /* stuck, still commanded to move, no alarm */
            moving = 1;
        }
    }
    if (ax->homing && !moving) {
        ax->homing = 0;
        ax->home_end = pos == 0.0;
    }
    uint32_t st = 0;
    if (ax->home_end)
        st |= ST_HOME_END;
    if (!moving && !ax->alarm)
        st |= ST_READY;
    if (ax->alarm)
        st |= ST_ALM_A;
    if (moving)
        st |= ST_MOVE;
    /* IN-POS: the operation has ended and the encoder rests within the
     * positioning completion band of the target, both in the drive's steps
     * (a half-step band at least: the drive cannot do better than its
     * step). Not in alarm. */
    double spd = m->cfg.steps_per_deg;
    long steps = lround(pos * spd);
    double band = fmax(m->cfg.in_pos_deg, 0.5 / spd);
    if (!moving && !ax->alarm && fabs((double)steps - ax->target_deg * spd) <= band * spd + 1e-6)
        st |= ST_IN_POS;
    put32(r, AX_STATUS, st);
    put32(r, AX_ALARM, (uint32_t)ax->alarm);
    put32(r, AX_FEEDBACK, (uint32_t)(int32_t)steps);
}

static void note_range(double v, double *lo, double *hi)
{
    if (!(v >= *lo))
        *lo = v;
    if (!(v <= *hi))
        *hi = v;
}

static void axis_start(msim *m, struct msim_axis *ax, double target_deg, double speed_deg,
                       double accel_deg)
{
    double here = sim_rig_position(m->rig, ax->id), goal = target_deg;
    note_range(target_deg, &ax->cmd_min, &ax->cmd_max);
    note_range(here, &ax->pos_min, &ax->pos_max);
    int jams = ax->jam != MSIM_JAM_NONE && target_deg >= ax->prof->min &&
               target_deg <= ax->prof->max && ax->jam_deg != here &&
               (ax->jam_deg - here) * (target_deg - ax->jam_deg) >= 0;
    if (jams) /* the move ends at the obstacle (decelerating into it) */
        goal = ax->jam_deg;
    if (sim_rig_start_move_at(m->rig, ax->id, goal, speed_deg, accel_deg, NULL) < 0) {
        /* Beyond the soft limits: alarm, and the axis does not move. */
        ax->alarm = target_deg < ax->prof->min || target_deg > ax->prof->max || !isfinite(target_deg)
                        ? MSIM_ALARM_OVERTRAVEL
                        : MSIM_ALARM_DATA;
        ax->refused++;
        ax->alarms++;
        return;
    }
    ax->moves++;
    note_range(goal, &ax->pos_min, &ax->pos_max);
    ax->target_deg = target_deg;
    ax->home_end = 0;
    ax->jammed = jams;
}

void msim_axis_trigger(msim *m, struct msim_axis *ax)
{
    const uint16_t *r = ax->map->tab_registers;
    if (ax->alarm)
        return; /* ignored until ALM-RST */
    uint32_t type = get32(r, AX_OP_TYPE);
    int32_t pos = (int32_t)get32(r, AX_POSITION);
    double spd = m->cfg.steps_per_deg;
    double speed = (double)(int32_t)get32(r, AX_SPEED) / spd;
    double accel = (double)(int32_t)get32(r, AX_ACCEL) / spd;
    double target;
    if (type == 1)
        target = pos / spd;
    else if (type == 2)
        target = sim_rig_position(m->rig, ax->id) + pos / spd;
    else
        target = NAN;
    if (!isfinite(target) || !(speed > 0) || !(accel > 0)) {
        ax->alarm = MSIM_ALARM_DATA;
        ax->alarms++;
        return;
    }
    ax->homing = 0;
    axis_start(m, ax, target, speed, accel);
}

void msim_axis_input(msim *m, struct msim_axis *ax)
{
    uint32_t now = get32(ax->map->tab_registers, AX_INPUT);
    uint32_t rise = now & ~ax->input_prev;
    ax->input_prev = now;
    if (rise & IN_ALM_RST) {
        ax->alarm = 0;
        sim_rig_reset_alarm(m->rig, ax->id);
    }
    if (rise & IN_STOP) {
        sim_rig_stop(m->rig, ax->id);
        ax->homing = 0;
        ax->jammed = 0;
    }
    if ((rise & IN_ZHOME) && !ax->alarm && !(rise & IN_STOP)) {
        axis_start(m, ax, 0.0, ax->prof->speed, ax->prof->accel);
        ax->homing = !ax->alarm;
    }
}

/* A count as a uint32 register: the ADC's counts are whole and within 32
 * bits (sim/effects.c, fx_adc); the clamp only guards the cast. */
static uint32_t count32(double v)
{
    return (uint32_t)fmin(fmax(nearbyint(v), 0), 4294967294.0);
}

/* A raw reading's channels as uint32 counts and its raw block. */
static void publish_raw(struct msim_detector *d, uint16_t *r)
{
    for (int k = 0; k < DET_NCHANNELS; k++)
        put32(r, DET_CHANNELS + 2 * k, count32(d->pending[k]));
    put32(r, DET_RAW_SEQUENCE, d->sequence);
    put32(r, DET_GAIN_STATE, 0);
    put32(r, DET_FULL_SCALE, count32(d->pending_full_scale));
    mb_put_float(r + DET_NONLINEARITY, (float)d->pending_nonlinearity);
    put32(r, DET_MONITOR,
          isnan(d->pending_monitor) ? MB_DET_MONITOR_NONE : count32(d->pending_monitor));
    put32(r, MB_DET_BAND_SEQUENCE, d->sequence);
    for (int k = 0; k < d->n_bands; k++)
        put32(r, MB_DET_BAND_COUNTS + 2 * k, count32(d->pending_bands[k]));
}

/* Completing an integration publishes its data and bumps the sequence. */
void msim_det_refresh(msim *m)
{
    struct msim_detector *d = &m->det;
    uint16_t *r = d->map->tab_registers;
    if (d->busy && sim_rig_now(m->rig) >= d->busy_until) {
        d->busy = 0;
        d->ready = 1;
        d->sequence++;
        d->raw = d->pending_raw;
        if (d->raw)
            publish_raw(d, r);
        else
            for (int k = 0; k < DET_NCHANNELS; k++)
                mb_put_float(r + DET_CHANNELS + 2 * k, (float)d->pending[k]);
        /* The integration register reads back what was actually used
         * (auto-exposure may have chosen another). */
        put32(r, DET_INTEGRATION, d->pending_us);
        d->flags = d->pending_flags;
    }
    put32(r, DET_STATUS, (d->busy ? DST_BUSY : 0u) | (d->ready ? DST_READY : 0u) |
                             (d->ready && (d->flags & SIM_SIGNAL_SATURATED) ? DST_SATURATED : 0u) |
                             (sim_rig_counts(m->rig) ? DST_RAW : 0u) |
                             (d->n_bands ? DST_BANDS : 0u) |
                             (m->cfg.simulated_clock ? DST_CLOCK_SIMULATED : 0u) |
                             (m->cfg.simulated_clock && m->cfg.baud > 0 ? DST_LINE_TIMED : 0u));
    put32(r, DET_SEQUENCE, d->sequence);
    put32(r, DET_CLOCK, (uint32_t)llround(sim_rig_now(m->rig) * 1000.0));
}

void msim_det_trigger(msim *m)
{
    struct msim_detector *d = &m->det;
    uint32_t us = get32(d->map->tab_registers, DET_INTEGRATION);
    /* The detector sees the material where the axes are as it starts,
     * through the scene's effects. */
    struct sim_reading rd;
    double used = us * 1e-6;
    d->pending_flags = 0;
    d->pending_raw = 0;
    if (us > 0 && sim_rig_read(m->rig, used, &rd, NULL) == 0) {
        memcpy(d->pending, rd.rgb, sizeof d->pending);
        used = rd.integration_s;
        d->pending_flags = rd.flags;
        d->pending_raw = rd.counts;
        d->pending_full_scale = rd.full_scale;
        d->pending_nonlinearity = rd.nonlinearity;
        d->pending_monitor = rd.monitor;
        for (int k = 0; k < d->n_bands; k++) /* the spectrum's counts, as the channels' */
            d->pending_bands[k] = rd.counts && rd.n_bands == d->n_bands ? rd.spectrum[k] : 0;
    } else {
        sim_rig_sample(m->rig, d->pending);
    }
    d->pending_us = (uint32_t)fmin(nearbyint(used * 1e6), 4294967295.0);
    d->busy = 1;
    d->ready = 0;
    d->busy_until = sim_rig_now(m->rig) + used;
    msim_det_refresh(m);
}

void msim_det_shutter(msim *m)
{
    uint16_t *r = m->det.map->tab_registers;
    int closed = get32(r, DET_SHUTTER) != 0;
    put32(r, DET_SHUTTER, (uint32_t)closed);
    sim_rig_shutter(m->rig, closed);
}

/* Each axis's slave id, in enum sim_axis_id's order. */
static const int axis_slave[SIM_N_AXES] = {MB_SLAVE_SAMPLE, MB_SLAVE_ARM, MB_SLAVE_AZIMUTH,
                                           MB_SLAVE_ROTATION};

struct msim_axis *msim_axis_of(msim *m, int slave)
{
    for (int i = 0; i < SIM_N_AXES; i++)
        if (m->served[i] && axis_slave[i] == slave)
            return &m->axis[i];
    return NULL;
}

int msim_jam(msim *m, int slave, enum msim_jam_kind kind, double deg, struct gonio_err *err)
{
    struct msim_axis *ax = msim_axis_of(m, slave);
    if (!ax || !isfinite(deg) || deg < ax->prof->min || deg > ax->prof->max)
        return gonio_err_set(err, GONIO_EUSAGE, "jam: no axis at slave %d, or %g deg outside "
                             "its limits", slave, deg);
    ax->jam = kind;
    ax->jam_deg = deg;
    return 0;
}

int msim_delay(msim *m, int slave, double ms, struct gonio_err *err)
{
    if (slave < 1 || slave > 247 || !(ms >= 0) || ms > 10000)
        return gonio_err_set(err, GONIO_EUSAGE, "delay: slave %d, %g ms (0 to 10000)", slave, ms);
    m->delay_ms[slave] = ms;
    return 0;
}

void msim_write_stats(const msim *m, FILE *out)
{
    long c[4] = {0};
    sim_faults *f = sim_rig_faults(m->rig);
    if (f)
        sim_faults_counts(f, c);
    fprintf(out, "{\"exchanges\": %ld, \"faults\": {\"dropped\": %ld, \"corrupted\": %ld, "
            "\"late\": %ld},\n \"detector\": {\"exchanges\": %ld},\n \"axes\": {",
            m->exchanges, c[SIM_FAULT_DROP], c[SIM_FAULT_CORRUPT], c[SIM_FAULT_LATE],
            m->slave_exchanges[MB_SLAVE_DETECTOR]);
    static const char *names[SIM_N_AXES] = {"sample", "arm", "azimuth", "rotation"};
    for (int i = 0, first = 1; i < SIM_N_AXES; i++) {
        if (!m->served[i])
            continue;
        const struct msim_axis *ax = &m->axis[i];
        /* JSON has no infinity: an axis never commanded reports nulls. */
        char cmd[64] = "null, null", pos[64] = "null, null";
        if (ax->moves + ax->refused > 0)
            snprintf(cmd, sizeof cmd, "%.17g, %.17g", ax->cmd_min, ax->cmd_max);
        if (ax->moves > 0)
            snprintf(pos, sizeof pos, "%.17g, %.17g", ax->pos_min, ax->pos_max);
        fprintf(out, "%s\n  \"%s\": {\"exchanges\": %ld, \"moves\": %ld, \"refused\": %ld, "
                "\"limits\": [%.17g, %.17g], \"commanded\": [%s], \"positions\": [%s], "
                "\"alarms\": %ld}", first ? "" : ",", names[i], m->slave_exchanges[axis_slave[i]],
                ax->moves, ax->refused, ax->prof->min, ax->prof->max, cmd, pos, ax->alarms);
        first = 0;
    }
    fprintf(out, "}");
    if (m->changer.map)
        fprintf(out, ",\n \"sample_changer\": {\"exchanges\": %ld, \"to_sample\": %ld, "
                "\"to_standard\": %ld, \"to_trap\": %ld}", m->slave_exchanges[MB_SLAVE_CHANGER],
                m->changer.moves[MB_CH_SLOT_SAMPLE], m->changer.moves[MB_CH_SLOT_STANDARD],
                m->changer.moves[MB_CH_SLOT_TRAP]);
    fprintf(out, "}\n");
}
