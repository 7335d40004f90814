/* goniod's devices for the Modbus drivers: the rig's axes, detector and
 * clock on the bus the configuration names (docs/protocol-modbus.md). The
 * sim driver needs none of this: goniod hands the engine the in-process
 * simulator (sim_source/sim_source.h). */
#ifndef GONIO_DAEMON_DEVICES_H
#define GONIO_DAEMON_DEVICES_H

#include <stdio.h>

#include "common/err.h"
#include "capture/capture.h"
#include "daemon/config.h"
#include "rig/rig.h"

/* Open the bus and the devices on it; *bus receives the bus handle for
 * goniod_devices_close. The azimuth axis is opened when the configuration
 * names its slave and the rig profile is out-of-plane, the rotation axis
 * when it names that slave and the profile has axes.rotation. cancelled (with
 * user; may be NULL) is the bus's cancel check (drv_modbus_bus_set_cancel):
 * once it says so, the devices' waits end and fail with -ECANCELED. */
int goniod_devices_open(const struct goniod_config *cfg, const struct rig_profile *rig,
                        int (*cancelled)(void *user), void *user,
                        struct capture_devices *dev, void **bus, struct gonio_err *err);

/* The bus's exchange counts so far (drivers/drv_modbus.h), for the stop
 * document and the log; all zero without a bus. reconnects: Modbus TCP
 * connections re-opened after the device or network dropped one. */
struct goniod_comm_stats {
    long requests, retries, timeouts, bad_replies, exceptions, failed, reconnects;
};
void goniod_devices_stats(const void *bus, struct goniod_comm_stats *out);

/* The sample changer (driver.slaves.sample_changer) on bus: slot (a
 * capture_slot: the sample, the standard, the light trap) in the sample's
 * place. */
int goniod_devices_mount(const struct goniod_config *cfg, void *bus, int slot,
                         struct gonio_err *err);

/* Free the devices, then the bus. */
void goniod_devices_close(struct capture_devices *dev, void *bus);

/* The rig's axes alone, for bring-up and the probe: every
 * axis the configuration wires (the azimuth where slaves.azimuth names
 * it, the rotation where slaves.rotation does), with the rig profile's limits and mechanics and its speeds and
 * accelerations times speed_factor (1: the profile's). names[i] and
 * slaves[i] go with ax[i]. The sim driver has no drives: GONIO_EUSAGE. */
#define GONIOD_AXES_MAX 4
struct goniod_axes {
    drv_axis *ax[GONIOD_AXES_MAX];
    const char *names[GONIOD_AXES_MAX];
    int slaves[GONIOD_AXES_MAX];
    int n;
    void *bus;
};
int goniod_axes_open(const struct goniod_config *cfg, const struct rig_profile *rig,
                     double speed_factor, int (*cancelled)(void *user), void *user,
                     struct goniod_axes *out, struct gonio_err *err);
void goniod_axes_close(struct goniod_axes *a);

/* goniod --check --probe: open the bus, ask every configured device what
 * it is (each axis drive's status, alarm and encoder; the detector's
 * status and channel count), a line each on out. 0 when all answered;
 * else -GONIO_EDEVICE with err naming the first that did not. */
int goniod_probe(const struct goniod_config *cfg, const struct rig_profile *rig, FILE *out,
                 struct gonio_err *err);

#endif
