/* The detector slave (docs/protocol-modbus.md): write the integration
 * time and the trigger, wait out the integration, poll until READY with a
 * sequence number the trigger did not start from, read the channels. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "drivers/drivers_private.h"
#include "drivers/drv_modbus_private.h"

/* The register map (modbus_map/modbus_map.h) under this file's names. */
enum { R_INTEGRATION = MB_DET_INTEGRATION, R_CHANNELS = MB_DET_CHANNELS };
enum { ST_BUSY = MB_DET_BUSY, ST_READY = MB_DET_READY, ST_SATURATED = MB_DET_SATURATED };

struct mb_detector {
    drv_modbus_bus *bus;
    int slave;
    char who[32];
    int seq_known; /* the sequence after our last reading: no read before the next */
    uint32_t seq;
};

/* Integration, trigger, status, channel count and sequence: registers
 * 0x00-0x09 in one read. The integration reads back what the detector
 * used (an auto-exposing detector may choose its own). */
static int read_state(struct mb_detector *d, uint32_t *st, uint32_t *count, uint32_t *seq,
                      uint32_t *used_us, struct gonio_err *err)
{
    uint16_t r[10];
    int rc = drv_modbus_read(d->bus, d->slave, R_INTEGRATION, 10, r, d->who, err);
    *used_us = drv_modbus_get32(r);
    *st = drv_modbus_get32(r + 4);
    *count = drv_modbus_get32(r + 6);
    *seq = drv_modbus_get32(r + 8);
    return rc;
}

static int mb_acquire(void *priv, double integration_s, struct drv_reading *out,
                      struct gonio_err *err)
{
    struct mb_detector *d = priv;
    double us = nearbyint(integration_s * 1e6);
    if (!(us >= 0) || us > 4294967295.0)
        return gonio_err_set(err, EINVAL, "%s: integration time %g s", d->who, integration_s);
    uint32_t st = 0, count = 3, seq0 = d->seq, seq, used_us = 0;
    int rc = d->seq_known ? 0 : read_state(d, &st, &count, &seq0, &used_us, err);
    if (rc < 0)
        return rc;
    d->seq_known = 0;
    if (count < 3 || count > 64)
        return gonio_err_set(err, GONIO_EDEVICE, "%s (slave %d): %u channels, expected RGB (3)",
                             d->who, d->slave, count);
    uint16_t w[4];
    drv_modbus_put32(w, (uint32_t)us);
    drv_modbus_put32(w + 2, 1);
    double scale = drv_modbus_time_scale(d->bus);
    double t0 = gonio_monotonic_s();
    if ((rc = drv_modbus_write(d->bus, d->slave, R_INTEGRATION, 4, w, d->who, err)) < 0)
        return rc;
    double deadline = t0 + (1.5 * integration_s + 2.0) / scale + 0.5 + 4 * drv_modbus_timeout(d->bus);
    double poll = fmin(fmax(0.01 / scale, 0.0002), 0.01);
    drv_modbus_sleep(t0 + integration_s / scale - gonio_monotonic_s());
    for (;;) {
        if ((rc = read_state(d, &st, &count, &seq, &used_us, err)) < 0)
            return rc;
        if ((st & ST_READY) && !(st & ST_BUSY) && seq != seq0)
            break;
        if (gonio_monotonic_s() > deadline)
            return gonio_err_set(err, GONIO_EDEVICE,
                                 "%s (slave %d): no fresh reading %.3g s after the trigger "
                                 "(status 0x%x, sequence %u)", d->who, d->slave,
                                 gonio_monotonic_s() - t0, st, seq);
        drv_modbus_sleep(poll);
    }
    uint16_t r[6];
    if ((rc = drv_modbus_read(d->bus, d->slave, R_CHANNELS, 6, r, d->who, err)) < 0)
        return rc;
    for (int k = 0; k < 3; k++) {
        out->rgb[k] = drv_modbus_get_float(r + 2 * k);
        /* A NaN or infinite reading would be journalled and fitted as a
         * sample: it is a device fault. */
        if (!isfinite(out->rgb[k]))
            return gonio_err_set(err, GONIO_EDEVICE, "%s (slave %d): channel %c reads %g",
                                 d->who, d->slave, "RGB"[k], out->rgb[k]);
    }
    d->seq_known = 1;
    d->seq = seq;
    out->integration_s = used_us * 1e-6;
    out->flags = (st & ST_SATURATED) ? DRV_READING_SATURATED : 0;
    return 0;
}

static const struct drv_detector_ops mb_detector_ops = {
    .name = "modbus",
    .acquire = mb_acquire,
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
