/* A Modbus bus: one libmodbus context shared by the devices on it, with
 * bounded retries and a drain after every failed exchange, so that a reply
 * arriving late is not taken for the answer to the next request; a TCP
 * connection the peer dropped is re-opened within the same retries. */
#include <errno.h>
#include <math.h>
#include <modbus.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>

#include "common/line_speed.h"
#include "drivers/drv_modbus_private.h"

struct drv_modbus_bus {
    modbus_t *ctx;
    char where[300]; /* "/dev/pts/3" or "127.0.0.1:1502", for messages */
    double timeout_s, time_scale, drain_s;
    int retries, trace, tcp;
    struct drv_modbus_stats stats;
    int last_exception; /* of the last transaction: its exception code, 0 none */
    int (*cancelled)(void *user); /* drv_modbus_bus_set_cancel */
    void *cancel_user;
    /* The line (drv_modbus_acted): wall seconds a character takes on it
     * and the silence that ends a frame (drv_modbus_gap_s); both 0 on TCP,
     * and from the first exchange faster than its frames could travel at
     * that rate (a line that charges no such time); the last answered
     * exchange's send and answer times and its frames' characters. */
    double char_s, gap_s;
    struct {
        double sent, answered;
        int req_chars, reply_chars;
    } last;
    /* The line in rig time (drv_modbus_line_rig): a character and the
     * silence at the configured rate, unscaled and never learned away; the
     * line time of the answered exchanges so far, in all and up to when
     * the last one's device acted. And whether the rig's clock is
     * simulated (drv_modbus_set_simulated_clock). */
    double char_rig, gap_rig, line_total, line_acted;
    int simulated_clock;
    struct { /* drv_modbus_note_clock */
        int slave;
        uint32_t ms;
        double lo, hi;
        long requests; /* stats.requests when noted */
    } clock;
};

int drv_modbus_last_exception(const drv_modbus_bus *bus)
{
    return bus->last_exception;
}

void drv_modbus_bus_stats(const drv_modbus_bus *bus, struct drv_modbus_stats *out)
{
    *out = bus->stats;
}

void drv_modbus_bus_cfg_default(struct drv_modbus_bus_cfg *cfg)
{
    memset(cfg, 0, sizeof *cfg);
    cfg->baud = 115200;
    cfg->parity = 'N';
    cfg->data_bits = 8;
    cfg->stop_bits = 1;
    cfg->timeout_s = 0.5;
    cfg->retries = 4;
    cfg->time_scale = 1.0;
}

static drv_modbus_bus *bus_finish(modbus_t *ctx, const struct drv_modbus_bus_cfg *cfg,
                                  const char *where, double char_s, double gap_s,
                                  struct gonio_err *err)
{
    if (!ctx) {
        gonio_err_set(err, EINVAL, "modbus %s: %s", where, modbus_strerror(errno));
        return NULL;
    }
    double timeout = cfg->timeout_s > 0 ? cfg->timeout_s : 0.5;
    double scale = cfg->time_scale > 0 ? cfg->time_scale : 1.0;
    double drain = cfg->drain_s > 0 ? cfg->drain_s : fmin(timeout, 0.1);
    if (!isfinite(timeout) || timeout > 3600 || !isfinite(scale) || !(drain <= 3600)) {
        modbus_free(ctx);
        gonio_err_set(err, EINVAL, "modbus %s: timeout %g s, drain %g s, time scale %g", where,
                      timeout, drain, scale);
        return NULL;
    }
    uint32_t sec = (uint32_t)timeout;
    modbus_set_response_timeout(ctx, sec, (uint32_t)((timeout - sec) * 1e6));
    if (modbus_connect(ctx) < 0) {
        int e = errno;
        modbus_free(ctx);
        gonio_err_set(err, GONIO_EDEVICE, "modbus %s: cannot connect: %s", where,
                      modbus_strerror(e));
        return NULL;
    }
    drv_modbus_bus *bus = calloc(1, sizeof *bus);
    if (!bus) {
        modbus_close(ctx);
        modbus_free(ctx);
        gonio_err_set(err, ENOMEM, "modbus %s: out of memory", where);
        return NULL;
    }
    bus->ctx = ctx;
    snprintf(bus->where, sizeof bus->where, "%s", where);
    bus->timeout_s = timeout;
    bus->drain_s = drain;
    bus->time_scale = scale;
    bus->retries = cfg->retries > 0 ? cfg->retries : 0;
    bus->trace = cfg->trace;
    bus->char_rig = char_s;
    bus->gap_rig = gap_s;
    bus->char_s = char_s / scale; /* a simulator's line is as much faster in wall time */
    bus->gap_s = gap_s / scale;
    return bus;
}

drv_modbus_bus *drv_modbus_bus_new_rtu(const struct drv_modbus_bus_cfg *cfg,
                                       struct gonio_err *err)
{
    if (!cfg->device || !cfg->device[0]) {
        gonio_err_set(err, EINVAL, "modbus RTU: no serial device given");
        return NULL;
    }
    char parity = cfg->parity ? cfg->parity : 'N';
    if (parity != 'N' && parity != 'E' && parity != 'O') {
        gonio_err_set(err, EINVAL, "modbus %s: parity '%c': use N, E or O", cfg->device, parity);
        return NULL;
    }
    int baud = cfg->baud > 0 ? cfg->baud : 115200, data = cfg->data_bits > 0 ? cfg->data_bits : 8,
        stop = cfg->stop_bits > 0 ? cfg->stop_bits : 1;
    modbus_t *ctx = modbus_new_rtu(cfg->device, baud, parity, data, stop);
    /* A character: start bit, data, parity, stop bits. The silence that
     * ends a frame, t3.5 of the Modbus serial line guide: 3.5 characters
     * (of 11 bits), 1.75 ms above 19200 baud. */
    double char_s = (1 + data + (parity != 'N') + stop) / (double)baud;
    double gap_s = baud > 19200 ? 1.75e-3 : 3.5 * 11.0 / baud;
    drv_modbus_bus *bus = bus_finish(ctx, cfg, cfg->device, char_s, gap_s, err);
    /* libmodbus sets the line to 9600 baud for a speed it has no case for
     * (1800, say), with no error: the devices would then be silent at a
     * speed nobody configured. Read back what the line was set to. */
    struct termios line;
    long set = bus && tcgetattr(modbus_get_socket(bus->ctx), &line) == 0
                   ? line_speed_baud(cfgetospeed(&line))
                   : baud;
    if (bus && set != baud) {
        drv_modbus_bus_free(bus);
        gonio_err_set(err, EINVAL,
                      "modbus %s: baud %d: the line was set to %ld baud instead (libmodbus "
                      "sets 1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200 and faster)",
                      cfg->device, baud, set);
        return NULL;
    }
    return bus;
}

drv_modbus_bus *drv_modbus_bus_new_tcp(const struct drv_modbus_bus_cfg *cfg,
                                       struct gonio_err *err)
{
    if (!cfg->host || !cfg->host[0] || cfg->port <= 0 || cfg->port > 65535) {
        gonio_err_set(err, EINVAL, "modbus TCP: host '%s' port %d", cfg->host ? cfg->host : "",
                      cfg->port);
        return NULL;
    }
    char where[300];
    snprintf(where, sizeof where, "%s:%d", cfg->host, cfg->port);
    drv_modbus_bus *bus = bus_finish(modbus_new_tcp(cfg->host, cfg->port), cfg, where, 0, 0,
                                     err);
    if (bus)
        bus->tcp = 1;
    return bus;
}

void drv_modbus_bus_free(drv_modbus_bus *bus)
{
    if (!bus)
        return;
    modbus_close(bus->ctx);
    modbus_free(bus->ctx);
    free(bus);
}

void drv_modbus_bus_set_trace(drv_modbus_bus *bus, int on)
{
    bus->trace = on;
}

long drv_modbus_faults(const drv_modbus_bus *bus)
{
    return bus->stats.retries + bus->stats.failed;
}

static int request_chars(int write, int n);

double drv_modbus_time_scale(const drv_modbus_bus *bus)
{
    return bus->time_scale;
}

void drv_modbus_set_simulated_clock(drv_modbus_bus *bus, int line_timed)
{
    bus->simulated_clock = 1;
    if (!line_timed) { /* a line that charges no time on the rig */
        bus->char_rig = bus->gap_rig = 0;
        bus->line_total = bus->line_acted = 0;
    }
}

int drv_modbus_simulated_clock(const drv_modbus_bus *bus)
{
    return bus->simulated_clock;
}

void drv_modbus_line_rig(const drv_modbus_bus *bus, double *acted, double *total)
{
    *acted = bus->line_acted;
    *total = bus->line_total;
}

void drv_modbus_line_rig_restore(drv_modbus_bus *bus, double acted, double total)
{
    bus->line_acted = acted;
    bus->line_total = total;
}

double drv_modbus_request_rig_s(const drv_modbus_bus *bus, int write, int n)
{
    return request_chars(write, n) * bus->char_rig;
}

double drv_modbus_timeout(const drv_modbus_bus *bus)
{
    return bus->timeout_s;
}

void drv_modbus_note_clock(drv_modbus_bus *bus, int slave, uint32_t ms)
{
    bus->clock.slave = slave;
    bus->clock.ms = ms;
    drv_modbus_acted(bus, &bus->clock.lo, &bus->clock.hi);
    bus->clock.requests = bus->stats.requests;
}

int drv_modbus_last_clock(const drv_modbus_bus *bus, int slave, uint32_t *ms, double *lo,
                          double *hi)
{
    if (bus->clock.slave != slave || bus->clock.requests != bus->stats.requests)
        return 0;
    *ms = bus->clock.ms;
    *lo = bus->clock.lo;
    *hi = bus->clock.hi;
    return 1;
}

/* Characters of an RTU frame (address, PDU, CRC): a request of n
 * registers and its answer. */
static int request_chars(int write, int n)
{
    return !write ? 8 : n == 1 ? 8 : 9 + 2 * n;
}

static int reply_chars(int write, int n)
{
    return write ? 8 : 5 + 2 * n;
}

double drv_modbus_request_s(const drv_modbus_bus *bus, int write, int n)
{
    return request_chars(write, n) * bus->char_s;
}

void drv_modbus_acted(const drv_modbus_bus *bus, double *lo, double *hi)
{
    *lo = bus->last.sent + bus->last.req_chars * bus->char_s;
    *hi = bus->last.answered - bus->last.reply_chars * bus->char_s;
}

double drv_modbus_gap_s(const drv_modbus_bus *bus)
{
    return bus->gap_s;
}

/* An exchange answered sooner than its frames can travel at the line's
 * rate took no line time (a pseudo-terminal, a simulator that emulates
 * none): the frames' times bound nothing on it, from now on. */
static void note_exchange(drv_modbus_bus *bus, int write, int n, double sent, double answered)
{
    bus->last.sent = sent;
    bus->last.answered = answered;
    bus->last.req_chars = request_chars(write, n);
    bus->last.reply_chars = reply_chars(write, n);
    bus->line_total += (bus->last.req_chars + bus->last.reply_chars) * bus->char_rig +
                       2 * bus->gap_rig;
    bus->line_acted = bus->line_total - bus->last.reply_chars * bus->char_rig - bus->gap_rig;
    if (answered - sent < (bus->last.req_chars + bus->last.reply_chars) * bus->char_s)
        bus->char_s = bus->gap_s = 0;
}

void drv_modbus_bus_set_cancel(drv_modbus_bus *bus, int (*cancelled)(void *user), void *user)
{
    bus->cancelled = cancelled;
    bus->cancel_user = user;
}

/* Slices of at most CANCEL_SLICE_S, the host's check before each: a stop
 * request waits no longer than one slice for a wait to end. */
#define CANCEL_SLICE_S 0.05

int drv_modbus_sleep(drv_modbus_bus *bus, double seconds, const char *who,
                     struct gonio_err *err)
{
    double end = gonio_monotonic_s() + (seconds > 0 ? seconds : 0);
    for (;;) {
        if (bus->cancelled && bus->cancelled(bus->cancel_user))
            return gonio_err_set(err, ECANCELED, "%s: cancelled", who);
        double left = end - gonio_monotonic_s();
        if (!(left > 0))
            return 0;
        double slice = fmin(left, CANCEL_SLICE_S);
        struct timespec ts = {.tv_sec = 0, .tv_nsec = (long)(slice * 1e9)};
        while (nanosleep(&ts, &ts) < 0 && errno == EINTR)
            ;
    }
}

static const char *exception_name(int code)
{
    switch (code) {
    case MODBUS_EXCEPTION_ILLEGAL_FUNCTION: return "illegal function";
    case MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS: return "illegal data address";
    case MODBUS_EXCEPTION_ILLEGAL_DATA_VALUE: return "illegal data value";
    case MODBUS_EXCEPTION_SLAVE_OR_SERVER_FAILURE: return "slave device failure";
    case MODBUS_EXCEPTION_SLAVE_OR_SERVER_BUSY: return "slave device busy";
    default: return "exception";
    }
}

static void trace(const drv_modbus_bus *bus, int slave, int write, int addr, int n,
                  const uint16_t *regs, int rc, int e, double ms)
{
    fprintf(stderr, "modbus %s: slave %d %s 0x%04x+%d", bus->where, slave,
            write ? "write" : "read", (unsigned)addr, n);
    if (rc >= 0) {
        fputs(write ? " [" : " -> [", stderr);
        for (int i = 0; i < n && i < 16; i++)
            fprintf(stderr, "%s%04x", i ? " " : "", regs[i]);
        fprintf(stderr, "%s] %.2f ms\n", n > 16 ? " ..." : "", ms);
    } else {
        fprintf(stderr, " failed: %s (%.2f ms)\n", modbus_strerror(e), ms);
    }
}

/* Whatever went wrong (no answer, a garbled or foreign one), drop what
 * the line holds before trying again. A device that is merely slow
 * answers after the timeout, and the rest of a garbled frame may still be
 * on its way: wait for the line to stay quiet for a window (drain_s: by
 * default the timeout, at most 0.1 s), dropping whatever arrives, so that
 * a late answer is flushed rather than read as the answer to the next
 * request. Bounded: a line that never goes quiet gets the retry anyway. */
static void drain(drv_modbus_bus *bus)
{
    int window_ms = (int)ceil(1e3 * bus->drain_s);
    int fd = modbus_get_socket(bus->ctx);
    for (int i = 0; i < 10; i++) {
        struct pollfd p = {.fd = fd, .events = POLLIN};
        int r = fd >= 0 ? poll(&p, 1, window_ms) : 0;
        modbus_flush(bus->ctx);
        if (r <= 0)
            return;
    }
}

/* A TCP connection the peer closed or reset (a restarted device or
 * gateway, a dropped network), a serial port that hung up (an unplugged
 * adapter, a simulator's pseudo-terminal gone), or either left closed by a
 * failed reconnection: no retry on the same descriptor can succeed. */
static int connection_lost(const drv_modbus_bus *bus, int e)
{
    if (!bus->tcp)
        return e == EIO || e == ENXIO || e == ENODEV || e == EBADF;
    return e == ECONNRESET || e == EPIPE || e == ENOTCONN || e == ECONNREFUSED ||
           e == ECONNABORTED || e == EBADF;
}

/* Re-open the TCP connection (the serial port) after a pause that doubles with each
 * attempt of the request (0.05 s, 0.1 s, ... at most the response
 * timeout), so a device that is coming back is not hammered; a cancelled
 * host cuts the pause short, so that a stop still gets through. A failed
 * connect leaves the context closed: the next attempt fails at once with
 * EBADF and comes back here. */
static int reconnect(drv_modbus_bus *bus, int attempt)
{
    modbus_close(bus->ctx);
    drv_modbus_sleep(bus, fmin(0.05 * (double)(1 << attempt), bus->timeout_s), bus->where, NULL);
    bus->stats.reconnects++;
    if (modbus_connect(bus->ctx) == 0)
        return 0;
    int e = errno;
    if (bus->trace)
        fprintf(stderr, "modbus %s: reconnect failed: %s\n", bus->where, modbus_strerror(e));
    return e;
}

/* Why a request on a lost connection failed: how the connection was
 * lost (lost: its errno; 0 when it was found closed) and what the last
 * reconnection said (0: it succeeded). */
static int lost_error(const drv_modbus_bus *bus, int slave, const char *who, int lost,
                      int refused, struct gonio_err *err)
{
    const char *how = !bus->tcp && lost ? "the serial port hung up"
                      : lost == ECONNRESET || lost == EPIPE ? "the device closed the connection"
                      : lost == ECONNREFUSED ? "the device refused the connection"
                      : lost ? modbus_strerror(lost)
                             : "the connection was closed (an earlier reconnection failed)";
    if (refused)
        return gonio_err_set(err, GONIO_EDEVICE, "%s (slave %d) on %s: %s; reconnecting: %s "
                             "(%d attempts)", who, slave, bus->where, how,
                             modbus_strerror(refused), bus->retries + 1);
    return gonio_err_set(err, GONIO_EDEVICE, "%s (slave %d) on %s: %s (%d attempts)", who,
                         slave, bus->where, how, bus->retries + 1);
}

static int transact(drv_modbus_bus *bus, int slave, int write, int addr, int n, uint16_t *regs,
                    const char *who, struct gonio_err *err)
{
    int e = 0, lost = 0, refused = 0;
    bus->stats.requests++;
    bus->last_exception = 0;
    for (int attempt = 0; attempt <= bus->retries; attempt++) {
        if (attempt > 0)
            bus->stats.retries++;
        double t0 = gonio_monotonic_s();
        int rc = modbus_set_slave(bus->ctx, slave);
        if (rc == 0) {
            if (write && n == 1)
                rc = modbus_write_register(bus->ctx, addr, regs[0]) == 1 ? 1 : -1;
            else if (write)
                rc = modbus_write_registers(bus->ctx, addr, n, regs);
            else
                rc = modbus_read_registers(bus->ctx, addr, n, regs);
        }
        e = errno;
        double t1 = gonio_monotonic_s();
        if (bus->trace)
            trace(bus, slave, write, addr, n, regs, rc == n ? 0 : -1, e, 1e3 * (t1 - t0));
        if (rc == n) {
            note_exchange(bus, write, n, t0, t1);
            return 0;
        }
        /* An exception is the device's considered answer: no retry. */
        if (e > MODBUS_ENOBASE && e < EMBBADCRC) {
            bus->stats.exceptions++;
            bus->last_exception = e - MODBUS_ENOBASE;
            return gonio_err_set(err, GONIO_EDEVICE,
                                 "%s (slave %d): %s register 0x%04x (%d): exception %d (%s)",
                                 who, slave, write ? "writing" : "reading", (unsigned)addr, n,
                                 e - MODBUS_ENOBASE, exception_name(e - MODBUS_ENOBASE));
        }
        if (connection_lost(bus, e)) {
            if (e != EBADF)
                lost = e;
            refused = reconnect(bus, attempt);
            continue;
        }
        lost = refused = 0;
        if (e == ETIMEDOUT)
            bus->stats.timeouts++;
        else
            bus->stats.bad_replies++;
        drain(bus);
    }
    bus->stats.failed++;
    if (connection_lost(bus, e))
        return lost_error(bus, slave, who, lost, refused, err);
    if (e == ETIMEDOUT)
        return gonio_err_set(err, ETIMEDOUT,
                             "%s (slave %d) on %s: no answer within %g s (%d attempts)", who,
                             slave, bus->where, bus->timeout_s, bus->retries + 1);
    return gonio_err_set(err, GONIO_EDEVICE, "%s (slave %d) on %s: %s (%d attempts)", who, slave,
                         bus->where, modbus_strerror(e), bus->retries + 1);
}

int drv_modbus_read(drv_modbus_bus *bus, int slave, int addr, int n, uint16_t *out,
                    const char *who, struct gonio_err *err)
{
    return transact(bus, slave, 0, addr, n, out, who, err);
}

int drv_modbus_write(drv_modbus_bus *bus, int slave, int addr, int n, const uint16_t *regs,
                     const char *who, struct gonio_err *err)
{
    uint16_t copy[MODBUS_MAX_WRITE_REGISTERS];
    if (n < 1 || n > MODBUS_MAX_WRITE_REGISTERS)
        return gonio_err_set(err, EINVAL, "%s: %d registers in one write", who, n);
    memcpy(copy, regs, (size_t)n * sizeof *copy);
    return transact(bus, slave, 1, addr, n, copy, who, err);
}
