/* The sample changer on the Modbus bus (docs/protocol-modbus.md, "Sample
 * changer"): write the target slot, then poll the status until the changer
 * is in position with that slot in place. */
#include <stdio.h>

#include "drivers/drv_modbus_private.h"

/* A swap takes seconds on a real changer; this bounds the wait (wall time). */
#define CHANGER_TIMEOUT_S 120.0
#define CHANGER_POLL_S 0.05

int drv_modbus_changer_set(drv_modbus_bus *bus, int slave, int standard, struct gonio_err *err)
{
    int slot = standard ? MB_CH_SLOT_STANDARD : MB_CH_SLOT_SAMPLE;
    char who[48];
    snprintf(who, sizeof who, "sample changer (slave %d)", slave);
    uint16_t w[2];
    drv_modbus_put32(w, (uint32_t)slot);
    int rc = drv_modbus_write(bus, slave, MB_CH_TARGET, 2, w, who, err);
    for (double waited = 0; rc == 0; waited += CHANGER_POLL_S) {
        uint16_t r[4];
        if ((rc = drv_modbus_read(bus, slave, MB_CH_STATUS, 4, r, who, err)) < 0)
            break;
        uint32_t status = drv_modbus_get32(r), at = drv_modbus_get32(r + 2);
        if (!(status & MB_CH_BUSY) && (status & MB_CH_IN_POS) && at == (uint32_t)slot)
            return 0;
        if (waited >= CHANGER_TIMEOUT_S)
            return gonio_err_set(err, GONIO_EDEVICE, "%s: slot %d not in place after %g s "
                                 "(status 0x%x, slot %u in place)", who, slot,
                                 CHANGER_TIMEOUT_S, status, at);
        rc = drv_modbus_sleep(bus, CHANGER_POLL_S, who, err);
    }
    return rc;
}
