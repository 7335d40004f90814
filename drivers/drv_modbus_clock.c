/* The rig clock of a Modbus rig: a simulator's detector publishes its
 * simulated time (register 0x0A, ms), which is the rig's time; hardware
 * publishes 0 and the rig's time is wall time. Sleeps are wall sleeps
 * shortened by the bus's time scale, so an accelerated simulator does not
 * make the capture wait in wall time for what passes faster on the rig. */
#include <errno.h>
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

static double mb_now(void *priv)
{
    struct mb_clock *c = priv;
    double wall = gonio_monotonic_s();
    uint32_t ms;
    if (c->simulated && read_ms(c, &ms, NULL) == 0) {
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
    drv_clock *clk = drv_clock_alloc(&mb_clock_ops, c);
    if (!clk)
        gonio_err_set(err, ENOMEM, "modbus clock: out of memory");
    return clk;
}
