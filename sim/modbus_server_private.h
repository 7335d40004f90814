/* gonio-sim's Modbus server from the inside: the state of the simulated
 * devices behind their register banks, and the calls its three parts make
 * of each other. Only sim/modbus_server.c (lifecycle, transports, the
 * loop), sim/modbus_devices.c (the drives' and the detector's state
 * machines, fault injection, stats) and sim/modbus_requests.c (answering
 * one request) include it. */
#ifndef GONIO_SIM_MODBUS_SERVER_PRIVATE_H
#define GONIO_SIM_MODBUS_SERVER_PRIVATE_H

#include <modbus.h>
#include <stdint.h>

#include "modbus_map/modbus_map.h"
#include "sim/modbus_server.h"
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
    DET_RAW_SEQUENCE = MB_DET_RAW_SEQUENCE, DET_GAIN_STATE = MB_DET_GAIN_STATE,
    DET_FULL_SCALE = MB_DET_FULL_SCALE, DET_NONLINEARITY = MB_DET_NONLINEARITY,
    DET_MONITOR = MB_DET_MONITOR, DET_SHUTTER = MB_DET_SHUTTER, DET_WAIT = MB_DET_WAIT,
    /* what the map holds: the raw block's, the wait's and the band block's too */
    DET_MAP_NREGS = MB_DET_BAND_COUNTS + 2 * MB_DET_MAX_BANDS,
};
enum { IN_ZHOME = MB_IN_ZHOME, IN_STOP = MB_IN_STOP, IN_ALM_RST = MB_IN_ALM_RST };
enum { ST_HOME_END = MB_ST_HOME_END, ST_READY = MB_ST_READY, ST_ALM_A = MB_ST_ALM_A,
       ST_MOVE = MB_ST_MOVE, ST_IN_POS = MB_ST_IN_POS };
enum { DST_BUSY = MB_DET_BUSY, DST_READY = MB_DET_READY, DST_SATURATED = MB_DET_SATURATED,
       DST_RAW = MB_DET_RAW, DST_BANDS = MB_DET_BANDS, DST_LINE_TIMED = MB_DET_LINE_TIMED,
       DST_CLOCK_SIMULATED = MB_DET_CLOCK_SIMULATED };
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
    const struct rig_axis *prof;
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
    /* A scene with an adc: the pending data are counts, with what the ADC
     * states and the monitor's counts (NAN: none); raw: the published
     * data's. */
    int pending_raw, raw;
    double pending_full_scale, pending_nonlinearity, pending_monitor;
    /* A spectral scene with an adc: its bands (docs/protocol-modbus.md,
     * "Band block"), 0 else; the pending reading's band counts. */
    int n_bands;
    double pending_bands[MB_DET_MAX_BANDS];
};

/* The sample changer (sim/modbus_changer.c): mapped only when the rig
 * profile has one; slot 1 holds MSIM_CHANGER_STANDARD, slot 2 a light trap. */
#define MSIM_CHANGER_STANDARD "standard:spectralon-99"
#define MSIM_CHANGER_TRAP "trap"
struct msim_changer {
    modbus_mapping_t *map;
    const brdf_material *sample;
    brdf_material *standard, *trap;
    struct sim_scene scene;
    int has_scene;
    long moves[MB_CH_SLOTS]; /* swaps done to each slot */
};

struct msim {
    struct msim_cfg cfg;
    const struct rig_profile *profile;
    sim_rig *rig;
    double wall0;
    struct msim_axis axis[SIM_N_AXES];
    int served[SIM_N_AXES]; /* the axes the profile has: sample, arm; azimuth, rotation if so */
    struct msim_detector det;
    struct msim_changer changer;
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
static inline uint32_t get32(const uint16_t *r, int addr)
{
    return mb_get32(r + addr);
}

static inline void put32(uint16_t *r, int addr, uint32_t v)
{
    mb_put32(r + addr, v);
}

/* ---- The sample changer (sim/modbus_changer.c) ---------------------------- */

/* Map the changer when the profile has one, slot 0 (the sample) in place. */
int msim_changer_new(msim *m, const brdf_material *sample, const struct sim_scene *scene,
                     struct gonio_err *err);
void msim_changer_free(msim *m);
/* The target slot written: swap to it (a slot out of range is ignored). */
void msim_changer_target(msim *m);

/* ---- The devices (sim/modbus_devices.c) ---------------------------------- */

/* Bring the simulated clock to the wall clock's scaled time (a wall
 * clock; a simulated clock stays where it is). */
void msim_sync_clock(msim *m);
/* Let seconds of bus time pass: a wall clock waits them, time_scale times
 * shorter, holding the server up as a line is held; a simulated clock
 * counts them. */
void msim_bus_time(msim *m, double seconds);
/* An answer seconds late (msim_delay, a late comm_fault): waited in wall
 * time, where the master's timeout runs, and counted as rig time too on a
 * simulated clock (the line was held that long). */
void msim_wait_late(msim *m, double seconds);
/* A simulated clock jumps to where a wait ends that a request of n
 * registers at addr polls for: the move of the axis (ax, else the
 * detector's integration) that a read of the status finds under way. */
void msim_poll_jump(msim *m, struct msim_axis *ax, int addr, int n);
/* The simulated clock's wait register written: let its time pass. */
void msim_det_wait(msim *m);
/* The axis served at slave id (docs/protocol-modbus.md), NULL for none. */
struct msim_axis *msim_axis_of(msim *m, int slave);
/* Refresh an axis's read-only registers from the simulation. */
void msim_axis_refresh(msim *m, struct msim_axis *ax);
/* A trigger register written 1: start the operation its registers describe. */
void msim_axis_trigger(msim *m, struct msim_axis *ax);
/* The input command register written: act on its rising edges. */
void msim_axis_input(msim *m, struct msim_axis *ax);
/* Completing an integration publishes its data and bumps the sequence. */
void msim_det_refresh(msim *m);
/* The detector's trigger written 1: start an integration. */
void msim_det_trigger(msim *m);
/* The shutter register written: nonzero closes it (reads back 1), 0 opens
 * it; the next integration sees it. */
void msim_det_shutter(msim *m);

/* ---- Requests (sim/modbus_requests.c) ------------------------------------ */

/* The Modbus CRC of an RTU frame's n bytes. */
uint16_t msim_crc16(const uint8_t *p, int n);
/* Answer one request arrived on ctx's transport: req is the whole ADU of
 * req_len bytes (hdr bytes of header ending with the unit id, then the
 * PDU, then an RTU frame's CRC); len counts the PDU's bytes. */
void msim_handle_request(msim *m, modbus_t *ctx, const uint8_t *req, int req_len, int hdr,
                         int len);

#endif
