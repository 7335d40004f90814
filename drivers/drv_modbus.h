/* Constructors of the Modbus backend: the rig's drives and detector on one
 * Modbus RTU bus or one Modbus TCP endpoint, with the register map of
 * docs/protocol-modbus.md (gonio-sim serves the same map).
 *
 * A bus is opened once and shared by the devices on it; the devices keep a
 * pointer to it, so free the devices first, then the bus. Nothing here is
 * thread-safe: one thread drives one bus. The drivers assume they are the
 * bus's only master: an axis remembers where a completed move left it and
 * the detector its last sequence number, to save round trips.
 *
 * On TCP, a connection the peer closed or reset (a restarted device or
 * gateway, a network drop) is re-opened, after a pause doubling from
 * 0.05 s, and the request sent again; each reconnection is one of the
 * request's attempts below. So is a serial port that hung up (an adapter
 * unplugged, a restarted gonio-sim's pty behind its --link): the device
 * path is opened again. A request that still fails says how the
 * connection was lost ("the device closed the connection; reconnecting:
 * Connection refused (5 attempts)"). A write may thus reach a device twice: the
 * drivers' writes are stored values, triggers that restart the same
 * operation, or input edges, which bear it.
 *
 * Errors: a request that gets no answer within the response timeout is
 * retried up to `retries` times, then fails with -ETIMEDOUT; after each
 * failed attempt the bus drains the line until it stays quiet for the
 * timeout (at most 0.1 s), so a late answer is not taken for the next one,
 * and the axes read status and position with requests of different sizes,
 * so one that slips through fails the size check instead. An exception
 * answer, a stalled move, or a drive alarm or a miss of the in-position
 * band that the axis's tries could not recover (drivers.h) fails
 * with -GONIO_EDEVICE; the message names the device, the register and the
 * problem, e.g. "axis arm (slave 2): drive alarm 0x30 (overload)". */
#ifndef GONIO_DRIVERS_DRV_MODBUS_H
#define GONIO_DRIVERS_DRV_MODBUS_H

#include "common/err.h"
#include "drivers/drivers.h"
#include "rig/rig.h"

typedef struct drv_modbus_bus drv_modbus_bus;

struct drv_modbus_bus_cfg {
    /* RTU: serial device (e.g. /dev/ttyUSB0 or gonio-sim's pty); line settings. */
    const char *device;
    int baud;      /* 0: 115200 */
    char parity;   /* 'N', 'E', 'O'; 0: 'N' */
    int data_bits; /* 0: 8 */
    int stop_bits; /* 0: 1 */
    /* TCP: host (numeric IPv4) and port; used by drv_modbus_bus_new_tcp. */
    const char *host;
    int port;
    double timeout_s; /* response timeout per request; 0: 0.5 s */
    int retries;      /* extra attempts after a failed one (default 4: docs/torture.md) */
    /* After a failed exchange the line must stay quiet this long before the
     * next attempt, so that an answer later than the timeout is flushed
     * rather than taken for the next; 0: the timeout, at most 0.1 s. */
    double drain_s;
    /* Simulated time runs time_scale times faster than wall time (gonio-sim
     * --time-scale); the devices pace their polling and the clock its
     * sleeps by it. 0: 1 (hardware). */
    double time_scale;
    int trace; /* log every register transaction on stderr */
};

/* Fill cfg with the defaults above (all pointers NULL, retries 4). */
void drv_modbus_bus_cfg_default(struct drv_modbus_bus_cfg *cfg);

/* Open an RTU bus on cfg->device, or a TCP connection to cfg->host:port.
 * NULL with err filled on failure. */
drv_modbus_bus *drv_modbus_bus_new_rtu(const struct drv_modbus_bus_cfg *cfg,
                                       struct gonio_err *err);
drv_modbus_bus *drv_modbus_bus_new_tcp(const struct drv_modbus_bus_cfg *cfg,
                                       struct gonio_err *err);
void drv_modbus_bus_free(drv_modbus_bus *bus);
/* Switch the per-transaction trace (stderr) on or off. */
void drv_modbus_bus_set_trace(drv_modbus_bus *bus, int on);

/* The host's cancel check (NULL: none), asked with user at least every
 * 50 ms while the devices on the bus wait: for an integration, a move, a
 * settle or a poll. Once it returns non-zero, the wait under way and every
 * later one end at once and the call that waited fails with -ECANCELED,
 * naming the device ("detector: cancelled"); requests are still sent (a
 * stop goes through), but without the pauses before reconnecting. It is
 * asked from the thread driving the bus. */
void drv_modbus_bus_set_cancel(drv_modbus_bus *bus, int (*cancelled)(void *user), void *user);

/* What the bus has been through since it was opened: requests made,
 * attempts sent (requests + retries), and why attempts failed. A fault
 * soak reports these next to the faults the rig injected. */
struct drv_modbus_stats {
    long requests, retries;
    long timeouts;    /* no (complete) answer within the timeout */
    long bad_replies; /* a garbled, foreign or mismatched answer */
    long exceptions;  /* the device refused (not retried) */
    long failed;      /* requests that gave up after every attempt */
    long reconnects;  /* connections (serial ports) re-opened after they were lost */
};
void drv_modbus_bus_stats(const drv_modbus_bus *bus, struct drv_modbus_stats *out);

/* Axis options beyond the rig profile: the drive's steps and the rig's
 * mechanics (rig/rig.h struct rig_mechanics, docs/plans.md), as
 * drivers.h's struct drv_axis_mechanics takes them. */
struct drv_modbus_axis_opts {
    double steps_per_deg;   /* drive steps per degree; 0: 100 */
    double in_position_deg; /* 0: half a step */
    double backlash_deg;    /* 0: direct moves */
    int approach;           /* -1: from above; 0, +1: from below */
    int move_retries;
};

/* An axis drive at slave id `slave`, with the mechanics of drivers.h
 * (struct drv_axis_mechanics: the profile's min/max and opts). Moves use
 * the profile's speed and acceleration converted to steps, and go to whole
 * steps. opts may be NULL (defaults: no backlash, no retries). name
 * ("sample", "arm", "azimuth") appears in messages. The profile is copied.
 *
 * Waiting on a move sleeps until the leg's expected end, then polls the
 * drive's status (the alarm code in the same read); the encoder's feedback
 * is read at once only for a drive resting without IN-POS, else when the
 * position is asked for (drivers.h). The rest is dated by the status read
 * (drv_axis_rested). A leg with no progress for 0.5 s of rig time and no
 * alarm is a stall. drv_axis_home raises ZHOME and waits for HOME-END.
 * docs/protocol-modbus.md, "Mechanics" (its bus cost per move), says what each costs. */
drv_axis *drv_axis_new_modbus(drv_modbus_bus *bus, int slave, const struct rig_axis *profile,
                              const struct drv_modbus_axis_opts *opts, const char *name,
                              struct gonio_err *err);

/* The detector at slave id `slave`. An acquisition whose reads show the
 * sequence or clock register gone back (a restarted device) fails with
 * -GONIO_EDEVICE, "detector (slave 3): the device restarted ...". */
drv_detector *drv_detector_new_modbus(drv_modbus_bus *bus, int slave, struct gonio_err *err);

/* The detector at slave id `slave` asked what it is without integrating
 * (goniod --check --probe): its status bits and channel count. */
int drv_modbus_detector_probe(drv_modbus_bus *bus, int slave, unsigned *status, int *channels,
                              struct gonio_err *err);

/* The detector's shutter register read (goniod --check --probe, on a rig
 * profile with a shutter): *closed 1 when it reads closed. A detector
 * without the register (exception 02): -ENOTSUP naming it. */
int drv_modbus_detector_probe_shutter(drv_modbus_bus *bus, int slave, int *closed,
                                      struct gonio_err *err);

/* What the detector at slave id `slave` reports, asked at open without
 * integrating: *counts 1 when its status says RAW (it gives counts, which
 * a calibration must turn into BRDF: docs/protocol-modbus.md, "Raw
 * mode"), 0 when it reports BRDF. */
int drv_modbus_detector_counts(drv_modbus_bus *bus, int slave, int *counts,
                               struct gonio_err *err);

/* The sample changer at slave id `slave`: put slot (MB_CH_SLOT_SAMPLE,
 * _STANDARD, _TRAP) in the sample's place and wait until it is there;
 * nothing is written when it is there already. -GONIO_EDEVICE when it is
 * not within 120 s. */
int drv_modbus_changer_set(drv_modbus_bus *bus, int slave, int slot, struct gonio_err *err);

/* What the changer at slave id `slave` says: its status bits (MB_CH_BUSY,
 * MB_CH_IN_POS) and the slot in place. */
int drv_modbus_changer_read(drv_modbus_bus *bus, int slave, unsigned *status, int *slot,
                            struct gonio_err *err);

/* The rig clock: seconds since the clock was created, read from the
 * detector's rig-clock register when it is non-zero (a simulator), else
 * wall time; monotonic across late answers and restarts of the device
 * (docs/protocol-modbus.md, "The rig clock"; drv_clock_stats counts
 * them). Sleeping waits seconds / time_scale of wall time (bus cfg).
 * A simulator's clock whose measured rate is not the bus's time_scale
 * (beyond a factor 1.5) is refused: NULL, GONIO_EBADCONFIG naming both. */
drv_clock *drv_clock_new_modbus(drv_modbus_bus *bus, int detector_slave, struct gonio_err *err);

#endif
