/* The detector slave (docs/protocol-modbus.md): write the integration
 * time (when the detector does not hold it already) and the trigger, wait
 * out the integration, read until READY with a sequence number the
 * trigger did not start from: the read that sees it holds the channels and
 * the rig clock too. A raw reading (status RAW) takes one read more, of the
 * raw block (drivers/drv_modbus_raw.c). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "drivers/drivers_private.h"
#include "drivers/drv_modbus_private.h"

/* The register map (modbus_map/modbus_map.h) under this file's names. */
enum { R_INTEGRATION = MB_DET_INTEGRATION, R_TRIGGER = MB_DET_TRIGGER, R_STATUS = MB_DET_STATUS,
       R_COUNT = MB_DET_COUNT, R_SEQUENCE = MB_DET_SEQUENCE, R_CLOCK = MB_DET_CLOCK,
       R_CHANNELS = MB_DET_CHANNELS, R_NREGS = MB_DET_CHANNELS + 6 };
enum { ST_BUSY = MB_DET_BUSY, ST_READY = MB_DET_READY, ST_SATURATED = MB_DET_SATURATED,
       ST_RAW = MB_DET_RAW, ST_BANDS = MB_DET_BANDS };

struct mb_detector {
    drv_modbus_bus *bus;
    int slave;
    char who[32];
    /* After our last reading, no read before the next: its sequence, and
     * the integration register as it read back. */
    int seq_known;
    uint32_t seq, used_us;
    long faults; /* drv_modbus_faults then: a device may restart across one */
    /* The sequence and clock registers as the last read saw them (seen):
     * a device that restarted shows them gone back. */
    int seen;
    uint32_t seen_seq, seen_clock;
    /* The shutter as last asked (1 closed), and drv_modbus_faults then: a
     * device that may have restarted since is told again. */
    int shutter_closed;
    long shutter_faults;
    struct mb_bands bands; /* a spectral detector's */
};

/* Integration, trigger, status, channel count, sequence, rig clock and
 * the RGB channels: registers 0x00-0x11 in one read, 18 registers, a size
 * no other request of the bus has (drv_modbus_axis.c: a late answer then
 * fails the size check). The integration reads back what the detector
 * used (an auto-exposing detector may choose its own); the clock is noted
 * on the bus, so that the rig clock need not read it again. */
struct det_state {
    uint32_t st, count, seq, used_us;
    double rgb[3];
    uint32_t counts[3]; /* the same registers as uint32: a raw reading's */
};

static int read_state(struct mb_detector *d, struct det_state *s, struct gonio_err *err)
{
    uint16_t r[R_NREGS];
    int rc = drv_modbus_read(d->bus, d->slave, R_INTEGRATION, R_NREGS, r, d->who, err);
    if (rc < 0)
        return rc;
    s->used_us = drv_modbus_get32(r);
    s->st = drv_modbus_get32(r + R_STATUS);
    s->count = drv_modbus_get32(r + R_COUNT);
    s->seq = drv_modbus_get32(r + R_SEQUENCE);
    for (int k = 0; k < 3; k++) {
        s->rgb[k] = drv_modbus_get_float(r + R_CHANNELS + 2 * k);
        s->counts[k] = drv_modbus_get32(r + R_CHANNELS + 2 * k);
    }
    uint32_t clock = drv_modbus_get32(r + R_CLOCK);
    drv_modbus_note_clock(d->bus, d->slave, clock);
    /* Differences modulo 2^32: a wrap is forward, a restart back. */
    int restarted = d->seen && ((int32_t)(s->seq - d->seen_seq) < 0 ||
                                (clock && (int32_t)(clock - d->seen_clock) < 0));
    uint32_t seq_was = d->seen_seq, clock_was = d->seen_clock;
    d->seen = 1;
    d->seen_seq = s->seq;
    d->seen_clock = clock;
    if (restarted) {
        d->seq_known = 0;
        return gonio_err_set(err, GONIO_EDEVICE,
                             "%s (slave %d): the device restarted (sequence %u after %u, clock "
                             "%.3f s after %.3f s): the reading and the axes' positions since "
                             "are in doubt; measure the point again", d->who, d->slave, s->seq,
                             seq_was, clock * 1e-3, clock_was * 1e-3);
    }
    return 0;
}

/* A reading accepted: the next trigger need not read the state first. */
static int reading_taken(struct mb_detector *d, const struct det_state *s,
                         struct drv_reading *out)
{
    d->seq_known = 1;
    d->faults = drv_modbus_faults(d->bus);
    d->seq = s->seq;
    d->used_us = s->used_us;
    out->integration_s = s->used_us * 1e-6;
    return 0;
}

/* The shutter register: 1 closed, 0 open. A detector without one answers
 * exception 02 (no such register): -ENOTSUP, as drivers.h says. */
static int write_shutter(struct mb_detector *d, int closed, struct gonio_err *err)
{
    uint16_t w[2];
    drv_modbus_put32(w, (uint32_t)closed);
    long faults = drv_modbus_faults(d->bus);
    int rc = drv_modbus_write(d->bus, d->slave, MB_DET_SHUTTER, 2, w, d->who, err);
    if (rc < 0 && drv_modbus_last_exception(d->bus) == 2)
        return gonio_err_set(err, ENOTSUP, "%s (slave %d) has no shutter (register 0x%04x: "
                             "exception 02): cover it instead", d->who, d->slave,
                             (unsigned)MB_DET_SHUTTER);
    if (rc < 0)
        return rc;
    d->shutter_closed = closed;
    d->shutter_faults = faults;
    return 0;
}

static int mb_shutter(void *priv, int closed, struct gonio_err *err)
{
    return write_shutter(priv, closed != 0, err);
}

static int mb_acquire(void *priv, double integration_s, struct drv_reading *out,
                      struct gonio_err *err)
{
    struct mb_detector *d = priv;
    double us = nearbyint(integration_s * 1e6);
    if (!(us >= 0) || us > 4294967295.0)
        return gonio_err_set(err, EINVAL, "%s: integration time %g s", d->who, integration_s);
    struct det_state s = {.count = 3, .seq = d->seq, .used_us = d->used_us};
    int known = d->seq_known && d->faults == drv_modbus_faults(d->bus);
    int rc = known ? 0 : read_state(d, &s, err);
    if (rc == 0 && d->shutter_closed && d->shutter_faults != drv_modbus_faults(d->bus))
        rc = write_shutter(d, 1, err);
    if (rc < 0)
        return rc;
    uint32_t seq0 = s.seq;
    d->seq_known = 0;
    if (s.count < 3 || s.count > 64)
        return gonio_err_set(err, GONIO_EDEVICE, "%s (slave %d): %u channels, expected RGB (3)",
                             d->who, d->slave, s.count);
    /* The integration register holds what the last integration used: when
     * that is the time wanted, the trigger alone (its lower register, one
     * FC 0x06 write: the upper one reads 0) starts the next. */
    uint16_t w[4];
    drv_modbus_put32(w, (uint32_t)us);
    drv_modbus_put32(w + 2, 1);
    double scale = drv_modbus_time_scale(d->bus);
    rc = s.used_us == (uint32_t)us
             ? drv_modbus_write(d->bus, d->slave, R_TRIGGER + 1, 1, w + 3, d->who, err)
             : drv_modbus_write(d->bus, d->slave, R_INTEGRATION, 4, w, d->who, err);
    if (rc < 0)
        return rc;
    /* The integration started when the detector took the trigger, likely
     * a frame's silence before it answered (drv_modbus_gap_s): the first
     * read, sent to reach the detector the integration after that,
     * normally sees READY. */
    double t0 = gonio_monotonic_s(), lo, hi, gap = drv_modbus_gap_s(d->bus);
    drv_modbus_acted(d->bus, &lo, &hi);
    double started = fmax(lo, hi - gap);
    double deadline = t0 + (1.5 * integration_s + 2.0) / scale + 0.5 + 4 * drv_modbus_timeout(d->bus);
    double poll = fmin(fmax(0.01 / scale, 0.0002), 0.01);
    if (!drv_modbus_simulated_clock(d->bus)) /* else the read finds the integration ended */
        rc = drv_modbus_sleep(d->bus, started + integration_s / scale -
                                          drv_modbus_request_s(d->bus, 0, R_NREGS) - gap -
                                          gonio_monotonic_s(), d->who, err);
    while (rc == 0) {
        if ((rc = read_state(d, &s, err)) < 0)
            return rc;
        if ((s.st & ST_READY) && !(s.st & ST_BUSY) && s.seq != seq0)
            break;
        if (gonio_monotonic_s() > deadline)
            return gonio_err_set(err, GONIO_EDEVICE,
                                 "%s (slave %d): no fresh reading %.3g s after the trigger "
                                 "(status 0x%x, sequence %u)", d->who, d->slave,
                                 gonio_monotonic_s() - t0, s.st, s.seq);
        rc = drv_modbus_sleep(d->bus, poll, d->who, err);
    }
    if (rc < 0)
        return rc;
    if (s.st & ST_RAW) {
        struct mb_raw_channels raw = {.seq = s.seq, .shutter_closed = d->shutter_closed,
                                      .saturated = (s.st & ST_SATURATED) != 0};
        memcpy(raw.counts, s.counts, sizeof raw.counts);
        if ((rc = drv_modbus_read_raw(d->bus, d->slave, d->who, &raw, out, err)) < 0 ||
            ((s.st & ST_BANDS) && (rc = drv_modbus_read_bands(d->bus, d->slave, d->who,
                                                              &d->bands, s.seq, out, err)) < 0))
            return rc;
        return reading_taken(d, &s, out);
    }
    for (int k = 0; k < 3; k++) {
        out->rgb[k] = s.rgb[k];
        /* A NaN or infinite reading would be journalled and fitted as a
         * sample: it is a device fault. */
        if (!isfinite(out->rgb[k]))
            return gonio_err_set(err, GONIO_EDEVICE, "%s (slave %d): channel %c reads %g",
                                 d->who, d->slave, "RGB"[k], out->rgb[k]);
    }
    out->flags = (s.st & ST_SATURATED) ? DRV_READING_SATURATED : 0;
    return reading_taken(d, &s, out);
}

/* The trigger's shortest write (FC 0x06) reaches the detector no sooner
 * than its frame takes on the line. */
static double mb_lag(const void *priv)
{
    const struct mb_detector *d = priv;
    if (drv_modbus_simulated_clock(d->bus)) /* the line's rig time, as the simulator charges it */
        return drv_modbus_request_rig_s(d->bus, 1, 1);
    return drv_modbus_request_s(d->bus, 1, 1) * drv_modbus_time_scale(d->bus);
}

static const struct drv_detector_ops mb_detector_ops = {
    .name = "modbus",
    .acquire = mb_acquire,
    .shutter = mb_shutter,
    .lag = mb_lag,
    .free_priv = free,
};

drv_detector *drv_detector_new_modbus(drv_modbus_bus *bus, int slave, struct gonio_err *err)
{
    if (!bus || slave < 1 || slave > 247) {
        gonio_err_set(err, EINVAL, "modbus detector: slave %d", slave);
        return NULL;
    }
    struct mb_detector *d = calloc(1, sizeof *d);
    if (!d) {
        gonio_err_set(err, ENOMEM, "modbus detector: out of memory");
        return NULL;
    }
    d->bus = bus;
    d->slave = slave;
    snprintf(d->who, sizeof d->who, "detector");
    drv_detector *det = drv_detector_alloc(&mb_detector_ops, d);
    if (!det)
        gonio_err_set(err, ENOMEM, "modbus detector: out of memory");
    return det;
}

int drv_modbus_detector_counts(drv_modbus_bus *bus, int slave, int *counts,
                               struct gonio_err *err)
{
    unsigned status = 0;
    int channels = 0;
    int rc = drv_modbus_detector_probe(bus, slave, &status, &channels, err);
    *counts = rc == 0 && (status & ST_RAW) != 0;
    return rc;
}

int drv_modbus_detector_probe(drv_modbus_bus *bus, int slave, unsigned *status, int *channels,
                              struct gonio_err *err)
{
    uint16_t r[4]; /* status and channel count, adjacent */
    int rc = drv_modbus_read(bus, slave, R_STATUS, 4, r, "detector", err);
    if (rc < 0)
        return rc;
    *status = drv_modbus_get32(r);
    *channels = (int)drv_modbus_get32(r + 2);
    return 0;
}

int drv_modbus_detector_probe_shutter(drv_modbus_bus *bus, int slave, int *closed,
                                      struct gonio_err *err)
{
    uint16_t r[2];
    int rc = drv_modbus_read(bus, slave, MB_DET_SHUTTER, 2, r, "detector", err);
    if (rc < 0 && drv_modbus_last_exception(bus) == 2)
        return gonio_err_set(err, ENOTSUP, "detector (slave %d) has no shutter (register "
                             "0x%04x: exception 02)", slave, (unsigned)MB_DET_SHUTTER);
    if (rc < 0)
        return rc;
    *closed = drv_modbus_get32(r) != 0;
    return 0;
}
