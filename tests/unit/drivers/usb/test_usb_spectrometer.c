/* The USB spectrometer driver against replayed USB traffic (umockdev).
 *
 * Runs with libumockdev-preload in LD_PRELOAD (ctest sets it; by hand:
 * umockdev-wrapper build/tests/test_usb_spectrometer), the library that
 * routes /sys, /dev and usbdevfs ioctls into a testbed. Each test builds a testbed from
 * usb2000plus.umockdev and replays one .ioctl recording of this folder
 * (make_recordings.py wrote them): libusb, and so the driver, see a
 * USB2000+ on bus 1 as device 5. The timeout tests need a device that
 * stays silent, which a recording cannot express (the replay answers every
 * URB at once), so they attach a small scripted usbdevfs handler instead.
 *
 * Expected values come from the recordings themselves: the test parses the
 * calibration replies and the spectrum packets out of the .ioctl file and
 * computes the bands by numerical integration of the nearest-pixel
 * spectrum, independently of the driver's overlap weights. */
#include <errno.h>
#include <linux/usbdevice_fs.h>
#include <string.h>
#include <sys/ioctl.h>

#include <umockdev.h>

#include "tests/gonio_test.h"
#include "tests/unit/drivers/usb/usb_test.h"

#include "brdf/colour.h"
#include "common/clock.h"
#include "drivers/drv_usbspec.h"

/* ---- reading the recording back ------------------------------------- */

struct urb_rec {
    int ep, status, actual;
    unsigned char data[512];
};

static int read_recording(const char *name, struct urb_rec *out, int max)
{
    char path[1024], line[2048];
    snprintf(path, sizeof path, "%s/%s", USB_DATA_DIR, name);
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    int n = 0;
    while (fgets(line, sizeof line, f) && n < max) {
        const char *s = line + strspn(line, " ");
        int ret, type, flags, len, errc, off = 0;
        struct urb_rec *u = &out[n];
        if (sscanf(s, "USBDEVFS_REAPURBNDELAY %d %d %d %d %d %d %d %d %n", &ret, &type, &u->ep,
                   &u->status, &flags, &len, &u->actual, &errc, &off) < 8)
            continue;
        for (int i = 0; i < u->actual; i++) {
            unsigned byte;
            assert_int_equal(sscanf(s + off + 2 * i, "%2x", &byte), 1);
            u->data[i] = (unsigned char)byte;
        }
        n++;
    }
    fclose(f);
    return n;
}

/* A query-information slot: the ASCII of the reply that follows "0x05 slot". */
static double recorded_slot(const struct urb_rec *r, int n, int slot)
{
    for (int i = 0; i + 1 < n; i++)
        if (r[i].ep == 0x01 && r[i].actual == 2 && r[i].data[0] == 0x05 &&
            r[i].data[1] == slot && r[i + 1].ep == 0x81)
            return strtod((const char *)r[i + 1].data + 2, NULL);
    return NAN;
}

/* Calibration: slots 1-4. */
static void recorded_coefficients(const struct urb_rec *r, int n, double c[4])
{
    for (int k = 0; k < 4; k++)
        c[k] = recorded_slot(r, n, k + 1);
}

/* Counts: the eight 512-byte packets from EP 0x82 after the request 0x09. */
static void recorded_counts(const struct urb_rec *r, int n, double *counts)
{
    int i = 0;
    while (i < n && !(r[i].ep == 0x01 && r[i].actual == 1 && r[i].data[0] == 0x09))
        i++;
    assert_true(i + 8 < n);
    for (int k = 0; k < 8; k++) {
        const struct urb_rec *u = &r[i + 1 + k];
        assert_int_equal(u->ep, 0x82);
        assert_int_equal(u->actual, 512);
        for (int j = 0; j < 256; j++)
            counts[256 * k + j] = u->data[2 * j] | u->data[2 * j + 1] << 8;
    }
}

/* Each pixel's wavelength (the calibration's cubic) and its counts above
 * the electric dark, the mean of pixels 6-20 (the masked ones). */
static void recorded_pixels(const struct urb_rec *r, int n, double *lam, double *y)
{
    double c[4], counts[DRV_USBSPEC_PIXELS], dark = 0;
    recorded_coefficients(r, n, c);
    recorded_counts(r, n, counts);
    for (int p = 6; p <= 20; p++)
        dark += counts[p] / 15.0;
    for (int p = 0; p < DRV_USBSPEC_PIXELS; p++) {
        double x = p;
        lam[p] = c[0] + c[1] * x + c[2] * x * x + c[3] * x * x * x;
        y[p] = counts[p] - dark;
    }
}

/* The band mean of the nearest-pixel spectrum, by midpoint quadrature on M
 * cells. Only a cell holding a pixel boundary is misassigned, by at most
 * the jump there over M: *bound receives the sum of those, the quadrature's
 * whole error (the box's own ends are cell ends). */
static double band_mean(const double *lam, const double *v, double lo, double hi,
                        double *bound)
{
    enum { M = 200000 };
    double sum = 0;
    int p = 0, first = -1;
    for (int j = 0; j < M; j++) {
        double x = lo + (j + 0.5) * (hi - lo) / M;
        while (p + 1 < DRV_USBSPEC_PIXELS && fabs(lam[p + 1] - x) < fabs(lam[p] - x))
            p++;
        if (first < 0)
            first = p;
        sum += v[p];
    }
    /* the boundaries inside the box, and one either side for the end cells */
    *bound = 0;
    for (int q = first > 0 ? first - 1 : 0; q <= p && q + 1 < DRV_USBSPEC_PIXELS; q++)
        *bound += fabs(v[q + 1] - v[q]) / M;
    return sum / M;
}

/* ---- the tests --------------------------------------------------------- */

/* Replayed replies come at once, but slowly under valgrind: a generous
 * timeout for them, a short one where the device is meant to stay silent. */
static double timeout_s = 2.0;

static struct drv_usbspec_cfg cfg_default(void)
{
    struct drv_usbspec_cfg c;
    drv_usbspec_cfg_default(&c);
    c.timeout_s = timeout_s;
    return c;
}

static void test_open_reads_calibration(void **state)
{
    (void)state;
    UMockdevTestbed *tb = usb_test_testbed("spectrum.ioctl");
    struct urb_rec rec[64];
    int n = read_recording("spectrum.ioctl", rec, 64);
    double want[4], got[4];
    recorded_coefficients(rec, n, want);
    struct drv_usbspec_cfg cfg = cfg_default();
    cfg.serial = "USB2+F01234";
    struct gonio_err err = {0};
    drv_usbspec *s = drv_usbspec_open(&cfg, &err);
    if (!s)
        fail_msg("open: %s", err.msg);
    drv_usbspec_coefficients(s, got);
    for (int k = 0; k < 4; k++)
        assert_close(got[k], want[k], 0); /* the same ASCII, the same strtod */
    assert_string_equal(drv_usbspec_serial(s), "USB2+F01234");
    drv_usbspec_close(s);
    g_object_unref(tb);
}

static void test_other_serial_is_not_opened(void **state)
{
    (void)state;
    UMockdevTestbed *tb = usb_test_testbed("spectrum.ioctl");
    struct drv_usbspec_cfg cfg = cfg_default();
    cfg.serial = "USB2+F99999";
    struct gonio_err err = {0};
    assert_null(drv_usbspec_open(&cfg, &err));
    assert_int_equal(err.code, GONIO_EDEVICE);
    assert_non_null(strstr(err.msg, "no such device"));
    assert_non_null(strstr(err.msg, "USB2+F99999"));
    g_object_unref(tb);
}

/* Integration time 0.1 s (the recording expects exactly 02 A0 86 01 00:
 * any other bytes find no URB to replay and fail), then the spectrum. */
static void check_spectrum(double first_nm, int n_bands)
{
    UMockdevTestbed *tb = usb_test_testbed("spectrum.ioctl");
    struct urb_rec rec[64];
    int n = read_recording("spectrum.ioctl", rec, 64);
    double lam[DRV_USBSPEC_PIXELS], v[DRV_USBSPEC_PIXELS];
    recorded_pixels(rec, n, lam, v);
    struct drv_usbspec_cfg cfg = cfg_default();
    cfg.first_nm = first_nm;
    cfg.n_bands = n_bands;
    cfg.scale = 2.5e-5;
    struct gonio_err err = {0};
    drv_detector *det = usb_test_detector(&cfg);
    struct drv_reading r;
    if (drv_detector_acquire(det, 0.1, &r, &err) < 0)
        fail_msg("acquire: %s", err.msg);
    assert_close(r.integration_s, 0.1, 1e-12);
    assert_int_equal(r.flags, 0);
    const double *centres, *spec;
    assert_int_equal(drv_usbspec_last_spectrum(det, &centres, &spec), n_bands);
    double k = cfg.scale / 0.1;
    for (int b = 0; b < n_bands; b++) {
        assert_close(centres[b], first_nm + 10 * b, 1e-9);
        double bound;
        double want = band_mean(lam, v, centres[b] - 5, centres[b] + 5, &bound);
        /* counts: within the quadrature's own bound (at most 0.074 counts
         * in this recording; the difference found is at most 0.007), so
         * that a dark level off by a tenth of a count fails */
        assert_true(bound < 0.1);
        assert_close(spec[b] / k, want, bound + 1e-9 * fabs(want));
    }
    /* the reading's colour is the colour of that spectrum */
    double xyz[3], rgb[3];
    assert_int_equal(brdf_colour_spectrum_to_xyz(centres, spec, (size_t)n_bands, xyz, NULL), 0);
    brdf_colour_xyz_to_srgb_linear(xyz, rgb);
    for (int ch = 0; ch < 3; ch++)
        assert_close(r.rgb[ch], rgb[ch], 1e-9 * fabs(rgb[ch]) + 1e-12);
    drv_detector_free(det);
    g_object_unref(tb);
}

/* Counts, the default: every pixel above the electric dark linearised as
 * y / P(y) with the recorded slots 6.. (order in slot 14), the bands
 * resampled as above, and each channel the mean of its bin's bands (R:
 * centres from 595 nm, G: 495-595 nm, B: below), computed here by
 * quadrature. */
static void check_counts(double first_nm, int n_bands)
{
    UMockdevTestbed *tb = usb_test_testbed("spectrum.ioctl");
    struct urb_rec rec[64];
    int n = read_recording("spectrum.ioctl", rec, 64);
    double lam[DRV_USBSPEC_PIXELS], v[DRV_USBSPEC_PIXELS];
    recorded_pixels(rec, n, lam, v);
    int order = (int)recorded_slot(rec, n, 14);
    assert_int_equal(order, 2);
    double nl[3] = {recorded_slot(rec, n, 6), recorded_slot(rec, n, 7),
                    recorded_slot(rec, n, 8)};
    for (int p = 0; p < DRV_USBSPEC_PIXELS; p++) {
        double y = v[p];
        v[p] = y / (nl[0] + nl[1] * y + nl[2] * y * y);
    }
    struct drv_usbspec_cfg cfg = cfg_default();
    cfg.first_nm = first_nm;
    cfg.n_bands = n_bands;
    struct gonio_err err = {0};
    drv_detector *det = usb_test_detector(&cfg);
    struct drv_reading r;
    if (drv_detector_acquire(det, 0.1, &r, &err) < 0)
        fail_msg("acquire: %s", err.msg);
    assert_int_equal(r.unit, DRV_UNIT_COUNTS);
    assert_close(r.integration_s, 0.1, 1e-12);
    assert_int_equal(r.flags, 0);
    assert_int_equal(r.gain_state, 0);
    assert_close(r.nonlinearity, 0, 0); /* undone per pixel, before the bands */
    double y = 65535;
    assert_close(r.full_scale, y / (nl[0] + nl[1] * y + nl[2] * y * y), 1e-9);
    double want[3] = {0, 0, 0}, tol[3] = {0, 0, 0};
    int in_bin[3] = {0, 0, 0};
    for (int b = 0; b < n_bands; b++) {
        double centre = first_nm + 10 * b, bound;
        int ch = centre >= 595 ? 0 : centre >= 495 ? 1 : 2;
        want[ch] += band_mean(lam, v, centre - 5, centre + 5, &bound);
        tol[ch] += bound;
        in_bin[ch]++;
    }
    assert_int_equal(in_bin[2], first_nm < 400 ? 11 : 10);
    for (int ch = 0; ch < 3; ch++) {
        assert_true(want[ch] > 1000);
        assert_close(r.rgb[ch], want[ch] / in_bin[ch], (tol[ch] + 1e-6) / in_bin[ch]);
    }
    drv_detector_free(det);
    g_object_unref(tb);
}

static void test_counts_31_bands(void **state)
{
    (void)state;
    check_counts(400, 31);
}

static void test_counts_35_bands(void **state)
{
    (void)state;
    check_counts(390, 35);
}

/* A nonlinearity correction that turns back (P negative near full scale)
 * would read more light as less: refused at open, naming the slots. */
static void test_bad_nonlinearity_refused(void **state)
{
    (void)state;
    UMockdevTestbed *tb = usb_test_testbed("bad_nonlinearity.ioctl");
    struct drv_usbspec_cfg cfg = cfg_default();
    struct gonio_err err = {0};
    assert_null(drv_usbspec_open(&cfg, &err));
    assert_int_equal(err.code, GONIO_EDEVICE);
    fprintf(stderr, "  %s\n", err.msg);
    if (!strstr(err.msg, "nonlinearity correction (slots 6-7") ||
        !strstr(err.msg, "must be positive and increase"))
        fail_msg("message: %s", err.msg);
    g_object_unref(tb);
}

static void test_spectrum_31_bands(void **state)
{
    (void)state;
    check_spectrum(400, 31);
}

static void test_spectrum_35_bands(void **state)
{
    (void)state;
    check_spectrum(390, 35);
}

/* One pixel at full scale (65535, near 596 nm) flags the reading, and
 * its channel (R: the 600 nm band's box reaches 595 nm) reads the top of
 * the scale, which the reduction gives no value; the others read light. */
static void test_saturated_pixel_flags_the_reading(void **state)
{
    (void)state;
    UMockdevTestbed *tb = usb_test_testbed("saturated.ioctl");
    struct drv_usbspec_cfg cfg = cfg_default();
    struct gonio_err err = {0};
    drv_detector *det = usb_test_detector(&cfg);
    struct drv_reading r;
    if (drv_detector_acquire(det, 0.1, &r, &err) < 0)
        fail_msg("acquire: %s", err.msg);
    assert_int_equal(r.flags, DRV_READING_SATURATED);
    assert_int_equal(r.unit, DRV_UNIT_COUNTS);
    assert_close(r.rgb[0], r.full_scale, 0);
    assert_true(r.rgb[1] > 1000 && r.rgb[1] < 0.9 * r.full_scale);
    assert_true(r.rgb[2] > 1000 && r.rgb[2] < 0.9 * r.full_scale);
    drv_detector_free(det);
    g_object_unref(tb);
}

/* Open a detector on a recording, acquire, expect failure naming `a` and `b`. */
static void expect_acquire_failure(const char *recording, const char *a, const char *b,
                                   drv_detector **keep)
{
    struct drv_usbspec_cfg cfg = cfg_default();
    struct gonio_err err = {0};
    drv_detector *det = usb_test_detector(&cfg);
    struct drv_reading r;
    assert_int_equal(drv_detector_acquire(det, 0.1, &r, &err), -GONIO_EDEVICE);
    assert_int_equal(err.code, GONIO_EDEVICE);
    fprintf(stderr, "  %s: %s\n", recording, err.msg); /* the operator's view */
    if (!strstr(err.msg, a) || !strstr(err.msg, b))
        fail_msg("%s: message '%s' lacks '%s' or '%s'", recording, err.msg, a, b);
    if (keep)
        *keep = det;
    else
        drv_detector_free(det);
}

static void test_short_read(void **state)
{
    (void)state;
    UMockdevTestbed *tb = usb_test_testbed("short_read.ioctl");
    expect_acquire_failure("short_read.ioctl", "packet 3 of 8",
                           "short read: 100 of 512 bytes from EP 0x82", NULL);
    g_object_unref(tb);
}

static void test_wrong_sync_byte(void **state)
{
    (void)state;
    UMockdevTestbed *tb = usb_test_testbed("bad_sync.ioctl");
    expect_acquire_failure("bad_sync.ioctl", "read spectrum", "sync byte 0x00, expected 0x69",
                           NULL);
    g_object_unref(tb);
}

/* The kernel ends the in-flight URB with -ESHUTDOWN when the device goes;
 * the next call must fail at once instead of touching a dead handle. */
static void test_unplugged_mid_read(void **state)
{
    (void)state;
    UMockdevTestbed *tb = usb_test_testbed("unplug.ioctl");
    drv_detector *det = NULL;
    expect_acquire_failure("unplug.ioctl", "packet 4 of 8", "device unplugged", &det);
    struct drv_reading r;
    struct gonio_err err = {0};
    assert_int_equal(drv_detector_acquire(det, 0.1, &r, &err), -GONIO_EDEVICE);
    assert_non_null(strstr(err.msg, "lost earlier"));
    drv_detector_free(det);
    g_object_unref(tb);
}

static void test_bad_calibration_reply(void **state)
{
    (void)state;
    UMockdevTestbed *tb = usb_test_testbed("bad_calibration.ioctl");
    struct drv_usbspec_cfg cfg = cfg_default();
    struct gonio_err err = {0};
    assert_null(drv_usbspec_open(&cfg, &err));
    assert_int_equal(err.code, GONIO_EDEVICE);
    if (!strstr(err.msg, "coefficient 1 (slot 2)") || !strstr(err.msg, "'0.38O5263'"))
        fail_msg("message: %s", err.msg);
    g_object_unref(tb);
}

/* ---- a device that stops answering ----------------------------------- */

/* A scripted USB2000+ on usbdevfs: answers the opening queries and the
 * status, sends `packets` spectrum packets after a request and then stays
 * silent; an URB it does not answer stays pending until libusb discards it
 * (its own timeout), as the kernel does with a silent device. Runs on the
 * testbed's thread. */
struct silent_dev {
    int packets, sent;
    GQueue done;               /* UMockdevIoctlData of URBs ready to reap */
    UMockdevIoctlData *pending;
    unsigned char reply[32];   /* queued EP 0x81 reply */
    int reply_len;
};

static void urb_finish(struct silent_dev *d, UMockdevIoctlData *u, const unsigned char *data,
                       int len, int status)
{
    struct usbdevfs_urb *urb = (struct usbdevfs_urb *)u->data;
    if (len > 0) {
        GError *e = NULL;
        UMockdevIoctlData *buf = umockdev_ioctl_data_resolve(
            u, offsetof(struct usbdevfs_urb, buffer), (gsize)urb->buffer_length, &e);
        if (buf) {
            umockdev_ioctl_data_update(buf, 0, (guint8 *)data, len);
            g_object_unref(buf);
        }
    }
    int fields[2] = {status, len};
    umockdev_ioctl_data_update(u, offsetof(struct usbdevfs_urb, status), (guint8 *)&fields[0],
                               sizeof(int));
    umockdev_ioctl_data_update(u, offsetof(struct usbdevfs_urb, actual_length),
                               (guint8 *)&fields[1], sizeof(int));
    g_queue_push_tail(&d->done, g_object_ref(u));
}

static void on_command(struct silent_dev *d, const unsigned char *c, int len)
{
    /* slots 1-4: wavelengths; 6: the nonlinearity's c0, 14: its order */
    static const char *slot[15] = {[1] = "339.620361", [2] = "0.3805263",
                                   [3] = "-1.953270E-05", [4] = "-1.18845E-09", [6] = "1",
                                   [14] = "0"};
    d->reply_len = 0;
    if (c[0] == 0x05 && len == 2 && c[1] < 15 && slot[c[1]]) {
        memset(d->reply, 0, 17);
        d->reply[0] = 0x05;
        d->reply[1] = c[1];
        memcpy(d->reply + 2, slot[c[1]], strlen(slot[c[1]]));
        d->reply_len = 17;
    } else if (c[0] == 0xFE) {
        static const unsigned char st[16] = {0x00, 0x08, 0xA0, 0x86, 0x01, 0x00, 0, 0,
                                             0, 9, 1, 0, 0, 0, 0x80, 0};
        memcpy(d->reply, st, 16);
        d->reply_len = 16;
    } else if (c[0] == 0x09) {
        d->sent = 0;
    }
}

static gboolean silent_ioctl(UMockdevIoctlBase *base, UMockdevIoctlClient *client, gpointer p)
{
    (void)base;
    struct silent_dev *d = p;
    gulong req = umockdev_ioctl_client_get_request(client);
    UMockdevIoctlData *arg = umockdev_ioctl_client_get_arg(client);
    GError *e = NULL;
    if (req == USBDEVFS_SUBMITURB) {
        UMockdevIoctlData *u = umockdev_ioctl_data_resolve(arg, 0, sizeof(struct usbdevfs_urb),
                                                           &e);
        struct usbdevfs_urb *urb = (struct usbdevfs_urb *)u->data;
        if (!(urb->endpoint & 0x80)) {
            UMockdevIoctlData *buf = umockdev_ioctl_data_resolve(
                u, offsetof(struct usbdevfs_urb, buffer), (gsize)urb->buffer_length, &e);
            on_command(d, buf->data, urb->buffer_length);
            g_object_unref(buf);
            urb_finish(d, u, NULL, 0, 0);
            int all = urb->buffer_length;
            umockdev_ioctl_data_update(u, offsetof(struct usbdevfs_urb, actual_length),
                                       (guint8 *)&all, sizeof all);
        } else if (urb->endpoint == 0x81 && d->reply_len) {
            urb_finish(d, u, d->reply, d->reply_len, 0);
            d->reply_len = 0;
        } else if (urb->endpoint == 0x82 && d->sent < d->packets) {
            unsigned char pk[512];
            for (int i = 0; i < 512; i++)
                pk[i] = (unsigned char)(i & 1 ? 0x10 : 0x00);
            urb_finish(d, u, pk, 512, 0);
            d->sent++;
        } else {
            d->pending = g_object_ref(u); /* silent */
        }
        /* resolve gave us a reference of our own; the queues hold theirs. */
        g_object_unref(u);
        umockdev_ioctl_client_complete(client, 0, 0);
    } else if (req == USBDEVFS_REAPURB || req == USBDEVFS_REAPURBNDELAY) {
        UMockdevIoctlData *u = g_queue_pop_head(&d->done);
        if (!u) {
            umockdev_ioctl_client_complete(client, -1, EAGAIN);
            return TRUE;
        }
        UMockdevIoctlData *out = umockdev_ioctl_data_resolve(arg, 0, sizeof(void *), &e);
        umockdev_ioctl_data_set_ptr(out, 0, u);
        g_object_unref(out); /* resolve returns a reference of our own (valgrind) */
        g_object_unref(u);
        umockdev_ioctl_client_complete(client, 0, 0);
    } else if (req == USBDEVFS_DISCARDURB) {
        if (!d->pending) {
            umockdev_ioctl_client_complete(client, -1, EINVAL);
            return TRUE;
        }
        urb_finish(d, d->pending, NULL, 0, -ENOENT);
        g_object_unref(d->pending);
        d->pending = NULL;
        umockdev_ioctl_client_complete(client, 0, 0);
    } else { /* claim/release interface, capabilities: accepted */
        umockdev_ioctl_client_complete(client, 0, 0);
    }
    return TRUE;
}

/* A testbed whose USB2000+ is the scripted dev. */
static UMockdevTestbed *silent_testbed(struct silent_dev *dev, UMockdevIoctlBase **handler)
{
    UMockdevTestbed *tb = usb_test_testbed(NULL);
    g_queue_init(&dev->done);
    *handler = umockdev_ioctl_base_new();
    g_signal_connect(*handler, "handle-ioctl", G_CALLBACK(silent_ioctl), dev);
    GError *e = NULL;
    if (!umockdev_testbed_attach_ioctl(tb, USB_TEST_DEVNODE, *handler, &e))
        fail_msg("attach: %s", e->message);
    return tb;
}

static void silent_testbed_free(UMockdevTestbed *tb, struct silent_dev *dev,
                                UMockdevIoctlBase *handler)
{
    g_object_unref(tb);
    g_object_unref(handler);
    while (!g_queue_is_empty(&dev->done))
        g_object_unref(g_queue_pop_head(&dev->done));
}

static void check_timeout(int packets, const char *step)
{
    struct silent_dev dev = {.packets = packets};
    UMockdevIoctlBase *handler;
    UMockdevTestbed *tb = silent_testbed(&dev, &handler);
    timeout_s = 0.5;
    expect_acquire_failure("silent device", step, "timed out", NULL);
    timeout_s = 2.0;
    silent_testbed_free(tb, &dev, handler);
}

static void test_timeout_before_first_packet(void **state)
{
    (void)state;
    check_timeout(0, "packet 1 of 8");
}

static void test_timeout_waiting_for_sync_byte(void **state)
{
    (void)state;
    check_timeout(8, "sync byte");
}

/* The host's stop, while the device integrates for as long as its timeout
 * allows (30 s here, 655 s at most): asked every 0.1 s, it cancels the
 * pending transfer and the read fails as cancelled within a fraction of a
 * second of the request, the device refusing further use until reopened. */
static double stop_at;

static int stop_requested(void *user)
{
    (void)user;
    return gonio_monotonic_s() >= stop_at;
}

static void test_cancel_while_integrating(void **state)
{
    (void)state;
    struct silent_dev dev = {.packets = 0};
    UMockdevIoctlBase *handler;
    UMockdevTestbed *tb = silent_testbed(&dev, &handler);
    timeout_s = 30.0;
    struct drv_usbspec_cfg cfg = cfg_default();
    timeout_s = 2.0;
    struct gonio_err err = {0};
    drv_usbspec *s = drv_usbspec_open(&cfg, &err);
    if (!s)
        fail_msg("open: %s", err.msg);
    drv_usbspec_set_cancel(s, stop_requested, NULL);
    drv_detector *det = drv_detector_new_usbspec(s, &cfg, &err);
    assert_non_null(det);
    struct drv_reading r;
    double t0 = gonio_monotonic_s();
    stop_at = t0 + 0.3;
    assert_int_equal(drv_detector_acquire(det, 0.1, &r, &err), -ECANCELED);
    double took = gonio_monotonic_s() - t0;
    fprintf(stderr, "  cancelled after %.3f s: %s\n", took, err.msg);
    assert_non_null(strstr(err.msg, "cancelled"));
    /* 0.3 s to the request, then one 0.1 s slice and the discard; far
     * below the 30 s the transfer would have waited */
    assert_true(took < 0.3 + 2.0 * gonio_test_time_factor());
    assert_int_equal(drv_detector_acquire(det, 0.1, &r, &err), -GONIO_EDEVICE);
    assert_non_null(strstr(err.msg, "lost"));
    drv_detector_free(det);
    silent_testbed_free(tb, &dev, handler);
}

/* ---- resampling alone -------------------------------------------------- */

static void test_resample_flat_and_bounds(void **state)
{
    (void)state;
    double lam[100], v[100], out[3];
    for (int p = 0; p < 100; p++) {
        lam[p] = 400 + 0.3 * p + 0.001 * p * p; /* uneven spacing */
        v[p] = 7;
    }
    double centres[3] = {405, 410, 420};
    assert_int_equal(drv_usbspec_resample(lam, v, 100, centres, 3, 10, out, NULL), 0);
    for (int b = 0; b < 3; b++)
        assert_close(out[b], 7, 1e-12);
    double beyond[1] = {440}; /* 435-445 nm: the pixels end near 439.6 nm */
    struct gonio_err err = {0};
    assert_int_equal(drv_usbspec_resample(lam, v, 100, beyond, 1, 10, out, &err),
                     -GONIO_EBADDATA);
    assert_non_null(strstr(err.msg, "beyond"));
    lam[50] = lam[49];
    assert_int_equal(drv_usbspec_resample(lam, v, 100, centres, 1, 10, out, &err),
                     -GONIO_EBADDATA);
    assert_non_null(strstr(err.msg, "pixel 50"));
}

int main(void)
{
    if (usb_test_no_preload())
        return 77;
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_resample_flat_and_bounds),
        cmocka_unit_test(test_open_reads_calibration),
        cmocka_unit_test(test_other_serial_is_not_opened),
        cmocka_unit_test(test_counts_31_bands),
        cmocka_unit_test(test_counts_35_bands),
        cmocka_unit_test(test_bad_nonlinearity_refused),
        cmocka_unit_test(test_spectrum_31_bands),
        cmocka_unit_test(test_spectrum_35_bands),
        cmocka_unit_test(test_saturated_pixel_flags_the_reading),
        cmocka_unit_test(test_short_read),
        cmocka_unit_test(test_wrong_sync_byte),
        cmocka_unit_test(test_unplugged_mid_read),
        cmocka_unit_test(test_bad_calibration_reply),
        cmocka_unit_test(test_timeout_before_first_packet),
        cmocka_unit_test(test_timeout_waiting_for_sync_byte),
        cmocka_unit_test(test_cancel_while_integrating),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
