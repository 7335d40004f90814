/* The sample changer on the Modbus bus (docs/protocol-modbus.md, "Sample
 * changer"): write the target slot, then poll the status until the changer
 * is in position with that slot in place. */
#include <stdio.h>

#include "drivers/drv_modbus_private.h"

/* A swap takes seconds on a real changer; this bounds the wait (wall time). */
#define CHANGER_TIMEOUT_S 120.0
#define CHANGER_POLL_S 0.05

int drv_modbus_changer_read(drv_modbus_bus *bus, int slave, unsigned *status, int *slot,
                            struct gonio_err *err)
{
    char who[48];
    snprintf(who, sizeof who, "sample changer (slave %d)", slave);
    uint16_t r[4];
    int rc = drv_modbus_read(bus, slave, MB_CH_STATUS, 4, r, who, err);
    if (rc == 0)
        *status = drv_modbus_get32(r), *slot = (int)drv_modbus_get32(r + 2);
    return rc;
}

static int in_place(unsigned status, int at, int slot)
{
    return !(status & MB_CH_BUSY) && (status & MB_CH_IN_POS) && at == slot;
}

int drv_modbus_changer_set(drv_modbus_bus *bus, int slave, int slot, struct gonio_err *err)
{
    char who[48];
    snprintf(who, sizeof who, "sample changer (slave %d)", slave);
    unsigned status;
    int at;
    /* Already there (a calibration resumed after goniod died): a changer
     * asked again would swap for nothing, or not at all. */
    int rc = drv_modbus_changer_read(bus, slave, &status, &at, err);
    if (rc < 0 || in_place(status, at, slot))
        return rc;
    uint16_t w[2];
    drv_modbus_put32(w, (uint32_t)slot);
    rc = drv_modbus_write(bus, slave, MB_CH_TARGET, 2, w, who, err);
    for (double waited = 0; rc == 0; waited += CHANGER_POLL_S) {
        if ((rc = drv_modbus_changer_read(bus, slave, &status, &at, err)) < 0)
            break;
        if (in_place(status, at, slot))
            return 0;
        if (waited >= CHANGER_TIMEOUT_S)
            return gonio_err_set(err, GONIO_EDEVICE, "%s: slot %d not in place after %g s "
                                 "(status 0x%x, slot %d in place)", who, slot,
                                 CHANGER_TIMEOUT_S, status, at);
        rc = drv_modbus_sleep(bus, CHANGER_POLL_S, who, err);
    }
    return rc;
}
