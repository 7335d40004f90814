#include "daemon/devices.h"

#include <errno.h>
#include <string.h>

#include "drivers/drivers.h"

#ifdef GONIOD_HAVE_MODBUS
#include "drivers/drv_modbus.h"
#ifdef GONIOD_HAVE_USB
#include "drivers/drv_usbspec.h"
#endif

/* The USB spectrometer as the rig's detector, its transfers cancellable
 * like the bus's waits; its clock is wall time. */
static int open_usb_detector(const struct goniod_config *cfg, int (*cancelled)(void *user),
                             void *user, struct capture_devices *dev, struct gonio_err *err)
{
#ifdef GONIOD_HAVE_USB
    struct drv_usbspec_cfg uc;
    drv_usbspec_cfg_default(&uc);
    uc.vendor = cfg->usb.vendor;
    uc.product = cfg->usb.product;
    uc.serial = cfg->usb.serial;
    uc.timeout_s = cfg->usb.timeout_s;
    uc.scale = cfg->usb.scale;
    if (cfg->usb.bands_390) {
        uc.first_nm = 390;
        uc.n_bands = 35;
    }
    drv_usbspec *s = drv_usbspec_open(&uc, err);
    if (!s)
        return -GONIO_EDEVICE;
    drv_usbspec_set_cancel(s, cancelled, user);
    if (!(dev->detector = drv_detector_new_usbspec(s, &uc, err)))
        return -GONIO_EDEVICE;
    if (!(dev->clock = drv_clock_new_wall(cancelled, user)))
        return gonio_err_set(err, ENOMEM, "wall clock: out of memory");
    return 0;
#else
    (void)cancelled;
    (void)user;
    (void)dev;
    return gonio_err_set(err, GONIO_EDEVICE, "%s: detector 'usb-spectrometer': this goniod was "
                         "built without the USB backend (drivers/drv_usbspec.c)", cfg->path);
#endif
}

int goniod_devices_open(const struct goniod_config *cfg, const struct rig_profile *rig,
                        int (*cancelled)(void *user), void *user,
                        struct capture_devices *dev, void **bus_out, struct gonio_err *err)
{
    memset(dev, 0, sizeof *dev);
    *bus_out = NULL;
    /* Checked at start and at each request; again here, where a missing
     * drive would silently leave an axis the plan moves where it stands. */
    char why[700];
    if (goniod_config_rig_gap(cfg, rig, rig->name, why, sizeof why) < 0)
        return gonio_err_set(err, GONIO_EBADCONFIG, "%s: %s", cfg->path, why);
    struct drv_modbus_bus_cfg bc;
    drv_modbus_bus_cfg_default(&bc);
    bc.timeout_s = cfg->timeout_s;
    bc.retries = cfg->retries;
    bc.time_scale = cfg->time_scale;
    drv_modbus_bus *bus;
    if (cfg->driver == GONIOD_DRIVER_MODBUS_RTU) {
        bc.device = cfg->device;
        bc.baud = (int)cfg->baud;
        bc.parity = cfg->parity;
        bc.data_bits = cfg->data_bits;
        bc.stop_bits = cfg->stop_bits;
        bus = drv_modbus_bus_new_rtu(&bc, err);
    } else {
        bc.host = cfg->host;
        bc.port = cfg->port;
        bus = drv_modbus_bus_new_tcp(&bc, err);
    }
    if (!bus)
        return -(err && err->code ? err->code : GONIO_EDEVICE);
    drv_modbus_bus_set_cancel(bus, cancelled, user);
    /* The rig profile's mechanics (docs/plans.md): band, backlash, tries. */
    struct drv_modbus_axis_opts opts = {.steps_per_deg = cfg->steps_per_deg,
                                        .in_position_deg = rig->mech.in_position_deg,
                                        .backlash_deg = rig->mech.backlash_deg,
                                        .approach = rig->mech.approach,
                                        .move_retries = rig->mech.move_retries};
    dev->sample = drv_axis_new_modbus(bus, cfg->slaves.sample, &rig->sample, &opts, "sample",
                                      err);
    if (dev->sample)
        dev->arm = drv_axis_new_modbus(bus, cfg->slaves.arm, &rig->arm, &opts, "arm", err);
    if (dev->arm && rig->out_of_plane)
        dev->azimuth = drv_axis_new_modbus(bus, cfg->slaves.azimuth, &rig->azimuth, &opts,
                                           "azimuth", err);
    int axes_ok = dev->arm && (dev->azimuth || !rig->out_of_plane);
    if (axes_ok && cfg->detector == GONIOD_DETECTOR_USB) {
        open_usb_detector(cfg, cancelled, user, dev, err);
    } else if (axes_ok) {
        dev->detector = drv_detector_new_modbus(bus, cfg->slaves.detector, err);
        if (dev->detector)
            dev->clock = drv_clock_new_modbus(bus, cfg->slaves.detector, err);
    }
    if (!dev->clock) {
        goniod_devices_close(dev, bus);
        return -(err && err->code ? err->code : GONIO_EDEVICE);
    }
    *bus_out = bus;
    return 0;
}

void goniod_devices_stats(const void *bus, struct goniod_comm_stats *out)
{
    memset(out, 0, sizeof *out);
    if (!bus)
        return;
    struct drv_modbus_stats st;
    drv_modbus_bus_stats(bus, &st);
    *out = (struct goniod_comm_stats){st.requests,    st.retries,    st.timeouts,
                                      st.bad_replies, st.exceptions, st.failed,
                                      st.reconnects};
}

void goniod_devices_close(struct capture_devices *dev, void *bus)
{
    drv_axis_free(dev->sample);
    drv_axis_free(dev->arm);
    drv_axis_free(dev->azimuth);
    drv_detector_free(dev->detector);
    drv_clock_free(dev->clock);
    memset(dev, 0, sizeof *dev);
    drv_modbus_bus_free(bus);
}

#else /* the Modbus backend is not in this build */

int goniod_devices_open(const struct goniod_config *cfg, const struct rig_profile *rig,
                        int (*cancelled)(void *user), void *user,
                        struct capture_devices *dev, void **bus_out, struct gonio_err *err)
{
    (void)rig;
    (void)cancelled;
    (void)user;
    memset(dev, 0, sizeof *dev);
    *bus_out = NULL;
    return gonio_err_set(err, GONIO_EDEVICE,
                         "%s: driver '%s': this goniod was built without the Modbus backend "
                         "(library gonio_drivers_modbus); use driver kind 'sim'",
                         cfg->path, goniod_driver_name(cfg->driver));
}

void goniod_devices_stats(const void *bus, struct goniod_comm_stats *out)
{
    (void)bus;
    memset(out, 0, sizeof *out);
}

void goniod_devices_close(struct capture_devices *dev, void *bus)
{
    (void)bus;
    memset(dev, 0, sizeof *dev);
}

#endif
