/* A spectral detector's band counts over Modbus (docs/protocol-modbus.md,
 * "Band block"): the band count and centres read once, then with each raw
 * reading its band counts, checked as the raw block's channels are
 * (drv_modbus_raw.c) before any of it reaches the engine. */
#include <math.h>
#include <stdio.h>

#include "drivers/drivers_private.h"
#include "drivers/drv_modbus_private.h"

static int refuse(const char *who, int slave, struct gonio_err *err, int reg, const char *what)
{
    return gonio_err_set(err, GONIO_EDEVICE, "%s (slave %d): register 0x%04x %s", who, slave,
                         (unsigned)reg, what);
}

/* The band count and centres of a detector whose status says BANDS. */
static int probe(drv_modbus_bus *bus, int slave, const char *who, struct mb_bands *b,
                 struct gonio_err *err)
{
    uint16_t r[2 * MB_DET_MAX_BANDS];
    int rc = drv_modbus_read(bus, slave, MB_DET_BAND_COUNT, 2, r, who, err);
    if (rc < 0)
        return rc;
    uint32_t n = drv_modbus_get32(r);
    char what[160];
    if (n < 1 || n > MB_DET_MAX_BANDS) {
        snprintf(what, sizeof what, "(band count) reads %u, where the status says BANDS: 1 to "
                 "%d", n, MB_DET_MAX_BANDS);
        return refuse(who, slave, err, MB_DET_BAND_COUNT, what);
    }
    if ((rc = drv_modbus_read(bus, slave, MB_DET_BAND_NM, 2 * (int)n, r, who, err)) < 0)
        return rc;
    for (uint32_t k = 0; k < n; k++) {
        b->nm[k] = drv_modbus_get_float(r + 2 * k);
        if (!(isfinite(b->nm[k]) && b->nm[k] > 0 && (k == 0 || b->nm[k] > b->nm[k - 1]))) {
            snprintf(what, sizeof what, "(band %u centre) reads %g nm: band centres are "
                     "positive and increasing", k, b->nm[k]);
            return refuse(who, slave, err, MB_DET_BAND_NM + 2 * (int)k, what);
        }
    }
    b->n = (int)n;
    b->probed = 1;
    return 0;
}

int drv_modbus_read_bands(drv_modbus_bus *bus, int slave, const char *who, struct mb_bands *b,
                          uint32_t seq, struct drv_reading *out, struct gonio_err *err)
{
    int rc = b->probed ? 0 : probe(bus, slave, who, b, err);
    if (rc < 0)
        return rc;
    uint16_t r[2 + 2 * MB_DET_MAX_BANDS];
    if ((rc = drv_modbus_read(bus, slave, MB_DET_BAND_SEQUENCE, 2 + 2 * b->n, r, who, err)) < 0)
        return rc;
    char what[200];
    uint32_t bseq = drv_modbus_get32(r);
    if (bseq != seq) {
        snprintf(what, sizeof what, "(band sequence) reads %u: the bands are of another "
                 "reading than the channels' (sequence %u)", bseq, seq);
        return refuse(who, slave, err, MB_DET_BAND_SEQUENCE, what);
    }
    for (int k = 0; k < b->n; k++) {
        uint32_t v = drv_modbus_get32(r + 2 + 2 * k);
        if (v > out->full_scale) {
            snprintf(what, sizeof what, "(band %d, %g nm) reads %u counts, above the full "
                     "scale %.0f (register 0x%04x)", k, b->nm[k], v, out->full_scale,
                     (unsigned)MB_DET_FULL_SCALE);
            return refuse(who, slave, err, MB_DET_BAND_COUNTS + 2 * k, what);
        }
        if (v == out->full_scale)
            out->flags |= DRV_READING_SATURATED;
        b->counts[k] = v;
    }
    out->n_bands = b->n;
    out->bands_nm = b->nm;
    out->bands = b->counts;
    return 0;
}
