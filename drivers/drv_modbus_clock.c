/* The rig clock of a Modbus rig: a simulator's detector publishes its
 * simulated time (register 0x0A, ms), which is the rig's time; hardware
 * publishes 0 and the rig's time is wall time. Sleeps are wall sleeps
 * shortened by the bus's time scale, so an accelerated simulator does not
 * make the capture wait in wall time for what passes faster on the rig.
 * That only holds when the bus's time scale is the simulator's: the clock
 * measures the simulator's rate when it is created and refuses another. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>

#include "drivers/drivers_private.h"
#include "drivers/drv_modbus_private.h"

enum { R_CLOCK = MB_DET_CLOCK }; /* modbus_map/modbus_map.h */

struct mb_clock {
    drv_modbus_bus *bus;
    int slave;
    int simulated;
    uint32_t ms0;             /* rig clock register at creation */
    double wall0;             /* wall time at creation */
    double last, last_wall;   /* last rig time read, and when */
};

static int read_ms(struct mb_clock *c, uint32_t *ms, struct gonio_err *err)
{
    uint16_t r[2];
    int rc = drv_modbus_read(c->bus, c->slave, R_CLOCK, 2, r, "detector clock", err);
    *ms = drv_modbus_get32(r);
    return rc;
}

/* How far the simulator's rate may be from the bus's time scale (a factor),
 * and how long the measurement may take before it gives the benefit of the
 * doubt (a machine too loaded to tell). */
#define RATE_TOLERANCE 1.5
#define RATE_MAX_S 1.0

/* Measure the simulator's rig-clock rate against wall time. Each reading's
 * wall time is bracketed by its request's start and end, and the register
 * is rounded to 1 ms, so [lo, hi] surely holds the true rate; the waits
 * double until that interval lies inside the tolerance (fine), wholly
 * outside it (a mismatch: an error naming both scales), or RATE_MAX_S. */
static int check_rate(struct mb_clock *c, struct gonio_err *err)
{
    double scale = drv_modbus_time_scale(c->bus), wait = 0.01;
    uint32_t ms0, ms;
    double a0 = gonio_monotonic_s();
    int rc = read_ms(c, &ms0, err);
    double a1 = gonio_monotonic_s();
    while (rc == 0) {
        drv_modbus_sleep(wait);
        wait *= 2;
        double b0 = gonio_monotonic_s();
        if ((rc = read_ms(c, &ms, err)) < 0)
            break;
        double b1 = gonio_monotonic_s();
        double d = (uint32_t)(ms - ms0) * 1e-3;
        double lo = (d - 1e-3) / (b1 - a0), hi = b0 > a1 ? (d + 1e-3) / (b0 - a1) : INFINITY;
        if (hi < scale / RATE_TOLERANCE || lo > scale * RATE_TOLERANCE)
            return gonio_err_set(err, GONIO_EBADCONFIG,
                                 "detector clock (slave %d): the simulator's rig clock runs at "
                                 "%.3g x wall time, the driver's time_scale is %g; set "
                                 "time_scale to the simulator's --time-scale",
                                 c->slave, d / (0.5 * (b0 + b1) - 0.5 * (a0 + a1)), scale);
        if ((lo >= scale / RATE_TOLERANCE && hi <= scale * RATE_TOLERANCE) ||
            b1 - a0 > RATE_MAX_S)
            break;
    }
    return rc;
}

/* The rig time now: the detector's reading of the clock when it is the
 * bus's latest exchange (nothing happened on the rig since that the
 * register would show otherwise), carried forward from when its request
 * was sent (at most that request's frame time over: never flattering);
 * else a read of the register. */
static double mb_now(void *priv)
{
    struct mb_clock *c = priv;
    double wall = gonio_monotonic_s(), seen;
    uint32_t ms;
    if (c->simulated && drv_modbus_last_clock(c->bus, c->slave, &ms, &seen)) {
        c->last = (uint32_t)(ms - c->ms0) * 1e-3 + (wall - seen) * drv_modbus_time_scale(c->bus);
        c->last_wall = wall;
    } else if (c->simulated && read_ms(c, &ms, NULL) == 0) {
        c->last = (uint32_t)(ms - c->ms0) * 1e-3; /* unsigned: survives a wrap */
        c->last_wall = wall;
    } else if (c->simulated) { /* the bus failed: extrapolate */
        return c->last + (wall - c->last_wall) * drv_modbus_time_scale(c->bus);
    } else {
        c->last = wall - c->wall0;
    }
    return c->last;
}

static int mb_sleep(void *priv, double seconds)
{
    struct mb_clock *c = priv;
    drv_modbus_sleep(seconds / drv_modbus_time_scale(c->bus));
    return 0;
}

static const struct drv_clock_ops mb_clock_ops = {
    .name = "modbus",
    .now = mb_now,
    .sleep = mb_sleep,
    .free_priv = free,
};

drv_clock *drv_clock_new_modbus(drv_modbus_bus *bus, int detector_slave, struct gonio_err *err)
{
    if (!bus || detector_slave < 1 || detector_slave > 247) {
        gonio_err_set(err, EINVAL, "modbus clock: detector slave %d", detector_slave);
        return NULL;
    }
    struct mb_clock *c = calloc(1, sizeof *c);
    if (!c) {
        gonio_err_set(err, ENOMEM, "modbus clock: out of memory");
        return NULL;
    }
    c->bus = bus;
    c->slave = detector_slave;
    c->wall0 = c->last_wall = gonio_monotonic_s();
    int rc = read_ms(c, &c->ms0, err);
    if (rc == 0 && c->ms0 == 0) { /* a simulator that just started reads 0 too */
        drv_modbus_sleep(0.005);
        rc = read_ms(c, &c->ms0, err);
    }
    if (rc < 0) {
        free(c);
        return NULL;
    }
    c->simulated = c->ms0 != 0;
    if (c->simulated && (rc = check_rate(c, err)) < 0) {
        free(c);
        return NULL;
    }
    drv_clock *clk = drv_clock_alloc(&mb_clock_ops, c);
    if (!clk)
        gonio_err_set(err, ENOMEM, "modbus clock: out of memory");
    return clk;
}
