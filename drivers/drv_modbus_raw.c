/* A raw reading over Modbus: the detector's raw block read after the
 * channels (docs/protocol-modbus.md, "Raw mode"), checked before any of it
 * reaches the engine. Counts feed a calibration: a value out of range
 * would be reduced as if it were light, so every register is checked
 * against what the map allows and refused naming it. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "drivers/drivers_private.h"
#include "drivers/drv_modbus_private.h"

/* A float32 register as the decimal value it was most likely written as:
 * binary32 holds 7 significant digits, and a device stores its stated
 * nonlinearity (0.02) as the nearest float (0.0199999996). */
static double float_as_written(float f)
{
    char buf[32];
    snprintf(buf, sizeof buf, "%.7g", (double)f);
    return strtod(buf, NULL);
}

static int refuse(const char *who, int slave, struct gonio_err *err, int reg, const char *what)
{
    return gonio_err_set(err, GONIO_EDEVICE, "%s (slave %d): register 0x%04x %s", who, slave,
                         (unsigned)reg, what);
}

int drv_modbus_read_raw(drv_modbus_bus *bus, int slave, const char *who,
                        const struct mb_raw_channels *ch, struct drv_reading *out,
                        struct gonio_err *err)
{
    uint16_t r[MB_DET_RAW_NREGS];
    int rc = drv_modbus_read(bus, slave, MB_DET_RAW_SEQUENCE, MB_DET_RAW_NREGS, r, who, err);
    if (rc < 0)
        return rc;
#define REG(addr) (r + ((addr) - MB_DET_RAW_SEQUENCE))
    uint32_t seq = drv_modbus_get32(REG(MB_DET_RAW_SEQUENCE));
    uint32_t gain = drv_modbus_get32(REG(MB_DET_GAIN_STATE));
    uint32_t full = drv_modbus_get32(REG(MB_DET_FULL_SCALE));
    float k = drv_modbus_get_float(REG(MB_DET_NONLINEARITY));
    uint32_t monitor = drv_modbus_get32(REG(MB_DET_MONITOR));
    uint32_t shutter = drv_modbus_get32(REG(MB_DET_SHUTTER));
#undef REG
    char what[200];
    if (seq != ch->seq) {
        snprintf(what, sizeof what, "(raw sequence) reads %u: the block is of another reading "
                 "than the channels' (sequence %u)", seq, ch->seq);
        return refuse(who, slave, err, MB_DET_RAW_SEQUENCE, what);
    }
    if (gain > MB_DET_GAIN_STATE_MAX) {
        snprintf(what, sizeof what, "(gain state) reads %u, above %u", gain,
                 MB_DET_GAIN_STATE_MAX);
        return refuse(who, slave, err, MB_DET_GAIN_STATE, what);
    }
    if (full == 0) {
        snprintf(what, sizeof what, "(full scale) reads 0 counts");
        return refuse(who, slave, err, MB_DET_FULL_SCALE, what);
    }
    if (!(k >= 0 && k < 0.5f)) {
        snprintf(what, sizeof what, "(nonlinearity) reads %g, outside 0 to 0.5", (double)k);
        return refuse(who, slave, err, MB_DET_NONLINEARITY, what);
    }
    if (shutter != (uint32_t)ch->shutter_closed) {
        snprintf(what, sizeof what, "(shutter) reads %u, where the driver %s it", shutter,
                 ch->shutter_closed ? "closed (1)" : "left it open (0)");
        return refuse(who, slave, err, MB_DET_SHUTTER, what);
    }
    out->flags = ch->saturated ? DRV_READING_SATURATED : 0;
    for (int c = 0; c < 3; c++) {
        if (ch->counts[c] > full) {
            snprintf(what, sizeof what, "(channel %c) reads %u counts, above the full scale %u "
                     "(register 0x%04x)", "RGB"[c], ch->counts[c], full,
                     (unsigned)MB_DET_FULL_SCALE);
            return refuse(who, slave, err, MB_DET_CHANNELS + 2 * c, what);
        }
        if (ch->counts[c] == full)
            out->flags |= DRV_READING_SATURATED;
        out->rgb[c] = ch->counts[c];
    }
    out->unit = DRV_UNIT_COUNTS;
    out->full_scale = full;
    out->nonlinearity = float_as_written(k);
    out->gain_state = (int)gain;
    out->monitor = monitor == MB_DET_MONITOR_NONE ? NAN : (double)monitor;
    return 0;
}
