/* gonio-sim's requests: one request answered as a real slave would,
 * checked against the register ranges of its device, with its time on
 * the bus and the scene's comm_faults, and the answers libmodbus cannot
 * frame. */
#include <errno.h>
#include <modbus.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "modbus_map/modbus_map.h"
#include "sim/effects_faults.h"
#include "sim/modbus_server_private.h"
#include "sim/sim.h"

/* The Modbus CRC (polynomial 0xA001 reflected, initial 0xFFFF). */
uint16_t msim_crc16(const uint8_t *p, int n)
{
    uint16_t crc = 0xFFFF;
    for (int i = 0; i < n; i++) {
        crc ^= p[i];
        for (int b = 0; b < 8; b++)
            crc = (crc & 1) ? (uint16_t)((crc >> 1) ^ 0xA001) : (uint16_t)(crc >> 1);
    }
    return crc;
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
    {DET_INTEGRATION, DET_TRIGGER + 1, 1}, {DET_STATUS, DET_NREGS - 1, 0},
    {DET_RAW_SEQUENCE, DET_SHUTTER - 1, 0}, {DET_SHUTTER, DET_SHUTTER + 1, 1}, {-1, -1, 0}};
static const struct reg_range changer_ranges[] = {
    {MB_CH_TARGET, MB_CH_TARGET + 1, 1}, {MB_CH_STATUS, MB_CH_NREGS - 1, 0}, {-1, -1, 0}};
/* A detector without a shutter (msim_cfg.no_shutter): no register 0x010A. */
static const struct reg_range det_ranges_no_shutter[] = {
    {DET_INTEGRATION, DET_TRIGGER + 1, 1}, {DET_STATUS, DET_NREGS - 1, 0},
    {DET_RAW_SEQUENCE, DET_SHUTTER - 1, 0}, {-1, -1, 0}};
/* A simulated clock's detector has its wait register too. */
static const struct reg_range det_wait_range[] = {{DET_WAIT, DET_WAIT + 1, 1}, {-1, -1, 0}};

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
 * time (msim_bus_time: waited in wall time, time_scale times shorter, with
 * the server held up meanwhile as a line is; or counted on a simulated
 * clock): its time on the RTU line (request and reply), or the TCP latency
 * (replies only). */
static void bus_wait(msim *m, int hdr, int pdu_len, int reply)
{
    double s = hdr != 1                ? (reply ? m->cfg.tcp_latency_s : 0.0)
               : m->cfg.baud > 0 ? rtu_frame_s(m->cfg.baud, 1 + pdu_len + 2)
                                 : 0.0;
    msim_bus_time(m, s);
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
        uint16_t crc = msim_crc16(out, len);
        if (garbled)
            crc = (uint16_t)~crc;
        out[len++] = (uint8_t)(crc & 0xFF);
        out[len++] = (uint8_t)(crc >> 8);
    }
    if (write(modbus_get_socket(ctx), out, (size_t)len) < 0)
        return; /* the client went away: nobody to answer */
}

/* The exception answer: the function code with its top bit set. */
static void send_exception(msim *m, modbus_t *ctx, const uint8_t *req, int hdr, int exc,
                           int garbled)
{
    uint8_t pdu[2] = {(uint8_t)(req[hdr] | 0x80), (uint8_t)exc};
    bus_wait(m, hdr, 2, 1);
    send_pdu(ctx, req, hdr, pdu, 2, garbled);
}

/* The request's function: its register count and whether it writes into
 * *n and *write; 0, or the exception it gets. */
static int function_of(const uint8_t *pdu, int len, int *n, int *write)
{
    switch (pdu[0]) {
    case MODBUS_FC_READ_HOLDING_REGISTERS:
        *n = len >= 5 ? (pdu[3] << 8) | pdu[4] : 0;
        return *n < 1 || *n > MODBUS_MAX_READ_REGISTERS ? MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE
                                                        : 0;
    case MODBUS_FC_WRITE_SINGLE_REGISTER:
        *n = 1;
        *write = 1;
        return len < 5 ? MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE : 0;
    case MODBUS_FC_WRITE_MULTIPLE_REGISTERS:
        *n = len >= 5 ? (pdu[3] << 8) | pdu[4] : 0;
        *write = 1;
        return *n < 1 || *n > MODBUS_MAX_WRITE_REGISTERS || len < 6 || pdu[5] != 2 * *n ||
                       len != 6 + 2 * *n
                   ? MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE
                   : 0;
    default:
        return MODBUS_EXCEPTION_ILLEGAL_FUNCTION;
    }
}

/* 0 when n registers from addr are mapped on the slave (an axis, the
 * changer or the detector) for the access, else the exception. */
static int address_check(const msim *m, const struct msim_axis *ax, int changer, int addr,
                         int n, int write)
{
    int exc = check_range(ax                  ? axis_ranges
                          : changer           ? changer_ranges
                          : m->cfg.no_shutter ? det_ranges_no_shutter
                                              : det_ranges,
                          addr, n, write);
    if (exc != MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS || ax || changer)
        return exc;
    if (m->cfg.simulated_clock && check_range(det_wait_range, addr, n, write) == 0)
        return 0;
    if (m->det.n_bands && !write) {
        /* the band block, read only, as long as the detector's bands */
        int nb = m->det.n_bands;
        const struct reg_range bands[] = {
            {MB_DET_BAND_COUNT, MB_DET_BAND_NM + 2 * nb - 1, 0},
            {MB_DET_BAND_SEQUENCE, MB_DET_BAND_COUNTS + 2 * nb - 1, 0}, {-1, -1, 0}};
        if (check_range(bands, addr, n, 0) == 0)
            return 0;
    }
    return exc;
}

/* Answer one request: req is the whole ADU (hdr bytes of header ending
 * with the unit id, then the PDU, then an RTU frame's CRC); len counts the
 * PDU's bytes. Requests to absent slaves get no answer. */
void msim_handle_request(msim *m, modbus_t *ctx, const uint8_t *req, int req_len, int hdr,
                         int len)
{
    int slave = req[hdr - 1];
    struct msim_axis *ax = msim_axis_of(m, slave);
    int is_det = slave == MB_SLAVE_DETECTOR;
    modbus_mapping_t *chg = slave == MB_SLAVE_CHANGER ? m->changer.map : NULL;
    const uint8_t *pdu = req + hdr;
    int fn = pdu[0];
    int addr = len >= 3 ? (pdu[1] << 8) | pdu[2] : -1;
    /* A simulated clock's wait is the master's sleep, not the rig's
     * traffic: its frames take no line time. */
    int wait = m->cfg.simulated_clock && is_det && fn == MODBUS_FC_WRITE_MULTIPLE_REGISTERS &&
               addr == DET_WAIT;
    if (!wait)
        bus_wait(m, hdr, len, 0); /* the request is on the line, whoever it is for */
    if (!ax && !is_det && !chg)
        return;
    int n = 0, write = 0;
    int exc = function_of(pdu, len, &n, &write);
    if (!exc)
        exc = address_check(m, ax, chg != NULL, addr, n, write);
    if (m->cfg.trace)
        fprintf(stderr, "gonio-sim: %.4f s: slave %d fn 0x%02x addr 0x%04x n %d%s%s\n",
                sim_rig_now(m->rig), slave, fn, addr < 0 ? 0 : addr, n,
                exc ? " -> exception " : "",
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
    /* Late in wall time, where the master's timeout runs; a simulated
     * clock counts the lateness as rig time too (the line was held). */
    msim_wait_late(m, late_s);
    if (exc) {
        send_exception(m, ctx, req, hdr, exc, 0);
        return;
    }
    msim_sync_clock(m);
    if (!write && !chg)
        msim_poll_jump(m, ax, addr, n);
    if (ax)
        msim_axis_refresh(m, ax);
    else if (!chg)
        msim_det_refresh(m);
    /* The registers are read as the request arrived; the reply then takes
     * its time on the bus: 2 + 2n bytes of PDU for a read, 5 for a write. */
    if (!wait)
        bus_wait(m, hdr, write ? 5 : 2 + 2 * n, 1);
    modbus_reply(ctx, req, req_len, ax ? ax->map : chg ? chg : m->det.map);
    if (!write)
        return;
    if (chg) {
        if (overlaps(addr, n, MB_CH_TARGET))
            msim_changer_target(m);
        return;
    }
    /* Act on what was written: a trigger register holding 1 starts the
     * operation and reads back 0; input commands act on rising edges. */
    if (ax) {
        uint16_t *r = ax->map->tab_registers;
        if (overlaps(addr, n, AX_INPUT))
            msim_axis_input(m, ax);
        if (overlaps(addr, n, AX_TRIGGER) && get32(r, AX_TRIGGER) == 1) {
            put32(r, AX_TRIGGER, 0);
            msim_axis_trigger(m, ax);
        }
        msim_axis_refresh(m, ax);
    } else {
        uint16_t *r = m->det.map->tab_registers;
        if (overlaps(addr, n, DET_SHUTTER))
            msim_det_shutter(m);
        if (overlaps(addr, n, DET_TRIGGER) && get32(r, DET_TRIGGER) == 1) {
            put32(r, DET_TRIGGER, 0);
            msim_det_trigger(m);
        }
        if (overlaps(addr, n, DET_WAIT)) {
            msim_det_wait(m);
            msim_det_refresh(m);
        }
    }
}
