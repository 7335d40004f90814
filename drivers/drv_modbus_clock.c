/* The rig clock of a Modbus rig: a simulator's detector publishes its
 * simulated time (register 0x0A, ms), which is the rig's time; hardware
 * publishes 0 and the rig's time is wall time. Sleeps are wall sleeps
 * shortened by the bus's time scale, so an accelerated simulator does not
 * make the capture wait in wall time for what passes faster on the rig.
 * That only holds when the bus's time scale is the simulator's: the clock
 * measures the simulator's rate when it is created and refuses another.
 * A simulator whose clock is simulated (status bit MB_DET_CLOCK_SIMULATED)
 * has no rate: its register is the rig time, carried forward by nothing,
 * and a sleep is a write of the wait register, which lets that much rig
 * time pass on the device at once. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "drivers/drivers_private.h"
#include "drivers/drv_modbus_private.h"

enum { R_STATUS = MB_DET_STATUS, R_CLOCK = MB_DET_CLOCK, R_WAIT = MB_DET_WAIT };

/* The rig time is kept as the last register reading taken (ms), the rig
 * seconds it stands for (rig) and the wall time by which the device had
 * surely taken it (wall: the answer's arrival less its line time), so the
 * time carried forward from it is never ahead of the device's. */
struct mb_clock {
    drv_modbus_bus *bus;
    int slave;
    int simulated; /* 0 hardware (wall time), 1 a simulator on wall time, 2 a simulated clock */
    double wall0;  /* wall time at creation (hardware) */
    uint32_t ms;   /* last register reading */
    double rig;    /* rig seconds it stands for */
    double wall;   /* wall time it was taken by */
    double wall_lo; /* and no sooner than */
    double last;   /* last rig time returned: the clamp */
    struct drv_clock_stats stats;
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
        if ((rc = drv_modbus_sleep(c->bus, wait, "detector clock", err)) < 0)
            break;
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

/* Warnings on stderr stop after this many of each kind; the counts go on
 * (drv_clock_stats). */
#define WARN_MAX 5

/* Take a register reading ms the device took between wall times lo and
 * hi. Forward, it advances the rig time by the difference modulo 2^32 (a
 * wrap after 49.7 days is forward), as far as the device's clock can have
 * run since the previous reading (its rate within the tolerance, and a
 * millisecond each for the rounding). Beyond that, or back, the register
 * started again: the device restarted, and the rig time carries on from
 * the previous reading by the wall time that surely passed since. */
static void take_reading(struct mb_clock *c, uint32_t ms, double lo, double hi)
{
    double scale = drv_modbus_time_scale(c->bus);
    uint32_t fwd = ms - c->ms;
    /* A simulated clock may jump by a whole move between readings (and
     * no wall time passes on it): forward is half the register's range. */
    double most = c->simulated > 1 ? 2147483.647
                                   : fmax(hi - c->wall_lo, 0) * scale * RATE_TOLERANCE + 2e-3;
    if (fwd * 1e-3 <= most) {
        c->rig += fwd * 1e-3;
    } else {
        c->stats.restarts++;
        if (c->simulated < 2)
            c->rig += fmax(lo - c->wall, 0) * scale;
        if (c->stats.restarts <= WARN_MAX)
            fprintf(stderr, "warning: detector clock (slave %d): the register went from %u to "
                    "%u ms: the device restarted; the rig time carries on at %.3f s\n",
                    c->slave, c->ms, ms, c->rig);
    }
    c->ms = ms;
    c->wall = hi;
    c->wall_lo = lo;
}

/* The rig time now: carried forward from the latest reading of the
 * register. The detector's read along with its reading serves while it is
 * the bus's latest exchange (nothing happened on the rig since that the
 * register would show otherwise); else the register is read. A reading is
 * carried forward from when the device had surely taken it (the answer's
 * arrival, less its line time), never from when it was asked for: a late
 * answer then never puts the rig time ahead of the device's. A rig time
 * that would still go back (a device whose clock runs slower than the
 * bus's time scale) is held at the last one returned, and counted. */
static double mb_now(void *priv)
{
    struct mb_clock *c = priv;
    if (!c->simulated)
        return c->last = fmax(c->last, gonio_monotonic_s() - c->wall0);
    double lo, hi;
    uint32_t ms;
    if (drv_modbus_last_clock(c->bus, c->slave, &ms, &lo, &hi)) {
        take_reading(c, ms, lo, hi);
    } else if (read_ms(c, &ms, NULL) == 0) {
        drv_modbus_acted(c->bus, &lo, &hi);
        take_reading(c, ms, lo, hi);
    } /* else the bus failed: carry the last reading forward */
    double now = c->rig;
    if (c->simulated < 2) /* a wall clock's time ran on since the reading */
        now += (gonio_monotonic_s() - c->wall) * drv_modbus_time_scale(c->bus);
    if (now < c->last - 1e-3) {
        c->stats.backward++;
        if (c->stats.backward <= WARN_MAX)
            fprintf(stderr, "warning: detector clock (slave %d): the rig time would go back "
                    "%.3f s, from %.3f s; held\n", c->slave, c->last - now, c->last);
    }
    return c->last = fmax(c->last, now);
}

static void mb_stats(const void *priv, struct drv_clock_stats *out)
{
    const struct mb_clock *c = priv;
    *out = c->stats;
}

/* The wait register takes whole microseconds, 32 bits of them: a longer
 * wait is several writes. */
#define WAIT_MAX_US 4000000000.0

static int mb_sleep(void *priv, double seconds)
{
    struct mb_clock *c = priv;
    if (c->simulated < 2)
        return drv_modbus_sleep(c->bus, seconds / drv_modbus_time_scale(c->bus), "settle", NULL);
    double us = nearbyint(seconds * 1e6), acted, total;
    int rc = drv_modbus_sleep(c->bus, 0, "settle", NULL); /* the cancel check */
    drv_modbus_line_rig(c->bus, &acted, &total);
    while (rc == 0 && us > 0) {
        double part = fmin(us, WAIT_MAX_US);
        uint16_t r[2];
        drv_modbus_put32(r, (uint32_t)part);
        rc = drv_modbus_write(c->bus, c->slave, R_WAIT, 2, r, "detector clock", NULL);
        us -= part;
    }
    drv_modbus_line_rig_restore(c->bus, acted, total); /* the wait's frames take no line time */
    return rc;
}

static const struct drv_clock_ops mb_clock_ops = {
    .name = "modbus",
    .now = mb_now,
    .sleep = mb_sleep,
    .stats = mb_stats,
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
    c->wall0 = gonio_monotonic_s();
    /* Status to clock in one read: whether the clock is simulated, and
     * the register. */
    uint16_t r[R_CLOCK + 2 - R_STATUS] = {0};
    int rc = drv_modbus_read(bus, detector_slave, R_STATUS, R_CLOCK + 2 - R_STATUS, r,
                             "detector clock", err);
    c->ms = drv_modbus_get32(r + (R_CLOCK - R_STATUS));
    uint32_t st = drv_modbus_get32(r);
    if (rc == 0 && (st & MB_DET_CLOCK_SIMULATED)) {
        c->simulated = 2;
        drv_modbus_set_simulated_clock(bus, (st & MB_DET_LINE_TIMED) != 0);
    } else if (rc == 0 && c->ms == 0) { /* a simulator that just started reads 0 too */
        drv_modbus_sleep(bus, 0.005, "detector clock", NULL);
        rc = read_ms(c, &c->ms, err);
    }
    if (rc < 0) {
        free(c);
        return NULL;
    }
    drv_modbus_acted(bus, &c->wall_lo, &c->wall);
    if (!c->simulated)
        c->simulated = c->ms != 0;
    if (c->simulated == 1 && (rc = check_rate(c, err)) < 0) {
        free(c);
        return NULL;
    }
    drv_clock *clk = drv_clock_alloc(&mb_clock_ops, c);
    if (!clk)
        gonio_err_set(err, ENOMEM, "modbus clock: out of memory");
    return clk;
}
