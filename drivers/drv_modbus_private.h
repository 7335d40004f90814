/* Inside the Modbus backend: register transactions on a bus, shared by the
 * axis, detector and clock files. Only drv_modbus_bus.c sees libmodbus. */
#ifndef GONIO_DRIVERS_DRV_MODBUS_PRIVATE_H
#define GONIO_DRIVERS_DRV_MODBUS_PRIVATE_H

#include <stdint.h>

#include "common/clock.h"
#include "drivers/drv_modbus.h"
#include "modbus_map/modbus_map.h"

/* Read or write n holding registers at addr of slave, with the bus's
 * timeout and retries. who names the device in messages ("axis arm"). */
int drv_modbus_read(drv_modbus_bus *bus, int slave, int addr, int n, uint16_t *out,
                    const char *who, struct gonio_err *err);
int drv_modbus_write(drv_modbus_bus *bus, int slave, int addr, int n, const uint16_t *regs,
                     const char *who, struct gonio_err *err);
/* A raw reading's channels as the detector's state read gave them, and
 * what the driver knows of it, for drv_modbus_read_raw. */
struct mb_raw_channels {
    uint32_t counts[3];
    uint32_t seq;       /* the reading's sequence number */
    int shutter_closed; /* as the driver last set it */
    int saturated;      /* the status said SATURATED */
};

/* Read the detector's raw block (docs/protocol-modbus.md, "Raw mode") and
 * fill out with the counts and what the block states (unit, full scale,
 * nonlinearity, monitor, gain state, flags). A block out of range (of
 * another reading, counts above its full scale, a nonlinearity outside
 * 0..0.5, a shutter not where it was put) is refused with -GONIO_EDEVICE
 * naming the register and its value. */
int drv_modbus_read_raw(drv_modbus_bus *bus, int slave, const char *who,
                        const struct mb_raw_channels *ch, struct drv_reading *out,
                        struct gonio_err *err);

/* A spectral detector's band block (docs/protocol-modbus.md, "Band
 * block"), for a raw reading whose status says BANDS: the count and
 * centres read at the first, then the band counts of each.
 * drv_modbus_read_bands reads those of reading seq into out (after
 * drv_modbus_read_raw: its full scale bounds them), checked. The counts
 * stay valid until the next reading. */
struct mb_bands {
    int probed, n;
    double nm[MB_DET_MAX_BANDS], counts[MB_DET_MAX_BANDS];
};
int drv_modbus_read_bands(drv_modbus_bus *bus, int slave, const char *who, struct mb_bands *b,
                          uint32_t seq, struct drv_reading *out, struct gonio_err *err);

/* The exception code the device answered the last read or write with (2:
 * no such register), 0 when it answered normally or not at all. */
int drv_modbus_last_exception(const drv_modbus_bus *bus);

/* When the device acted on the bus's last answered request (took the
 * registers it read, carried out the write), wall seconds
 * (gonio_monotonic_s): no earlier than *lo, no later than *hi. On a
 * serial line every frame takes at least its characters' time at the
 * baud: the request had to arrive whole (lo: sent plus its time) and the
 * answer to travel (hi: answered less its time). On TCP, and on a line
 * that once answered sooner than its frames could travel (a
 * pseudo-terminal, a simulator charging no line time), the frames bound
 * nothing: the send and answer times themselves. */
void drv_modbus_acted(const drv_modbus_bus *bus, double *lo, double *hi);
/* The least wall time a request (a read or write of n registers) takes
 * on the line before its device can act on it, as drv_modbus_acted counts
 * it (0 where frames bound nothing). */
double drv_modbus_request_s(const drv_modbus_bus *bus, int write, int n);
/* The silence that ends a frame on the line (t3.5), wall seconds; 0 where
 * frames bound nothing. A device that waits for it before acting on a
 * request, and leaves it before answering, acts that much after
 * drv_modbus_acted's lo and before its hi: what the drivers expect when
 * they time their polls, never what they count on. */
double drv_modbus_gap_s(const drv_modbus_bus *bus);

/* Failed attempts on the bus so far (no answer, a bad one, a lost
 * connection). A device may have restarted across any of them and lost
 * what the drivers stored on it: they store it again when this changed. */
long drv_modbus_faults(const drv_modbus_bus *bus);

/* Simulated seconds per wall second on this bus (1 on hardware). */
double drv_modbus_time_scale(const drv_modbus_bus *bus);
/* The rig's clock is simulated (gonio-sim --clock simulated, the
 * detector's status bit MB_DET_CLOCK_SIMULATED): it advances only by what
 * the simulator models, and a poll for a move's or an integration's end
 * finds it ended. The devices then wait for nothing in wall time before
 * they look, and count rig time from the clock and the line's model, never
 * from wall time. Set by the rig clock (drv_clock_new_modbus) when it sees
 * the bit; line_timed when the simulator charges the line's frames too
 * (MB_DET_LINE_TIMED: at the bus's baud, which must then be the
 * simulator's), else the line's rig time below is 0. */
void drv_modbus_set_simulated_clock(drv_modbus_bus *bus, int line_timed);
int drv_modbus_simulated_clock(const drv_modbus_bus *bus);
/* The line's time in rig seconds at the configured rate (RTU frames and
 * their silences; 0 on TCP), summed over the answered exchanges so far:
 * up to when the last one's device acted (*acted), and in all (*total). A
 * simulated clock counts this time; the drivers date what they saw on it
 * by these sums. */
void drv_modbus_line_rig(const drv_modbus_bus *bus, double *acted, double *total);
/* Put the sums back to what drv_modbus_line_rig said: the exchanges since
 * took no line time (a simulated clock's wait, which is the master's
 * sleep, not the rig's traffic). */
void drv_modbus_line_rig_restore(drv_modbus_bus *bus, double acted, double total);
/* A request's line time in rig seconds at the configured rate. */
double drv_modbus_request_rig_s(const drv_modbus_bus *bus, int write, int n);
/* The response timeout, wall seconds. */
double drv_modbus_timeout(const drv_modbus_bus *bus);

/* The detector's rig-clock register (MB_DET_CLOCK) of slave as the
 * detector read it along with its reading, in the bus's last answered
 * exchange: the clock (drv_modbus_clock.c) takes it instead of reading the
 * register again while it is the bus's latest exchange.
 * drv_modbus_last_clock returns 1, the reading and when the device took it
 * (drv_modbus_acted's lo and hi, wall seconds) then, else 0. */
void drv_modbus_note_clock(drv_modbus_bus *bus, int slave, uint32_t ms);
int drv_modbus_last_clock(const drv_modbus_bus *bus, int slave, uint32_t *ms, double *lo,
                          double *hi);

/* Sleep, wall seconds (time is read with gonio_monotonic_s, common/clock.h),
 * asking the bus's cancel check (drv_modbus_bus_set_cancel) at the start
 * and every 50 ms: 0 when the time passed, -ECANCELED ("WHO: cancelled")
 * as soon as the check says so. */
int drv_modbus_sleep(drv_modbus_bus *bus, double seconds, const char *who,
                     struct gonio_err *err);

/* 32-bit values and floats: the register map's codec (upper word first),
 * under the drivers' names. */
static inline uint32_t drv_modbus_get32(const uint16_t *r)
{
    return mb_get32(r);
}

static inline void drv_modbus_put32(uint16_t *r, uint32_t v)
{
    mb_put32(r, v);
}

static inline float drv_modbus_get_float(const uint16_t *r)
{
    return mb_get_float(r);
}

static inline void drv_modbus_put_float(uint16_t *r, float f)
{
    mb_put_float(r, f);
}

#endif
