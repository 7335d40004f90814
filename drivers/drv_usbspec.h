/* An Ocean Optics USB2000+-class spectrometer on libusb-1.0, speaking the
 * OOI bulk protocol (docs/usb-spectrometer.md): commands go to EP 0x01,
 * replies to queries come from EP 0x81, spectra from EP 0x82 in 512-byte
 * packets (64-byte at full speed) closed by the sync byte 0x69.
 *
 * Opening claims the device, initialises it (0x01), reads the wavelength
 * calibration (query information 0x05, slots 1-4: the coefficients c0..c3
 * of lambda(p) = c0 + c1 p + c2 p^2 + c3 p^3 as ASCII) and the status
 * (0xFE), and the factory's nonlinearity correction (slot 14: the order
 * of P, slots 6-13: its coefficients c0..c7; a count y above the electric
 * dark is linearised as y / P(y)). A spectrum (0x09) is 2048 little-endian 16-bit counts; it is
 * resampled onto the configured bands (by default 31 bands 400-700 nm, or
 * 35 bands 390-730 nm, each a 10 nm box around its centre).
 *
 * Every transfer has a deadline (the transfer timeout, plus the
 * integration time when the device is integrating), enforced by our own
 * event loop rather than libusb's synchronous calls, which retry forever
 * when event handling itself fails. A timeout, a short read, a missing
 * sync byte or a device unplugged mid-read (LIBUSB_ERROR_NO_DEVICE) fails
 * with -GONIO_EDEVICE and a message naming the device and the step, e.g.
 * "usb spectrometer 2457:101e: read spectrum: packet 3 of 8 from EP 0x82:
 * device unplugged". After an unplug the handle refuses further work. */
#ifndef GONIO_DRIVERS_DRV_USBSPEC_H
#define GONIO_DRIVERS_DRV_USBSPEC_H

#include <stddef.h>
#include <stdint.h>

#include "common/err.h"
#include "drivers/drivers.h"

#define DRV_USBSPEC_PIXELS 2048
#define DRV_USBSPEC_MAX_BANDS 64
#define DRV_USBSPEC_MIN_US 1000u      /* the USB2000+'s integration range */
#define DRV_USBSPEC_MAX_US 655350000u
#define DRV_USBSPEC_FULL_SCALE 65535  /* the 16-bit ADC's largest count */
#define DRV_USBSPEC_NL_MAX 7          /* the nonlinearity polynomial's highest order */

struct drv_usbspec_cfg {
    int vendor, product;  /* USB ids; defaults 0x2457, 0x101e (USB2000+) */
    const char *serial;   /* NULL or "": the first device with these ids */
    double timeout_s;     /* per transfer beyond the integration; default 1 */
    /* Band centres first_nm + k * step_nm, k < n_bands, each band a box of
     * width step_nm. Default 400, 10, 31. */
    double first_nm, step_nm;
    int n_bands;
    /* 0 (the default): the detector reports counts, which a calibration
     * reduces to BRDF (docs/radiometry.md). > 0: a shortcut that reports
     * BRDF as dark-corrected band counts times scale per second of
     * integration (a white reference's constant, measured once), with no
     * dark frame, reference standard or uncertainty. */
    double scale;
};

void drv_usbspec_cfg_default(struct drv_usbspec_cfg *cfg);

typedef struct drv_usbspec drv_usbspec;

/* Find, claim and initialise the device; read calibration and status.
 * NULL with err filled (the step that failed) on failure. */
drv_usbspec *drv_usbspec_open(const struct drv_usbspec_cfg *cfg, struct gonio_err *err);
void drv_usbspec_close(drv_usbspec *s);

/* The calibration coefficients c0..c3 read at open. */
void drv_usbspec_coefficients(const drv_usbspec *s, double c[4]);
/* The nonlinearity correction read at open: c0..c[*order] of P. */
void drv_usbspec_nonlinearity(const drv_usbspec *s, double c[DRV_USBSPEC_NL_MAX + 1],
                              int *order);
/* y / P(y), P(y) = c0 + c1 y + ... + c_order y^order: a count y above the
 * electric dark with the detector's nonlinearity undone. */
double drv_usbspec_linearise(const double *c, int order, double y);
/* The serial number the device reports in sysfs ("" when unknown). */
const char *drv_usbspec_serial(const drv_usbspec *s);

struct drv_usbspec_status {
    unsigned pixels;          /* bytes 0-1 */
    uint32_t integration_us;  /* bytes 2-5 */
    int lamp_enabled;         /* byte 6 */
    int trigger_mode;         /* byte 7 */
    int high_speed;           /* byte 14: 0x80 high speed, 0 full speed */
};

/* Query status (0xFE). */
int drv_usbspec_status(drv_usbspec *s, struct drv_usbspec_status *st, struct gonio_err *err);

/* Set the integration time (0x02), microseconds within the device's range. */
int drv_usbspec_set_integration(drv_usbspec *s, uint32_t us, struct gonio_err *err);

/* Request a spectrum (0x09) and read it: counts[DRV_USBSPEC_PIXELS]. */
int drv_usbspec_read_raw(drv_usbspec *s, uint16_t *counts, struct gonio_err *err);

/* The host's cancel check (NULL: none), asked at least every 0.1 s while a
 * transfer is pending: once it says so, the transfer is cancelled and the
 * call fails with -ECANCELED ("...: cancelled"); the device is then out of
 * step and refuses further use until it is opened again. */
void drv_usbspec_set_cancel(drv_usbspec *s, int (*cancelled)(void *user), void *user);

/* Pixel wavelengths lambda[n] = c0 + c1 p + c2 p^2 + c3 p^3. */
void drv_usbspec_wavelengths(const double c[4], size_t n, double *lambda_nm);

/* Resample a spectrum v[n] at increasing pixel wavelengths lambda[n] onto
 * n_bands boxes of width width_nm centred on centres[]: each band is the
 * mean of the piecewise-constant spectrum (pixel p covers the interval
 * between the midpoints to its neighbours) over the box, i.e. every pixel
 * weighted by its overlap with the box. Fails (-GONIO_EBADDATA) when the
 * wavelengths do not increase or a box reaches beyond the pixels. */
int drv_usbspec_resample(const double *lambda_nm, const double *v, size_t n,
                         const double *centres_nm, size_t n_bands, double width_nm,
                         double *out, struct gonio_err *err);

/* The detector of the capture engine (drivers/drivers.h). Each acquire sets
 * the integration time when it changed, reads a spectrum and subtracts the
 * electric dark level (mean of the optically masked pixels 6-20).
 *
 * Counts (scale 0): each pixel is linearised with the device's correction,
 * the pixels are resampled onto the bands, and the reading's three
 * channels are the mean band counts of three broad bins, R: bands centred
 * at 595 nm and above, G: 495-595 nm, B: below 495 nm (DRV_UNIT_COUNTS,
 * gain state 0, nonlinearity 0 as it is undone here; full_scale the
 * linearised top of the ADC, which a channel with a pixel at 65535 reads,
 * so that the reduction gives it no value). A calibration's dark frames
 * and reference standard turn each channel into BRDF.
 *
 * BRDF (scale > 0, the shortcut): the band counts times scale / integration
 * time, and the reading the linear sRGB of that spectrum under D65
 * (brdf/spectral.h, as the simulated spectral detector does).
 *
 * A pixel at full scale in the bands' range sets DRV_READING_SATURATED.
 * Bands and scale come from cfg; a band beyond the calibrated pixels fails
 * here. The detector owns s (closed on failure too). */
drv_detector *drv_detector_new_usbspec(drv_usbspec *s, const struct drv_usbspec_cfg *cfg,
                                       struct gonio_err *err);

/* The last acquire's band centres and spectrum of a detector made by
 * drv_detector_new_usbspec (linearised counts above the electric dark, or
 * BRDF in 1/sr with the scale shortcut); returns the band count (0 before
 * the first reading). */
int drv_usbspec_last_spectrum(const drv_detector *d, const double **centres_nm,
                              const double **spectrum);

#endif
