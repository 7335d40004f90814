#include "daemon/devices.h"

#include <errno.h>
#include <string.h>

#include "drivers/drivers.h"

#ifdef GONIOD_HAVE_MODBUS
#include "drivers/drv_modbus.h"
#include "modbus_map/modbus_map.h"
#ifdef GONIOD_HAVE_USB
#include "drivers/drv_usbspec.h"
#endif

#ifdef GONIOD_HAVE_USB
/* The spectrometer's driver settings from goniod's config. */
static void usb_cfg(const struct goniod_config *cfg, struct drv_usbspec_cfg *uc)
{
    drv_usbspec_cfg_default(uc);
    uc->vendor = cfg->usb.vendor;
    uc->product = cfg->usb.product;
    uc->serial = cfg->usb.serial;
    uc->timeout_s = cfg->usb.timeout_s;
    uc->scale = cfg->usb.scale;
    if (cfg->usb.bands_390) {
        uc->first_nm = 390;
        uc->n_bands = 35;
    }
}
#endif

/* The USB spectrometer as the rig's detector, its transfers cancellable
 * like the bus's waits; its clock is wall time. */
static int open_usb_detector(const struct goniod_config *cfg, int (*cancelled)(void *user),
                             void *user, struct capture_devices *dev, struct gonio_err *err)
{
#ifdef GONIOD_HAVE_USB
    struct drv_usbspec_cfg uc;
    usb_cfg(cfg, &uc);
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

/* The configured bus, with its line settings, timeout and retries. */
static drv_modbus_bus *open_bus(const struct goniod_config *cfg, struct gonio_err *err)
{
    struct drv_modbus_bus_cfg bc;
    drv_modbus_bus_cfg_default(&bc);
    bc.timeout_s = cfg->timeout_s;
    bc.drain_s = cfg->drain_s;
    bc.retries = cfg->retries;
    bc.time_scale = cfg->time_scale;
    if (cfg->driver == GONIOD_DRIVER_MODBUS_RTU) {
        bc.device = cfg->device;
        bc.baud = (int)cfg->baud;
        bc.parity = cfg->parity;
        bc.data_bits = cfg->data_bits;
        bc.stop_bits = cfg->stop_bits;
        return drv_modbus_bus_new_rtu(&bc, err);
    }
    bc.host = cfg->host;
    bc.port = cfg->port;
    return drv_modbus_bus_new_tcp(&bc, err);
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
    drv_modbus_bus *bus = open_bus(cfg, err);
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
    if (dev->arm && (dev->azimuth || !rig->out_of_plane) && rig->has_rotation)
        dev->rotation = drv_axis_new_modbus(bus, cfg->slaves.rotation, &rig->rotation, &opts,
                                            "rotation", err);
    int axes_ok = dev->arm && (dev->azimuth || !rig->out_of_plane) &&
                  (dev->rotation || !rig->has_rotation);
    if (axes_ok && cfg->detector == GONIOD_DETECTOR_USB) {
        open_usb_detector(cfg, cancelled, user, dev, err);
    } else if (axes_ok) {
        dev->detector = drv_detector_new_modbus(bus, cfg->slaves.detector, err);
        /* It says whether it gives counts before anything moves. */
        if (dev->detector &&
            drv_modbus_detector_counts(bus, cfg->slaves.detector, &dev->counts, err) < 0) {
            drv_detector_free(dev->detector);
            dev->detector = NULL;
        }
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
    drv_axis_free(dev->rotation);
    drv_detector_free(dev->detector);
    drv_clock_free(dev->clock);
    memset(dev, 0, sizeof *dev);
    drv_modbus_bus_free(bus);
}

int goniod_axes_open(const struct goniod_config *cfg, const struct rig_profile *rig,
                     double speed_factor, int (*cancelled)(void *user), void *user,
                     struct goniod_axes *out, struct gonio_err *err)
{
    memset(out, 0, sizeof *out);
    if (cfg->driver == GONIOD_DRIVER_SIM)
        return gonio_err_set(err, GONIO_EUSAGE, "%s: driver 'sim' has no drives to bring up "
                             "(the in-process rig starts at home for every capture)", cfg->path);
    drv_modbus_bus *bus = open_bus(cfg, err);
    if (!bus)
        return -(err && err->code ? err->code : GONIO_EDEVICE);
    drv_modbus_bus_set_cancel(bus, cancelled, user);
    out->bus = bus;
    struct drv_modbus_axis_opts opts = {.steps_per_deg = cfg->steps_per_deg,
                                        .in_position_deg = rig->mech.in_position_deg,
                                        .backlash_deg = rig->mech.backlash_deg,
                                        .approach = rig->mech.approach,
                                        .move_retries = rig->mech.move_retries};
    const struct rig_axis *prof[] = {&rig->sample, &rig->arm, &rig->azimuth, &rig->rotation};
    static const char *const names[] = {"sample", "arm", "azimuth", "rotation"};
    const int slaves[] = {cfg->slaves.sample, cfg->slaves.arm, cfg->slaves.azimuth,
                          cfg->slaves.rotation};
    for (int i = 0; i < GONIOD_AXES_MAX; i++) {
        if (!slaves[i])
            continue;
        struct rig_axis p = *prof[i];
        p.speed *= speed_factor;
        p.accel *= speed_factor;
        drv_axis *ax = drv_axis_new_modbus(bus, slaves[i], &p, &opts, names[i], err);
        if (!ax) {
            goniod_axes_close(out);
            return -(err && err->code ? err->code : GONIO_EDEVICE);
        }
        out->ax[out->n] = ax;
        out->names[out->n] = names[i];
        out->slaves[out->n++] = slaves[i];
    }
    return 0;
}

void goniod_axes_close(struct goniod_axes *a)
{
    for (int i = 0; i < a->n; i++)
        drv_axis_free(a->ax[i]);
    drv_modbus_bus_free(a->bus);
    memset(a, 0, sizeof *a);
}

/* One probe line, a YAML comment (so that --check's output stays the
 * configuration): the device, then what it answered or why it did not;
 * the first failure kept in first. */
static void probe_line(FILE *out, const char *who, int rc, const char *what,
                       const struct gonio_err *e, struct gonio_err *first)
{
    fprintf(out, "# probe: %-22s %s%s\n", who,
            rc == 0 ? "" : rc == -ENOTSUP ? "answered, but " : "did not answer: ",
            rc == 0 ? what : e->msg);
    if (rc < 0 && !first->msg[0])
        *first = *e;
}

/* The USB spectrometer: opened as a capture opens it (initialised, its
 * wavelength calibration and status read), nothing measured; its bands
 * must lie within the wavelengths its calibration gives its pixels. */
static void probe_usb(const struct goniod_config *cfg, FILE *out, struct gonio_err *first)
{
    const char *who = "detector (usb)";
#ifdef GONIOD_HAVE_USB
    struct drv_usbspec_cfg uc;
    usb_cfg(cfg, &uc);
    struct gonio_err e = {0};
    char what[256] = "";
    int rc = -GONIO_EDEVICE;
    drv_usbspec *s = drv_usbspec_open(&uc, &e);
    if (s) {
        double c[4], lambda[DRV_USBSPEC_PIXELS];
        drv_usbspec_coefficients(s, c);
        drv_usbspec_wavelengths(c, DRV_USBSPEC_PIXELS, lambda);
        double lo = uc.first_nm - uc.step_nm / 2;
        double hi = uc.first_nm + (uc.n_bands - 0.5) * uc.step_nm;
        const double first_px = lambda[0], last_px = lambda[DRV_USBSPEC_PIXELS - 1];
        snprintf(what, sizeof what, "answered: serial %s, %d pixels, %.1f-%.1f nm, %d bands "
                 "%g-%g nm", drv_usbspec_serial(s), DRV_USBSPEC_PIXELS, first_px, last_px,
                 uc.n_bands, uc.first_nm, uc.first_nm + (uc.n_bands - 1) * uc.step_nm);
        rc = 0;
        if (!(first_px <= lo && hi <= last_px))
            rc = gonio_err_set(&e, GONIO_EDEVICE, "%s: its pixels span %.1f-%.1f nm, which "
                               "does not hold the configured bands' %g-%g nm (driver.detector."
                               "bands)", who, first_px, last_px, lo, hi);
        drv_usbspec_close(s);
    }
    probe_line(out, who, rc, what, &e, first);
#else
    (void)cfg;
    (void)first;
    fprintf(out, "# probe: %-22s not probed (this goniod was built without the USB "
            "backend)\n", who);
#endif
}

/* A device that did not answer at all: what to check, with the settings
 * goniod used (a slave at another speed hears framing errors and stays
 * silent, as does one at another id). */
static void probe_hint(const struct goniod_config *cfg, struct gonio_err *err)
{
    if (err->code != ETIMEDOUT)
        return;
    char msg[GONIO_ERR_MSG_MAX];
    snprintf(msg, sizeof msg, "%s", err->msg);
    if (cfg->driver == GONIOD_DRIVER_MODBUS_RTU)
        gonio_err_set(err, err->code, "%s: check driver.device (%s), driver.baud (%ld, "
                      "parity %c) and the slave id against the device's settings", msg,
                      cfg->device, cfg->baud, cfg->parity);
    else
        gonio_err_set(err, err->code, "%s: check driver.host and driver.port (%s:%d) and the "
                      "slave id against the device's settings", msg, cfg->host, cfg->port);
}

/* The sample changer the config declares: the slot in place and its
 * status; one that does not answer, or answers with a slot it has not,
 * is refused here rather than at the first calibration. */
static void probe_changer(const struct goniod_config *cfg, drv_modbus_bus *bus, FILE *out,
                          struct gonio_err *first)
{
    static const char *const holds[] = {"the sample", "the standard", "the light trap"};
    unsigned status = 0;
    int slot = 0, slave = cfg->slaves.sample_changer;
    struct gonio_err e = {0};
    char who[64], what[256];
    int rc = drv_modbus_changer_read(bus, slave, &status, &slot, &e);
    snprintf(who, sizeof who, "sample changer (slave %d)", slave);
    if (rc == 0 && (slot < 0 || slot > MB_CH_SLOT_TRAP))
        rc = gonio_err_set(&e, GONIO_EDEVICE, "sample changer (slave %d): slot %d in place, "
                           "not 0..2: not a gonio sample changer", slave, slot);
    if (rc == 0)
        snprintf(what, sizeof what, "answered: slot %d (%s) in place, %s%s", slot, holds[slot],
                 status & MB_CH_BUSY ? "BUSY" : status & MB_CH_IN_POS ? "IN-POS" : "not IN-POS",
                 status & MB_CH_BUSY && status & MB_CH_IN_POS ? ", IN-POS" : "");
    probe_line(out, who, rc, what, &e, first);
}

int goniod_probe(const struct goniod_config *cfg, const struct rig_profile *rig, FILE *out,
                 struct gonio_err *err)
{
    if (cfg->driver == GONIOD_DRIVER_SIM) {
        fprintf(out, "# probe: driver sim, the in-process rig: nothing to probe\n");
        return 0;
    }
    struct goniod_axes axes;
    int rc = goniod_axes_open(cfg, rig, 1, NULL, NULL, &axes, err);
    if (rc < 0)
        return rc;
    struct gonio_err first = {0};
    char who[64], what[256], alarm[64];
    for (int i = 0; i < axes.n; i++) {
        struct drv_axis_state st;
        struct gonio_err e = {0};
        rc = drv_axis_state(axes.ax[i], &st, &e);
        snprintf(who, sizeof who, "axis %s (slave %d)", axes.names[i], axes.slaves[i]);
        snprintf(alarm, sizeof alarm, st.alarm ? "0x%02x (%s)" : "none", st.alarm,
                 drv_alarm_name(st.alarm));
        snprintf(what, sizeof what, "answered: at %.2f deg, %s%s%s, alarm %s",
                 st.position_deg, st.ready > 0 ? "READY" : "not READY",
                 st.moving > 0 ? ", MOVE" : "", st.home_end > 0 ? ", HOME-END" : "", alarm);
        probe_line(out, who, rc, what, &e, &first);
    }
    if (cfg->detector == GONIOD_DETECTOR_MODBUS) {
        unsigned status = 0;
        int channels = 0;
        struct gonio_err e = {0};
        rc = drv_modbus_detector_probe(axes.bus, cfg->slaves.detector, &status, &channels, &e);
        snprintf(who, sizeof who, "detector (slave %d)", cfg->slaves.detector);
        snprintf(what, sizeof what, "answered: %d channels, %s", channels,
                 status & 1 ? "BUSY" : status & 2 ? "READY" : "idle");
        if (rc == 0 && (channels < 1 || channels > 64)) {
            rc = gonio_err_set(&e, GONIO_EDEVICE, "detector (slave %d): channel count %d, "
                               "not 1..64: not a gonio detector", cfg->slaves.detector, channels);
        }
        /* The profile's dark frames close the shutter (rig shutter:
         * true): a detector without one is found here, not at the first
         * dark frame. */
        int closed = 0;
        if (rc == 0 && rig->shutter &&
            (rc = drv_modbus_detector_probe_shutter(axes.bus, cfg->slaves.detector, &closed,
                                                    &e)) == 0)
            snprintf(what + strlen(what), sizeof what - strlen(what), ", shutter %s",
                     closed ? "closed" : "open");
        probe_line(out, who, rc, what, &e, &first);
    } else {
        probe_usb(cfg, out, &first);
    }
    if (cfg->slaves.sample_changer)
        probe_changer(cfg, axes.bus, out, &first);
    goniod_axes_close(&axes);
    if (first.msg[0]) {
        *err = first;
        probe_hint(cfg, err);
        return -GONIO_EDEVICE;
    }
    return 0;
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

int goniod_axes_open(const struct goniod_config *cfg, const struct rig_profile *rig,
                     double speed_factor, int (*cancelled)(void *user), void *user,
                     struct goniod_axes *out, struct gonio_err *err)
{
    (void)rig, (void)speed_factor, (void)cancelled, (void)user;
    memset(out, 0, sizeof *out);
    return gonio_err_set(err, GONIO_EDEVICE, "%s: driver '%s': this goniod was built without "
                         "the Modbus backend", cfg->path, goniod_driver_name(cfg->driver));
}

void goniod_axes_close(struct goniod_axes *a)
{
    memset(a, 0, sizeof *a);
}

int goniod_probe(const struct goniod_config *cfg, const struct rig_profile *rig, FILE *out,
                 struct gonio_err *err)
{
    (void)rig;
    if (cfg->driver == GONIOD_DRIVER_SIM) {
        fprintf(out, "# probe: driver sim, the in-process rig: nothing to probe\n");
        return 0;
    }
    return goniod_axes_open(cfg, rig, 1, NULL, NULL, &(struct goniod_axes){0}, err);
}

#endif

int goniod_devices_mount(const struct goniod_config *cfg, void *bus, int slot,
                         struct gonio_err *err)
{
    if (!bus || !cfg->slaves.sample_changer)
        return gonio_err_set(err, GONIO_EBADCONFIG, "no sample changer on the bus "
                             "(driver.slaves.sample_changer)");
    return drv_modbus_changer_set(bus, cfg->slaves.sample_changer, slot, err);
}
