/* The OOI bulk protocol of a USB2000+-class spectrometer over libusb-1.0
 * (docs/usb-spectrometer.md). Transfers are asynchronous with our own
 * deadline: libusb_bulk_transfer cancels and retries forever when event
 * handling fails (seen when a device node stops answering), which would
 * hang the capture. */
#include "drivers/drv_usbspec.h"

#include <errno.h>
#include <libusb.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/clock.h"

enum { EP_CMD = 0x01, EP_REPLY = 0x81, EP_SPECTRUM = 0x82 };
enum { CMD_INIT = 0x01, CMD_INTEGRATION = 0x02, CMD_QUERY_INFO = 0x05, CMD_SPECTRUM = 0x09,
       CMD_STATUS = 0xFE };
enum { INFO_REPLY = 17, STATUS_REPLY = 16, SYNC_BYTE = 0x69 };
enum { RAW_BYTES = 2 * DRV_USBSPEC_PIXELS };

struct xfer_state {
    int done;
    enum libusb_transfer_status status;
    int actual;
};

struct drv_usbspec {
    libusb_context *ctx;
    libusb_device_handle *h;
    char who[96];       /* "usb spectrometer 2457:101e (serial X)" */
    char serial[64];
    double timeout_s;
    double coef[4];
    double nl[DRV_USBSPEC_NL_MAX + 1]; /* the nonlinearity correction's c0..c7 */
    int nl_order;
    int packet;         /* spectrum packet size: 512 high speed, 64 full speed */
    int lost;           /* unplugged, or a transfer libusb never gave back */
    int (*cancelled)(void *user); /* the host's cancel check, or NULL */
    void *cancel_user;
    struct xfer_state xs;      /* outlives a transfer libusb keeps */
    unsigned char buf[512];    /* the same */
};

void drv_usbspec_cfg_default(struct drv_usbspec_cfg *cfg)
{
    memset(cfg, 0, sizeof *cfg);
    cfg->vendor = 0x2457;
    cfg->product = 0x101e;
    cfg->timeout_s = 1.0;
    cfg->first_nm = 400;
    cfg->step_nm = 10;
    cfg->n_bands = 31;
    cfg->scale = 0; /* counts */
}

static void LIBUSB_CALL on_done(struct libusb_transfer *t)
{
    struct xfer_state *xs = t->user_data;
    xs->status = t->status;
    xs->actual = t->actual_length;
    xs->done = 1;
}

void drv_usbspec_set_cancel(drv_usbspec *s, int (*cancelled)(void *user), void *user)
{
    s->cancelled = cancelled;
    s->cancel_user = user;
}

/* Run events until the transfer completes or the deadline passes; asks the
 * host's cancel check every 0.1 s when cancellable, so that a stop does
 * not wait out an integration of up to 655 s. */
static int wait_done(drv_usbspec *s, double deadline, int cancellable)
{
    while (!s->xs.done) {
        if (cancellable && s->cancelled && s->cancelled(s->cancel_user))
            return -ECANCELED;
        double left = deadline - gonio_monotonic_s();
        if (left <= 0)
            return LIBUSB_ERROR_TIMEOUT;
        if (left > 0.1)
            left = 0.1;
        struct timeval tv = {0, (long)(left * 1e6) + 1};
        int rc = libusb_handle_events_timeout_completed(s->ctx, &tv, &s->xs.done);
        if (rc < 0 && rc != LIBUSB_ERROR_INTERRUPTED)
            return rc;
    }
    return 0;
}

static const char *status_text(enum libusb_transfer_status st)
{
    switch (st) {
    case LIBUSB_TRANSFER_TIMED_OUT: return "timed out";
    case LIBUSB_TRANSFER_NO_DEVICE: return "device unplugged (LIBUSB_ERROR_NO_DEVICE)";
    case LIBUSB_TRANSFER_STALL: return "endpoint stalled";
    case LIBUSB_TRANSFER_OVERFLOW: return "device sent more than asked for";
    case LIBUSB_TRANSFER_CANCELLED: return "cancelled";
    default: return "transfer failed";
    }
}

/* One bulk transfer of len bytes to or from ep, within timeout_s. An IN
 * transfer must bring exactly `want` bytes (a short packet otherwise ends
 * it early: a short read). step names the protocol step in messages. */
static int bulk(drv_usbspec *s, unsigned char ep, unsigned char *data, int len, int want,
                double timeout_s, const char *step, struct gonio_err *err)
{
    if (s->lost)
        return gonio_err_set(err, GONIO_EDEVICE, "%s: %s: the device was lost earlier",
                             s->who, step);
    if (len < 1 || len > (int)sizeof s->buf || want > len)
        return gonio_err_set(err, EINVAL, "%s: %s: transfer of %d bytes", s->who, step, len);
    struct libusb_transfer *t = libusb_alloc_transfer(0);
    if (!t)
        return gonio_err_set(err, ENOMEM, "%s: %s: out of memory", s->who, step);
    if (ep & 0x80)
        memset(s->buf, 0, sizeof s->buf);
    else
        memcpy(s->buf, data, (size_t)len);
    s->xs = (struct xfer_state){0};
    unsigned ms = (unsigned)ceil(timeout_s * 1000.0);
    libusb_fill_bulk_transfer(t, s->h, ep, s->buf, len, on_done, &s->xs, ms);
    int rc = libusb_submit_transfer(t);
    if (rc < 0) {
        libusb_free_transfer(t);
        if (rc == LIBUSB_ERROR_NO_DEVICE)
            s->lost = 1;
        return gonio_err_set(err, GONIO_EDEVICE, "%s: %s: %s", s->who, step,
                             rc == LIBUSB_ERROR_NO_DEVICE
                                 ? "device unplugged (LIBUSB_ERROR_NO_DEVICE)"
                                 : libusb_error_name(rc));
    }
    /* libusb's own timer ends the transfer at ms; ours is the backstop */
    int wrc = wait_done(s, gonio_monotonic_s() + timeout_s + 0.5, 1);
    if (!s->xs.done) {
        libusb_cancel_transfer(t);
        wait_done(s, gonio_monotonic_s() + 0.5, 0);
        if (wrc == -ECANCELED) {
            /* The device may still send what was asked: out of step until
             * it is opened again (a capture's devices are, per capture). */
            s->lost = 1;
            if (s->xs.done)
                libusb_free_transfer(t);
            return gonio_err_set(err, ECANCELED, "%s: %s: cancelled", s->who, step);
        }
        if (!s->xs.done) { /* libusb still owns it: never free or reuse it */
            s->lost = 1;
            return gonio_err_set(err, GONIO_EDEVICE, "%s: %s: no completion within %.3g s (%s)",
                                 s->who, step, timeout_s,
                                 wrc == LIBUSB_ERROR_TIMEOUT ? "timed out"
                                                             : libusb_error_name(wrc));
        }
        if (s->xs.status == LIBUSB_TRANSFER_CANCELLED)
            s->xs.status = LIBUSB_TRANSFER_TIMED_OUT;
    }
    libusb_free_transfer(t);
    if (s->xs.status != LIBUSB_TRANSFER_COMPLETED) {
        if (s->xs.status == LIBUSB_TRANSFER_NO_DEVICE)
            s->lost = 1;
        if (s->xs.status == LIBUSB_TRANSFER_TIMED_OUT)
            return gonio_err_set(err, GONIO_EDEVICE, "%s: %s: timed out after %.3g s (EP 0x%02x)",
                                 s->who, step, timeout_s, ep);
        return gonio_err_set(err, GONIO_EDEVICE, "%s: %s: %s (EP 0x%02x)", s->who, step,
                             status_text(s->xs.status), ep);
    }
    if (s->xs.actual != want)
        return gonio_err_set(err, GONIO_EDEVICE, "%s: %s: %s read: %d of %d bytes from EP 0x%02x",
                             s->who, step, s->xs.actual < want ? "short" : "long",
                             s->xs.actual, want, ep);
    if (ep & 0x80)
        memcpy(data, s->buf, (size_t)want);
    return 0;
}

static int command(drv_usbspec *s, const unsigned char *cmd, int len, const char *step,
                   struct gonio_err *err)
{
    return bulk(s, EP_CMD, (unsigned char *)cmd, len, len, s->timeout_s, step, err);
}

/* Query information slot (0x05): the reply echoes 0x05 and the slot, then
 * up to 15 bytes of NUL-terminated ASCII. */
static int query_info(drv_usbspec *s, int slot, char *text, size_t size, struct gonio_err *err)
{
    char step[48];
    snprintf(step, sizeof step, "query information slot %d", slot);
    unsigned char cmd[2] = {CMD_QUERY_INFO, (unsigned char)slot}, r[INFO_REPLY];
    int rc = command(s, cmd, 2, step, err);
    if (rc < 0 || (rc = bulk(s, EP_REPLY, r, INFO_REPLY, INFO_REPLY, s->timeout_s, step, err)) < 0)
        return rc;
    if (r[0] != CMD_QUERY_INFO || r[1] != slot)
        return gonio_err_set(err, GONIO_EDEVICE, "%s: %s: reply starts 0x%02x 0x%02x, expected "
                             "0x05 0x%02x", s->who, step, r[0], r[1], slot);
    size_t n = 0;
    while (n + 2 < INFO_REPLY && r[n + 2] && n + 1 < size) {
        text[n] = (char)r[n + 2];
        n++;
    }
    text[n] = '\0';
    return 0;
}

/* A number stored as ASCII in a query-information slot; what names it in
 * the error ("wavelength coefficient 1"). */
static int slot_number(drv_usbspec *s, int slot, const char *what, double *v,
                       struct gonio_err *err)
{
    char text[24], *end;
    int rc = query_info(s, slot, text, sizeof text, err);
    if (rc < 0)
        return rc;
    errno = 0;
    *v = strtod(text, &end);
    while (*end == ' ')
        end++;
    if (end == text || *end || errno == ERANGE || !isfinite(*v))
        return gonio_err_set(err, GONIO_EDEVICE, "%s: %s (slot %d): '%s' is not a number",
                             s->who, what, slot, text);
    return 0;
}

static int read_calibration(drv_usbspec *s, struct gonio_err *err)
{
    for (int k = 0; k < 4; k++) {
        char what[40];
        snprintf(what, sizeof what, "wavelength coefficient %d", k);
        int rc = slot_number(s, k + 1, what, &s->coef[k], err);
        if (rc < 0)
            return rc;
    }
    double lam[DRV_USBSPEC_PIXELS];
    drv_usbspec_wavelengths(s->coef, DRV_USBSPEC_PIXELS, lam);
    for (int p = 1; p < DRV_USBSPEC_PIXELS; p++)
        if (!(lam[p] > lam[p - 1]))
            return gonio_err_set(err, GONIO_EDEVICE, "%s: wavelength calibration %g %g %g %g "
                                 "does not increase at pixel %d (%g nm after %g nm)", s->who,
                                 s->coef[0], s->coef[1], s->coef[2], s->coef[3], p, lam[p],
                                 lam[p - 1]);
    return 0;
}

static double poly(const double *c, int order, double y)
{
    double p = 0;
    for (int k = order; k >= 0; k--)
        p = p * y + c[k];
    return p;
}

double drv_usbspec_linearise(const double *c, int order, double y)
{
    return y / poly(c, order, y);
}

/* Slots 6-13: the coefficients c0..c7 of the correction y / P(y) the
 * device's factory calibration measured; slot 14: the order of P. Checked
 * over the ADC's whole range: P positive and y / P(y) increasing, so that
 * a larger count is always more light. */
static int read_nonlinearity(drv_usbspec *s, struct gonio_err *err)
{
    double order;
    int rc = slot_number(s, 14, "nonlinearity order", &order, err);
    if (rc < 0)
        return rc;
    if (!(order >= 0 && order <= DRV_USBSPEC_NL_MAX) || order != floor(order))
        return gonio_err_set(err, GONIO_EDEVICE, "%s: nonlinearity order (slot 14): %g, "
                             "expected a whole number 0-%d", s->who, order, DRV_USBSPEC_NL_MAX);
    s->nl_order = (int)order;
    for (int k = 0; k <= s->nl_order; k++) {
        char what[40];
        snprintf(what, sizeof what, "nonlinearity coefficient %d", k);
        if ((rc = slot_number(s, 6 + k, what, &s->nl[k], err)) < 0)
            return rc;
    }
    double last = -INFINITY;
    for (int y = 0; y <= DRV_USBSPEC_FULL_SCALE; y += 64) {
        double p = poly(s->nl, s->nl_order, y);
        double x = drv_usbspec_linearise(s->nl, s->nl_order, y);
        if (!(p > 0) || !(x > last))
            return gonio_err_set(err, GONIO_EDEVICE, "%s: nonlinearity correction (slots 6-%d, "
                                 "c0 = %g): at %d counts P(y) = %g, y / P(y) = %g; it must be "
                                 "positive and increase", s->who, 6 + s->nl_order, s->nl[0], y,
                                 p, x);
        last = x;
    }
    return 0;
}

void drv_usbspec_nonlinearity(const drv_usbspec *s, double c[DRV_USBSPEC_NL_MAX + 1],
                              int *order)
{
    memcpy(c, s->nl, sizeof s->nl);
    *order = s->nl_order;
}

int drv_usbspec_status(drv_usbspec *s, struct drv_usbspec_status *st, struct gonio_err *err)
{
    unsigned char cmd = CMD_STATUS, r[STATUS_REPLY];
    int rc = command(s, &cmd, 1, "query status", err);
    if (rc < 0 || (rc = bulk(s, EP_REPLY, r, STATUS_REPLY, STATUS_REPLY, s->timeout_s,
                             "query status", err)) < 0)
        return rc;
    st->pixels = r[0] | (unsigned)r[1] << 8;
    st->integration_us = r[2] | (uint32_t)r[3] << 8 | (uint32_t)r[4] << 16 | (uint32_t)r[5] << 24;
    st->lamp_enabled = r[6];
    st->trigger_mode = r[7];
    st->high_speed = r[14] == 0x80;
    return 0;
}

int drv_usbspec_set_integration(drv_usbspec *s, uint32_t us, struct gonio_err *err)
{
    if (us < DRV_USBSPEC_MIN_US || us > DRV_USBSPEC_MAX_US)
        return gonio_err_set(err, EINVAL, "%s: integration time %u us outside %u-%u us", s->who,
                             us, DRV_USBSPEC_MIN_US, DRV_USBSPEC_MAX_US);
    unsigned char cmd[5] = {CMD_INTEGRATION, us & 0xff, (us >> 8) & 0xff, (us >> 16) & 0xff,
                            (us >> 24) & 0xff};
    return command(s, cmd, 5, "set integration time", err);
}

int drv_usbspec_read_raw(drv_usbspec *s, uint16_t *counts, struct gonio_err *err)
{
    struct drv_usbspec_status st;
    int rc = drv_usbspec_status(s, &st, err);
    if (rc < 0)
        return rc;
    unsigned char cmd = CMD_SPECTRUM;
    if ((rc = command(s, &cmd, 1, "request spectrum", err)) < 0)
        return rc;
    /* the first packet arrives once the integration is over */
    double first = s->timeout_s + st.integration_us * 1e-6;
    int n = RAW_BYTES / s->packet;
    unsigned char raw[RAW_BYTES];
    for (int i = 0; i < n; i++) {
        char step[64];
        snprintf(step, sizeof step, "read spectrum: packet %d of %d", i + 1, n);
        if ((rc = bulk(s, EP_SPECTRUM, raw + i * s->packet, s->packet, s->packet,
                       i ? s->timeout_s : first, step, err)) < 0)
            return rc;
    }
    unsigned char sync = 0;
    /* asked as a whole packet: a device out of step sends more than one byte */
    if ((rc = bulk(s, EP_SPECTRUM, &sync, s->packet, 1, s->timeout_s,
                   "read spectrum: sync byte", err)) < 0)
        return rc;
    if (sync != SYNC_BYTE)
        return gonio_err_set(err, GONIO_EDEVICE, "%s: read spectrum: sync byte 0x%02x, expected "
                             "0x69 (the data stream is out of step)", s->who, sync);
    for (int p = 0; p < DRV_USBSPEC_PIXELS; p++)
        counts[p] = (uint16_t)(raw[2 * p] | raw[2 * p + 1] << 8);
    return 0;
}

void drv_usbspec_coefficients(const drv_usbspec *s, double c[4])
{
    memcpy(c, s->coef, sizeof s->coef);
}

const char *drv_usbspec_serial(const drv_usbspec *s)
{
    return s->serial;
}

/* The sysfs serial attribute of a device (no control transfer needed). */
static void sysfs_serial(libusb_device *dev, char *out, size_t size)
{
    uint8_t ports[8];
    int n = libusb_get_port_numbers(dev, ports, 8);
    out[0] = '\0';
    if (n <= 0)
        return;
    char path[128];
    int len = snprintf(path, sizeof path, "/sys/bus/usb/devices/%u-%u",
                       libusb_get_bus_number(dev), ports[0]);
    for (int i = 1; i < n && len > 0 && (size_t)len < sizeof path; i++)
        len += snprintf(path + len, sizeof path - (size_t)len, ".%u", ports[i]);
    if (len <= 0 || (size_t)len + 8 >= sizeof path)
        return;
    strcat(path, "/serial");
    FILE *f = fopen(path, "r");
    if (!f)
        return;
    if (fgets(out, (int)size, f))
        out[strcspn(out, "\r\n")] = '\0';
    else
        out[0] = '\0';
    fclose(f);
}

static int find_device(drv_usbspec *s, const struct drv_usbspec_cfg *cfg, struct gonio_err *err)
{
    libusb_device **list;
    ssize_t n = libusb_get_device_list(s->ctx, &list);
    if (n < 0)
        return gonio_err_set(err, GONIO_EDEVICE, "%s: listing USB devices: %s", s->who,
                             libusb_error_name((int)n));
    int found = 0, rc = 0;
    for (ssize_t i = 0; i < n && !found; i++) {
        struct libusb_device_descriptor d;
        if (libusb_get_device_descriptor(list[i], &d) < 0 || d.idVendor != cfg->vendor ||
            d.idProduct != cfg->product)
            continue;
        char serial[64];
        sysfs_serial(list[i], serial, sizeof serial);
        if (cfg->serial && cfg->serial[0] && strcmp(serial, cfg->serial))
            continue;
        found = 1;
        snprintf(s->serial, sizeof s->serial, "%s", serial);
        rc = libusb_open(list[i], &s->h);
    }
    libusb_free_device_list(list, 1);
    if (!found)
        return gonio_err_set(err, GONIO_EDEVICE, "%s: no such device is connected", s->who);
    if (rc < 0)
        return gonio_err_set(err, GONIO_EDEVICE, "%s: open: %s%s", s->who, libusb_error_name(rc),
                             rc == LIBUSB_ERROR_ACCESS ? " (no permission on /dev/bus/usb: "
                                                         "see docs/usb-spectrometer.md)" : "");
    if ((rc = libusb_claim_interface(s->h, 0)) < 0) {
        libusb_close(s->h);
        s->h = NULL;
        return gonio_err_set(err, GONIO_EDEVICE, "%s: claim interface 0: %s", s->who,
                             libusb_error_name(rc));
    }
    return 0;
}

drv_usbspec *drv_usbspec_open(const struct drv_usbspec_cfg *cfg, struct gonio_err *err)
{
    drv_usbspec *s = calloc(1, sizeof *s);
    if (!s) {
        gonio_err_set(err, ENOMEM, "usb spectrometer: out of memory");
        return NULL;
    }
    int has_serial = cfg->serial && cfg->serial[0];
    snprintf(s->who, sizeof s->who, "usb spectrometer %04x:%04x%s%.40s%s", cfg->vendor,
             cfg->product, has_serial ? " (serial " : "", has_serial ? cfg->serial : "",
             has_serial ? ")" : "");
    s->timeout_s = cfg->timeout_s > 0 ? cfg->timeout_s : 1.0;
    int rc = libusb_init(&s->ctx);
    if (rc < 0) {
        gonio_err_set(err, GONIO_EDEVICE, "%s: libusb_init: %s", s->who, libusb_error_name(rc));
        free(s);
        return NULL;
    }
    unsigned char init = CMD_INIT;
    struct drv_usbspec_status st;
    if ((rc = find_device(s, cfg, err)) < 0 ||
        (rc = command(s, &init, 1, "initialise", err)) < 0 ||
        (rc = read_calibration(s, err)) < 0 || (rc = read_nonlinearity(s, err)) < 0 ||
        (rc = drv_usbspec_status(s, &st, err)) < 0) {
        drv_usbspec_close(s);
        return NULL;
    }
    if (st.pixels != DRV_USBSPEC_PIXELS) {
        gonio_err_set(err, GONIO_EDEVICE, "%s: query status: %u pixels, this driver reads %d",
                      s->who, st.pixels, DRV_USBSPEC_PIXELS);
        drv_usbspec_close(s);
        return NULL;
    }
    s->packet = st.high_speed ? 512 : 64;
    return s;
}

void drv_usbspec_close(drv_usbspec *s)
{
    if (!s)
        return;
    /* a transfer libusb never gave back may still point into s: keep s */
    if (s->h && !(s->lost && !s->xs.done)) {
        libusb_release_interface(s->h, 0);
        libusb_close(s->h);
    } else if (s->h) {
        return;
    }
    libusb_exit(s->ctx);
    free(s);
}

void drv_usbspec_wavelengths(const double c[4], size_t n, double *lambda_nm)
{
    for (size_t p = 0; p < n; p++) {
        double x = (double)p;
        lambda_nm[p] = c[0] + x * (c[1] + x * (c[2] + x * c[3]));
    }
}
