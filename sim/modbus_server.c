#define _DEFAULT_SOURCE /* cfmakeraw */
#define _XOPEN_SOURCE 700 /* posix_openpt, grantpt, ptsname */
#include "sim/modbus_server.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "common/clock.h"
#include "modbus_map/modbus_map.h"
#include "sim/effects_detector.h"
#include "sim/effects_faults.h"
#include "sim/scene.h"
#include "sim/sim.h"

/* The register map (modbus_map/modbus_map.h) under this file's short
 * names; the simulated detector has three channels. */
enum {
    AX_DATA_NO = MB_AX_DATA_NO, AX_OP_TYPE = MB_AX_OP_TYPE, AX_POSITION = MB_AX_POSITION,
    AX_SPEED = MB_AX_SPEED, AX_ACCEL = MB_AX_ACCEL, AX_TRIGGER = MB_AX_TRIGGER,
    AX_INPUT = MB_AX_INPUT, AX_STATUS = MB_AX_STATUS, AX_ALARM = MB_AX_ALARM,
    AX_FEEDBACK = MB_AX_FEEDBACK, AX_NREGS = MB_AX_NREGS,
    DET_INTEGRATION = MB_DET_INTEGRATION, DET_TRIGGER = MB_DET_TRIGGER,
    DET_STATUS = MB_DET_STATUS, DET_COUNT = MB_DET_COUNT, DET_SEQUENCE = MB_DET_SEQUENCE,
    DET_CLOCK = MB_DET_CLOCK, DET_CHANNELS = MB_DET_CHANNELS, DET_NCHANNELS = 3,
    DET_NREGS = DET_CHANNELS + 2 * DET_NCHANNELS,
};
enum { IN_ZHOME = MB_IN_ZHOME, IN_STOP = MB_IN_STOP, IN_ALM_RST = MB_IN_ALM_RST };
enum { ST_HOME_END = MB_ST_HOME_END, ST_READY = MB_ST_READY, ST_ALM_A = MB_ST_ALM_A,
       ST_MOVE = MB_ST_MOVE, ST_IN_POS = MB_ST_IN_POS };
enum { DST_BUSY = MB_DET_BUSY, DST_READY = MB_DET_READY, DST_SATURATED = MB_DET_SATURATED };
enum { MSIM_ALARM_OVERLOAD = MB_ALARM_OVERLOAD, MSIM_ALARM_DEVIATION = MB_ALARM_DEVIATION,
       MSIM_ALARM_OVERTRAVEL = MB_ALARM_OVERTRAVEL, MSIM_ALARM_DATA = MB_ALARM_DATA };

#define MAX_CLIENTS 8
#define RTU_GAP_MS 10 /* silence that ends a frame of unknown length */
/* The longest request a function's own length fields can describe: FC
 * 0x10 with a byte count of 255 (header, address, quantity, count, data).
 * Longer than the protocol's ADU limits, so that a write of too many
 * registers still arrives whole and gets its exception 03. */
#define RTU_MAX_FRAME (1 + 6 + 255 + 2)
#define TCP_MAX_ADU (7 + 6 + 255)

struct msim_axis {
    modbus_mapping_t *map;
    enum sim_axis_id id;
    const struct plan_axis *prof;
    uint32_t input_prev; /* input command as last written: commands act on edges */
    double target_deg;
    int alarm, homing, home_end;
    /* An injected jam (msim_jam): moves across jam_deg halt there; jammed
     * while the axis sits at the jam pretending to move. */
    enum msim_jam_kind jam;
    double jam_deg;
    int jammed;
    /* What was asked of the drive and where it went (msim_write_stats):
     * a trapezoidal move stays between its ends, so the ends bound every
     * position the axis took. */
    long moves, refused, alarms;
    double cmd_min, cmd_max, pos_min, pos_max;
};

struct msim_detector {
    modbus_mapping_t *map;
    double busy_until; /* simulated time the running integration ends */
    int busy, ready;
    uint32_t sequence;
    double pending[DET_NCHANNELS];
    uint32_t pending_us; /* the integration the detector chose */
    unsigned pending_flags, flags;
};

struct msim {
    struct msim_cfg cfg;
    const struct plan_rig *profile;
    sim_rig *rig;
    double wall0;
    struct msim_axis axis[SIM_N_AXES];
    int n_axes;
    struct msim_detector det;
    double delay_ms[256]; /* per slave id: answers this late (msim_delay) */
    /* RTU: the pty master, a held-open slave (so the master never sees a
     * hang-up between clients) and a libmodbus context that writes replies. */
    int pty_master, pty_slave;
    /* Requests to a present slave, faulty or not: all, and per slave id. */
    long exchanges, slave_exchanges[256];
    modbus_t *rtu;
    uint8_t rtu_buf[RTU_MAX_FRAME];
    int rtu_len;
    /* TCP: listening socket and clients, each with the part of a frame
     * received so far (frames are cut by the MBAP header's length). */
    modbus_t *tcp;
    int listen_fd;
    struct tcp_client {
        int fd, len;
        uint8_t buf[TCP_MAX_ADU];
    } clients[MAX_CLIENTS];
};

/* The map's codec at a register address of a device's table. */
static uint32_t get32(const uint16_t *r, int addr)
{
    return mb_get32(r + addr);
}

static void put32(uint16_t *r, int addr, uint32_t v)
{
    mb_put32(r + addr, v);
}

msim *msim_new(const struct plan_rig *profile, const brdf_material *material,
               const struct sim_scene *scene, const struct msim_cfg *cfg,
               struct gonio_err *err)
{
    if (!(cfg->time_scale > 0) || !(cfg->steps_per_deg > 0)) {
        gonio_err_set(err, GONIO_EUSAGE, "gonio-sim: time scale %g and steps per degree %g must "
                      "be positive", cfg->time_scale, cfg->steps_per_deg);
        return NULL;
    }
    msim *m = calloc(1, sizeof *m);
    if (!m) {
        gonio_err_set(err, ENOMEM, "gonio-sim: out of memory");
        return NULL;
    }
    m->cfg = *cfg;
    m->profile = profile;
    m->pty_master = m->pty_slave = m->listen_fd = -1;
    for (int i = 0; i < MAX_CLIENTS; i++)
        m->clients[i].fd = -1;
    m->rig = sim_rig_new_scene(profile, material, scene, NULL, err);
    if (!m->rig) {
        free(m);
        return NULL;
    }
    const struct plan_axis *profs[SIM_N_AXES] = {&profile->sample, &profile->arm,
                                                 &profile->azimuth};
    m->n_axes = profile->out_of_plane ? 3 : 2;
    for (int i = 0; i < SIM_N_AXES; i++) {
        m->axis[i].id = (enum sim_axis_id)i;
        m->axis[i].cmd_min = m->axis[i].pos_min = INFINITY;
        m->axis[i].cmd_max = m->axis[i].pos_max = -INFINITY;
        m->axis[i].prof = profs[i];
        m->axis[i].map = modbus_mapping_new_start_address(0, 0, 0, 0, 0, AX_NREGS, 0, 0);
        if (!m->axis[i].map)
            break;
    }
    m->det.map = modbus_mapping_new_start_address(0, 0, 0, 0, 0, DET_NREGS, 0, 0);
    if (!m->det.map || !m->axis[SIM_N_AXES - 1].map) {
        msim_free(m);
        gonio_err_set(err, ENOMEM, "gonio-sim: out of memory");
        return NULL;
    }
    put32(m->det.map->tab_registers, DET_COUNT, DET_NCHANNELS);
    m->wall0 = gonio_monotonic_s();
    return m;
}

void msim_free(msim *m)
{
    if (!m)
        return;
    for (int i = 0; i < SIM_N_AXES; i++)
        modbus_mapping_free(m->axis[i].map);
    modbus_mapping_free(m->det.map);
    if (m->rtu)
        modbus_free(m->rtu);
    if (m->tcp)
        modbus_free(m->tcp);
    for (int i = 0; i < MAX_CLIENTS; i++)
        if (m->clients[i].fd >= 0)
            close(m->clients[i].fd);
    if (m->listen_fd >= 0)
        close(m->listen_fd);
    if (m->pty_slave >= 0)
        close(m->pty_slave);
    if (m->pty_master >= 0)
        close(m->pty_master);
    sim_rig_free(m->rig);
    free(m);
}

/* ---- The devices' state machines ---------------------------------------- */

/* Bring the simulated clock to the wall clock's scaled time. */
static void sync_clock(msim *m)
{
    double target = (gonio_monotonic_s() - m->wall0) * m->cfg.time_scale;
    sim_rig_advance(m->rig, target - sim_rig_now(m->rig));
}

static int axis_moving(const msim *m, const struct msim_axis *ax)
{
    return sim_rig_move_end(m->rig, ax->id) > sim_rig_now(m->rig);
}

/* Refresh the read-only registers from the simulation. */
static void axis_refresh(msim *m, struct msim_axis *ax)
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

static void axis_trigger(msim *m, struct msim_axis *ax)
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

static void axis_input(msim *m, struct msim_axis *ax)
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

/* Completing an integration publishes its data and bumps the sequence. */
static void det_refresh(msim *m)
{
    struct msim_detector *d = &m->det;
    uint16_t *r = d->map->tab_registers;
    if (d->busy && sim_rig_now(m->rig) >= d->busy_until) {
        d->busy = 0;
        d->ready = 1;
        d->sequence++;
        for (int k = 0; k < DET_NCHANNELS; k++)
            mb_put_float(r + DET_CHANNELS + 2 * k, (float)d->pending[k]);
        /* The integration register reads back what was actually used
         * (auto-exposure may have chosen another). */
        put32(r, DET_INTEGRATION, d->pending_us);
        d->flags = d->pending_flags;
    }
    put32(r, DET_STATUS, (d->busy ? DST_BUSY : 0u) | (d->ready ? DST_READY : 0u) |
                             (d->ready && (d->flags & SIM_SIGNAL_SATURATED) ? DST_SATURATED : 0u));
    put32(r, DET_SEQUENCE, d->sequence);
    put32(r, DET_CLOCK, (uint32_t)llround(sim_rig_now(m->rig) * 1000.0));
}

static void det_trigger(msim *m)
{
    struct msim_detector *d = &m->det;
    uint32_t us = get32(d->map->tab_registers, DET_INTEGRATION);
    /* The detector sees the material where the axes are as it starts,
     * through the scene's effects. */
    struct sim_reading rd;
    double used = us * 1e-6;
    d->pending_flags = 0;
    if (us > 0 && sim_rig_read(m->rig, used, &rd, NULL) == 0) {
        memcpy(d->pending, rd.rgb, sizeof d->pending);
        used = rd.integration_s;
        d->pending_flags = rd.flags;
    } else {
        sim_rig_sample(m->rig, d->pending);
    }
    d->pending_us = (uint32_t)fmin(nearbyint(used * 1e6), 4294967295.0);
    d->busy = 1;
    d->ready = 0;
    d->busy_until = sim_rig_now(m->rig) + used;
    det_refresh(m);
}

int msim_jam(msim *m, int slave, enum msim_jam_kind kind, double deg, struct gonio_err *err)
{
    struct msim_axis *ax = NULL;
    if (slave == MB_SLAVE_SAMPLE || slave == MB_SLAVE_ARM ||
        (slave == MB_SLAVE_AZIMUTH && m->n_axes > 2))
        ax = &m->axis[slave == MB_SLAVE_SAMPLE ? SIM_AXIS_SAMPLE
                      : slave == MB_SLAVE_ARM  ? SIM_AXIS_ARM
                                                 : SIM_AXIS_AZIMUTH];
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

static uint16_t crc16(const uint8_t *p, int n)
{
    uint16_t crc = 0xFFFF;
    for (int i = 0; i < n; i++) {
        crc ^= p[i];
        for (int b = 0; b < 8; b++)
            crc = (crc & 1) ? (uint16_t)((crc >> 1) ^ 0xA001) : (uint16_t)(crc >> 1);
    }
    return crc;
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
    static const char *names[SIM_N_AXES] = {"sample", "arm", "azimuth"};
    static const int slaves[SIM_N_AXES] = {MB_SLAVE_SAMPLE, MB_SLAVE_ARM, MB_SLAVE_AZIMUTH};
    for (int i = 0; i < m->n_axes; i++) {
        const struct msim_axis *ax = &m->axis[i];
        /* JSON has no infinity: an axis never commanded reports nulls. */
        char cmd[64] = "null, null", pos[64] = "null, null";
        if (ax->moves + ax->refused > 0)
            snprintf(cmd, sizeof cmd, "%.17g, %.17g", ax->cmd_min, ax->cmd_max);
        if (ax->moves > 0)
            snprintf(pos, sizeof pos, "%.17g, %.17g", ax->pos_min, ax->pos_max);
        fprintf(out, "%s\n  \"%s\": {\"exchanges\": %ld, \"moves\": %ld, \"refused\": %ld, "
                "\"limits\": [%.17g, %.17g], \"commanded\": [%s], \"positions\": [%s], "
                "\"alarms\": %ld}", i ? "," : "", names[i], m->slave_exchanges[slaves[i]], ax->moves,
                ax->refused, ax->prof->min, ax->prof->max, cmd, pos, ax->alarms);
    }
    fprintf(out, "}}\n");
}

/* ---- Requests ------------------------------------------------------------ */

/* The register ranges of each device: what may be read, what written. */
struct reg_range {
    int lo, hi; /* inclusive */
    int writable;
};
static const struct reg_range axis_ranges[] = {
    {AX_DATA_NO, AX_TRIGGER + 1, 1}, {AX_INPUT, AX_INPUT + 1, 1},
    {AX_STATUS, AX_ALARM + 1, 0},     {AX_FEEDBACK, AX_FEEDBACK + 1, 0}, {-1, -1, 0}};
static const struct reg_range det_ranges[] = {
    {DET_INTEGRATION, DET_TRIGGER + 1, 1}, {DET_STATUS, DET_NREGS - 1, 0}, {-1, -1, 0}};

/* 0 when every register of [addr, addr + n) is mapped (and writable when
 * asked), else the Modbus exception code. */
static int check_range(const struct reg_range *ranges, int addr, int n, int write)
{
    for (int a = addr; a < addr + n; a++) {
        const struct reg_range *r = ranges;
        while (r->lo >= 0 && !(a >= r->lo && a <= r->hi))
            r++;
        if (r->lo < 0 || (write && !r->writable))
            return MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS;
    }
    return 0;
}

static int overlaps(int addr, int n, int reg)
{
    return addr <= reg + 1 && reg < addr + n;
}

static struct msim_axis *axis_of(msim *m, int slave)
{
    switch (slave) {
    case MB_SLAVE_SAMPLE: return &m->axis[SIM_AXIS_SAMPLE];
    case MB_SLAVE_ARM: return &m->axis[SIM_AXIS_ARM];
    case MB_SLAVE_AZIMUTH: return m->n_axes > 2 ? &m->axis[SIM_AXIS_AZIMUTH] : NULL;
    default: return NULL;
    }
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

/* Seconds a frame of n bytes holds an RTU line at baud, with the silence
 * that must follow it (t3.5 of the Modbus serial line guide: 3.5
 * characters, fixed at 1.75 ms above 19200 baud). RTU characters are 11
 * bits whatever the parity: start, 8 data, parity or a second stop, stop. */
static double rtu_frame_s(long baud, int n)
{
    double ch = 11.0 / (double)baud;
    return n * ch + (baud > 19200 ? 1.75e-3 : 3.5 * ch);
}

/* What a frame carrying pdu_len bytes of PDU costs on the bus, in rig
 * time, waited in wall time (time_scale times shorter), with the server
 * held up meanwhile as a line is: its time on the RTU line (request and
 * reply), or the TCP latency (replies only). */
static void bus_wait(const msim *m, int hdr, int pdu_len, int reply)
{
    double s = hdr != 1                ? (reply ? m->cfg.tcp_latency_s : 0.0)
               : m->cfg.baud > 0 ? rtu_frame_s(m->cfg.baud, 1 + pdu_len + 2)
                                 : 0.0;
    wait_wall(s / m->cfg.time_scale);
}

/* Send a PDU framed for the transport the request came on (hdr 1: RTU, 7:
 * TCP), for the answers libmodbus cannot frame: an exception to any
 * function code (modbus_reply_exception adds 0x80 to the code, so a
 * request with code 0x80 came back with 0x00), and a reply damaged on the
 * line (garbled): a bad CRC on RTU, a header naming another transaction
 * and protocol on TCP; either way the master detects a bad answer. */
static void send_pdu(modbus_t *ctx, const uint8_t *req, int hdr, const uint8_t *pdu, int n,
                     int garbled)
{
    uint8_t out[16];
    int len = 0;
    if (hdr == 1) {
        out[len++] = req[0];
    } else {
        uint8_t mask = garbled ? 0xFF : 0x00;
        out[len++] = req[0] ^ mask;
        out[len++] = req[1] ^ mask;
        out[len++] = mask; /* protocol id: 0 is Modbus */
        out[len++] = mask;
        out[len++] = 0;
        out[len++] = (uint8_t)(n + 1);
        out[len++] = req[6];
    }
    memcpy(out + len, pdu, (size_t)n);
    len += n;
    if (hdr == 1) {
        uint16_t crc = crc16(out, len);
        if (garbled)
            crc = (uint16_t)~crc;
        out[len++] = (uint8_t)(crc & 0xFF);
        out[len++] = (uint8_t)(crc >> 8);
    }
    if (write(modbus_get_socket(ctx), out, (size_t)len) < 0)
        return; /* the client went away: nobody to answer */
}

/* The exception answer: the function code with its top bit set. */
static void send_exception(const msim *m, modbus_t *ctx, const uint8_t *req, int hdr, int exc,
                           int garbled)
{
    uint8_t pdu[2] = {(uint8_t)(req[hdr] | 0x80), (uint8_t)exc};
    bus_wait(m, hdr, 2, 1);
    send_pdu(ctx, req, hdr, pdu, 2, garbled);
}

/* Answer one request: req is the whole ADU (hdr bytes of header ending
 * with the unit id, then the PDU, then an RTU frame's CRC); len counts the
 * PDU's bytes. Requests to absent slaves get no answer. */
static void handle(msim *m, modbus_t *ctx, const uint8_t *req, int req_len, int hdr, int len)
{
    int slave = req[hdr - 1];
    bus_wait(m, hdr, len, 0); /* the request is on the line, whoever it is for */
    struct msim_axis *ax = axis_of(m, slave);
    int is_det = slave == MB_SLAVE_DETECTOR;
    if (!ax && !is_det)
        return;
    const uint8_t *pdu = req + hdr;
    int fn = pdu[0];
    int addr = len >= 3 ? (pdu[1] << 8) | pdu[2] : -1;
    int n = 0, write = 0, exc = 0;
    switch (fn) {
    case MODBUS_FC_READ_HOLDING_REGISTERS:
        n = len >= 5 ? (pdu[3] << 8) | pdu[4] : 0;
        if (n < 1 || n > MODBUS_MAX_READ_REGISTERS)
            exc = MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE;
        break;
    case MODBUS_FC_WRITE_SINGLE_REGISTER:
        n = 1;
        write = 1;
        if (len < 5)
            exc = MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE;
        break;
    case MODBUS_FC_WRITE_MULTIPLE_REGISTERS:
        n = len >= 5 ? (pdu[3] << 8) | pdu[4] : 0;
        write = 1;
        if (n < 1 || n > MODBUS_MAX_WRITE_REGISTERS || len < 6 || pdu[5] != 2 * n ||
            len != 6 + 2 * n)
            exc = MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE;
        break;
    default:
        exc = MODBUS_EXCEPTION_ILLEGAL_FUNCTION;
    }
    if (!exc)
        exc = check_range(ax ? axis_ranges : det_ranges, addr, n, write);
    if (m->cfg.trace)
        fprintf(stderr, "gonio-sim: slave %d fn 0x%02x addr 0x%04x n %d%s%s\n", slave, fn,
                addr < 0 ? 0 : addr, n, exc ? " -> exception " : "",
                exc == 1 ? "01" : exc == 2 ? "02" : exc == 3 ? "03" : "");
    m->exchanges++;
    m->slave_exchanges[slave]++;
    double late_s = m->delay_ms[slave] * 1e-3;
    sim_faults *faults = sim_rig_faults(m->rig);
    enum sim_fault fault = SIM_FAULT_NONE;
    if (faults)
        sim_faults_next(faults, &fault);
    if (fault != SIM_FAULT_NONE && m->cfg.trace)
        fprintf(stderr, "gonio-sim: slave %d: exchange %s (scene comm_faults)\n", slave,
                sim_fault_name(fault));
    if (fault == SIM_FAULT_DROP) /* lost on the line: not executed, no answer */
        return;
    if (fault == SIM_FAULT_CORRUPT) { /* garbled on the line: not executed */
        send_exception(m, ctx, req, hdr, MODBUS_EXCEPTION_SLAVE_OR_SERVER_FAILURE, 1);
        return;
    }
    if (fault == SIM_FAULT_LATE)
        late_s += sim_faults_timeout(faults);
    wait_wall(late_s);
    if (exc) {
        send_exception(m, ctx, req, hdr, exc, 0);
        return;
    }
    sync_clock(m);
    if (ax)
        axis_refresh(m, ax);
    else
        det_refresh(m);
    /* The registers are read as the request arrived; the reply then takes
     * its time on the bus: 2 + 2n bytes of PDU for a read, 5 for a write. */
    bus_wait(m, hdr, write ? 5 : 2 + 2 * n, 1);
    modbus_reply(ctx, req, req_len, ax ? ax->map : m->det.map);
    if (!write)
        return;
    /* Act on what was written: a trigger register holding 1 starts the
     * operation and reads back 0; input commands act on rising edges. */
    if (ax) {
        uint16_t *r = ax->map->tab_registers;
        if (overlaps(addr, n, AX_INPUT))
            axis_input(m, ax);
        if (overlaps(addr, n, AX_TRIGGER) && get32(r, AX_TRIGGER) == 1) {
            put32(r, AX_TRIGGER, 0);
            axis_trigger(m, ax);
        }
        axis_refresh(m, ax);
    } else {
        uint16_t *r = m->det.map->tab_registers;
        if (overlaps(addr, n, DET_TRIGGER) && get32(r, DET_TRIGGER) == 1) {
            put32(r, DET_TRIGGER, 0);
            det_trigger(m);
        }
    }
}

/* ---- RTU on a pseudo-terminal --------------------------------------------- */

int msim_open_pty(msim *m, const char *link, char *path, size_t size, struct gonio_err *err)
{
    int fd = posix_openpt(O_RDWR | O_NOCTTY);
    if (fd < 0 || grantpt(fd) < 0 || unlockpt(fd) < 0) {
        int e = errno;
        if (fd >= 0)
            close(fd);
        return gonio_err_set(err, e, "gonio-sim: pseudo-terminal: %s", strerror(e));
    }
    m->pty_master = fd;
    const char *name = ptsname(fd);
    if (!name || strlen(name) >= size)
        return gonio_err_set(err, EIO, "gonio-sim: no name for the pseudo-terminal");
    snprintf(path, size, "%s", name);
    m->pty_slave = open(path, O_RDWR | O_NOCTTY);
    if (m->pty_slave < 0)
        return gonio_err_set(err, errno, "gonio-sim: %s: %s", path, strerror(errno));
    /* Raw bytes both ways, as on a serial line; clients set their own mode
     * too, but a client that does not must not get echoes. */
    struct termios t;
    if (tcgetattr(m->pty_slave, &t) == 0) {
        cfmakeraw(&t);
        tcsetattr(m->pty_slave, TCSANOW, &t);
    }
    fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
    m->rtu = modbus_new_rtu("/dev/null", 115200, 'N', 8, 1);
    if (!m->rtu || modbus_set_socket(m->rtu, fd) < 0)
        return gonio_err_set(err, ENOMEM, "gonio-sim: RTU context: %s", modbus_strerror(errno));
    if (link) {
        unlink(link);
        if (symlink(path, link) < 0)
            return gonio_err_set(err, errno, "gonio-sim: --link %s: %s", link, strerror(errno));
    }
    return 0;
}

/* Length of the RTU frame starting the buffer from its function code; 0:
 * not known yet, -1: a function whose length we cannot tell (the frame ends
 * at a silence). */
static int rtu_frame_len(const uint8_t *b, int n)
{
    if (n < 2)
        return 0;
    switch (b[1]) {
    case 0x01: case 0x02: case 0x03: case 0x04: case 0x05: case 0x06:
        return 8;
    case 0x0F: case 0x10:
        return n < 7 ? 0 : 9 + b[6];
    default:
        return -1;
    }
}

static void rtu_frame(msim *m, int len)
{
    const uint8_t *b = m->rtu_buf;
    /* A frame with a bad CRC is noise: a real slave says nothing. */
    if (len < 4 || crc16(b, len - 2) != (uint16_t)(b[len - 2] | (b[len - 1] << 8))) {
        if (m->cfg.trace)
            fprintf(stderr, "gonio-sim: RTU frame of %d bytes with a bad CRC ignored\n", len);
        return;
    }
    handle(m, m->rtu, b, len, 1, len - 3);
}

/* Read what the pty holds; answer complete frames. */
static void rtu_read(msim *m)
{
    for (;;) {
        if (m->rtu_len == (int)sizeof m->rtu_buf)
            m->rtu_len = 0; /* nothing valid is that long: drop it */
        ssize_t got = read(m->pty_master, m->rtu_buf + m->rtu_len,
                           sizeof m->rtu_buf - (size_t)m->rtu_len);
        if (got <= 0)
            break;
        m->rtu_len += (int)got;
    }
    for (;;) {
        int fl = rtu_frame_len(m->rtu_buf, m->rtu_len);
        if (fl <= 0 || fl > m->rtu_len)
            return;
        if (fl > (int)sizeof m->rtu_buf) {
            m->rtu_len = 0;
            return;
        }
        int bad = crc16(m->rtu_buf, fl - 2) !=
                  (uint16_t)(m->rtu_buf[fl - 2] | (m->rtu_buf[fl - 1] << 8));
        rtu_frame(m, fl);
        if (bad) { /* the rest of a noisy burst is noise too */
            m->rtu_len = 0;
            return;
        }
        memmove(m->rtu_buf, m->rtu_buf + fl, (size_t)(m->rtu_len - fl));
        m->rtu_len -= fl;
    }
}

/* A silence ended whatever is buffered. */
static void rtu_silence(msim *m)
{
    if (m->rtu_len > 0)
        rtu_frame(m, m->rtu_len);
    m->rtu_len = 0;
}

/* ---- TCP on loopback --------------------------------------------------------- */

int msim_open_tcp(msim *m, const char *addr, int *port, struct gonio_err *err)
{
    char host[64];
    const char *colon = strrchr(addr, ':');
    char *end;
    long p = colon ? strtol(colon + 1, &end, 10) : -1;
    if (!colon || (size_t)(colon - addr) >= sizeof host || *end || p < 0 || p > 65535 ||
        colon == addr)
        return gonio_err_set(err, GONIO_EUSAGE, "--tcp '%s': use HOST:PORT (PORT 0 picks one)",
                             addr);
    memcpy(host, addr, (size_t)(colon - addr));
    host[colon - addr] = '\0';
    struct in_addr ia;
    if (inet_pton(AF_INET, host, &ia) != 1)
        return gonio_err_set(err, GONIO_EUSAGE, "--tcp '%s': '%s' is not an IPv4 address", addr,
                             host);
    m->tcp = modbus_new_tcp(host, (int)p);
    if (!m->tcp)
        return gonio_err_set(err, ENOMEM, "--tcp %s: %s", addr, modbus_strerror(errno));
    m->listen_fd = modbus_tcp_listen(m->tcp, MAX_CLIENTS);
    if (m->listen_fd < 0)
        return gonio_err_set(err, errno, "--tcp %s: %s", addr, modbus_strerror(errno));
    struct sockaddr_in sa;
    socklen_t sl = sizeof sa;
    if (getsockname(m->listen_fd, (struct sockaddr *)&sa, &sl) < 0)
        return gonio_err_set(err, errno, "--tcp %s: %s", addr, strerror(errno));
    *port = ntohs(sa.sin_port);
    return 0;
}

static void tcp_accept(msim *m)
{
    int fd = accept(m->listen_fd, NULL, NULL);
    if (fd < 0)
        return;
    for (int i = 0; i < MAX_CLIENTS; i++)
        if (m->clients[i].fd < 0) {
            m->clients[i].fd = fd;
            m->clients[i].len = 0;
            return;
        }
    close(fd); /* full: refuse */
}

static void tcp_close(msim *m, int slot)
{
    close(m->clients[slot].fd);
    m->clients[slot].fd = -1;
}

/* Read what a client sent and answer each complete frame. The MBAP
 * header's length cuts the frames, as the Modbus TCP implementation guide
 * has a server do, so a PDU whose own fields disagree with it (an FC 0x10
 * byte count) gets its exception 03 and the stream stays in step. A frame
 * whose protocol id is not 0 (Modbus) is discarded unanswered; a length no
 * request can have loses the stream, and the connection is closed. */
static void tcp_read(msim *m, int slot)
{
    struct tcp_client *c = &m->clients[slot];
    ssize_t got = recv(c->fd, c->buf + c->len, sizeof c->buf - (size_t)c->len, MSG_DONTWAIT);
    if (got < 0 && (errno == EAGAIN || errno == EINTR))
        return;
    if (got <= 0) { /* the client went away */
        tcp_close(m, slot);
        return;
    }
    c->len += (int)got;
    while (c->len >= 7) {
        int n = 6 + ((c->buf[4] << 8) | c->buf[5]); /* the whole frame */
        if (n < 8 || n > TCP_MAX_ADU) {
            if (m->cfg.trace)
                fprintf(stderr, "gonio-sim: TCP frame length %d: connection closed\n", n - 6);
            tcp_close(m, slot);
            return;
        }
        if (c->len < n)
            return;
        if (c->buf[2] || c->buf[3]) {
            if (m->cfg.trace)
                fprintf(stderr, "gonio-sim: TCP frame of protocol %u discarded\n",
                        (unsigned)((c->buf[2] << 8) | c->buf[3]));
        } else {
            modbus_set_socket(m->tcp, c->fd);
            handle(m, m->tcp, c->buf, n, 7, n - 7);
        }
        memmove(c->buf, c->buf + n, (size_t)(c->len - n));
        c->len -= n;
    }
}

/* ---- The loop -------------------------------------------------------------- */

int msim_serve(msim *m, volatile sig_atomic_t *stop, volatile sig_atomic_t *hangup,
               struct gonio_err *err)
{
    while (!*stop) {
        if (*hangup) {
            *hangup = 0;
            for (int i = 0; i < MAX_CLIENTS; i++)
                if (m->clients[i].fd >= 0)
                    tcp_close(m, i);
        }
        struct pollfd pf[2 + MAX_CLIENTS];
        int slot[2 + MAX_CLIENTS];
        int n = 0;
        if (m->pty_master >= 0)
            pf[n] = (struct pollfd){.fd = m->pty_master, .events = POLLIN}, slot[n++] = -1;
        if (m->listen_fd >= 0)
            pf[n] = (struct pollfd){.fd = m->listen_fd, .events = POLLIN}, slot[n++] = -2;
        for (int i = 0; i < MAX_CLIENTS; i++)
            if (m->clients[i].fd >= 0)
                pf[n] = (struct pollfd){.fd = m->clients[i].fd, .events = POLLIN},
                slot[n++] = i;
        int rc = poll(pf, (nfds_t)n, m->rtu_len > 0 ? RTU_GAP_MS : 200);
        if (rc < 0) {
            if (errno == EINTR)
                continue;
            return gonio_err_set(err, errno, "gonio-sim: poll: %s", strerror(errno));
        }
        if (rc == 0) {
            rtu_silence(m);
            continue;
        }
        for (int i = 0; i < n; i++) {
            if (!(pf[i].revents & (POLLIN | POLLHUP | POLLERR)))
                continue;
            if (slot[i] == -1)
                rtu_read(m);
            else if (slot[i] == -2)
                tcp_accept(m);
            else
                tcp_read(m, slot[i]);
        }
    }
    return 0;
}
