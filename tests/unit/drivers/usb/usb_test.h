/* What the USB tests share: the testbed of a replayed USB2000+ (umockdev)
 * and the detector opened on it. Include after tests/gonio_test.h. */
#ifndef GONIO_TESTS_USB_TEST_H
#define GONIO_TESTS_USB_TEST_H

#include <stdlib.h>
#include <string.h>

#include <umockdev.h>

#include "drivers/drv_usbspec.h"

#define USB_TEST_DEVNODE "/dev/bus/usb/001/005"

/* A testbed with the USB2000+ of usb2000plus.umockdev on bus 1 as device
 * 5, replaying the .ioctl recording of this folder (NULL: none, for a
 * scripted handler). */
static inline UMockdevTestbed *usb_test_testbed(const char *recording)
{
    UMockdevTestbed *tb = umockdev_testbed_new();
    GError *e = NULL;
    char path[1024];
    snprintf(path, sizeof path, "%s/usb2000plus.umockdev", USB_DATA_DIR);
    if (!umockdev_testbed_add_from_file(tb, path, &e))
        fail_msg("%s: %s", path, e->message);
    if (recording) {
        snprintf(path, sizeof path, "%s/%s", USB_DATA_DIR, recording);
        if (!umockdev_testbed_load_ioctl(tb, USB_TEST_DEVNODE, path, &e))
            fail_msg("%s: %s", path, e->message);
    }
    return tb;
}

/* The spectrometer of cfg opened as a detector; the test fails, naming
 * the step, where it cannot be. */
static inline drv_detector *usb_test_detector(const struct drv_usbspec_cfg *cfg)
{
    struct gonio_err err = {0};
    drv_usbspec *s = drv_usbspec_open(cfg, &err);
    if (!s)
        fail_msg("open: %s", err.msg);
    drv_detector *det = drv_detector_new_usbspec(s, cfg, &err);
    if (!det)
        fail_msg("detector: %s", err.msg);
    return det;
}

/* Nonzero, having said SKIPPED, when the preload library that routes
 * libusb into the testbed is not loaded. umockdev_in_mock_environment()
 * answers 0 under the wrapper in umockdev 0.17.16, so look for the
 * library itself. */
static inline int usb_test_no_preload(void)
{
    const char *preload = getenv("LD_PRELOAD");
    if (preload && strstr(preload, "libumockdev-preload"))
        return 0;
    fprintf(stderr, "SKIPPED: needs libumockdev-preload in LD_PRELOAD (ctest sets it; "
                    "or run through umockdev-wrapper)\n");
    return 1;
}

#endif
