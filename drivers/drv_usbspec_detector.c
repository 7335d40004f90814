/* The USB spectrometer as the capture engine's detector: counts -> dark
 * corrected band spectrum -> BRDF -> linear sRGB (drivers/drv_usbspec.h). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/spectral.h"
#include "drivers/drivers_private.h"
#include "drivers/drv_usbspec.h"

/* Optically masked ("electric dark") pixels of the USB2000+'s detector,
 * as python-seabreeze lists them (docs/usb-spectrometer.md). */
enum { DARK_FIRST = 6, DARK_END = 21, FULL_SCALE = 65535 };

struct usb_detector {
    drv_usbspec *s;
    int n_bands;
    double step_nm, scale;
    double centres[DRV_USBSPEC_MAX_BANDS];
    double w[3 * DRV_USBSPEC_MAX_BANDS]; /* band spectrum -> linear sRGB */
    double lambda[DRV_USBSPEC_PIXELS];
    size_t p_lo, p_hi;                   /* pixels within the bands' range */
    uint32_t set_us;                     /* integration last set, 0: none */
    int have;                            /* a reading is in spectrum[] */
    double spectrum[DRV_USBSPEC_MAX_BANDS];
};

static int usb_acquire(void *priv, double integration_s, struct drv_reading *out,
                       struct gonio_err *err)
{
    struct usb_detector *d = priv;
    double us = nearbyint(integration_s * 1e6);
    if (!(us >= DRV_USBSPEC_MIN_US && us <= DRV_USBSPEC_MAX_US))
        return gonio_err_set(err, EINVAL, "usb spectrometer: integration time %g s outside "
                             "%g-%g s", integration_s, DRV_USBSPEC_MIN_US * 1e-6,
                             DRV_USBSPEC_MAX_US * 1e-6);
    int rc;
    if ((uint32_t)us != d->set_us) {
        d->set_us = 0; /* unknown until the device took it */
        if ((rc = drv_usbspec_set_integration(d->s, (uint32_t)us, err)) < 0)
            return rc;
        d->set_us = (uint32_t)us;
    }
    uint16_t counts[DRV_USBSPEC_PIXELS];
    d->have = 0;
    if ((rc = drv_usbspec_read_raw(d->s, counts, err)) < 0)
        return rc;
    double dark = 0, v[DRV_USBSPEC_PIXELS];
    for (int p = DARK_FIRST; p < DARK_END; p++)
        dark += counts[p];
    dark /= DARK_END - DARK_FIRST;
    unsigned flags = 0;
    for (size_t p = 0; p < DRV_USBSPEC_PIXELS; p++) {
        v[p] = counts[p] - dark;
        if (p >= d->p_lo && p <= d->p_hi && counts[p] >= FULL_SCALE)
            flags |= DRV_READING_SATURATED;
    }
    double t = d->set_us * 1e-6;
    if ((rc = drv_usbspec_resample(d->lambda, v, DRV_USBSPEC_PIXELS, d->centres,
                                   (size_t)d->n_bands, d->step_nm, d->spectrum, err)) < 0)
        return rc;
    for (int b = 0; b < d->n_bands; b++)
        d->spectrum[b] *= d->scale / t;
    for (int c = 0; c < 3; c++) {
        double sum = 0;
        for (int b = 0; b < d->n_bands; b++)
            sum += d->w[3 * b + c] * d->spectrum[b];
        out->rgb[c] = sum;
    }
    out->integration_s = t;
    out->flags = flags;
    d->have = 1;
    return 0;
}

static void usb_free(void *priv)
{
    struct usb_detector *d = priv;
    drv_usbspec_close(d->s);
    free(d);
}

static const struct drv_detector_ops usb_detector_ops = {
    .name = "usb-spectrometer",
    .acquire = usb_acquire,
    .free_priv = usb_free,
};

drv_detector *drv_detector_new_usbspec(drv_usbspec *s, const struct drv_usbspec_cfg *cfg,
                                       struct gonio_err *err)
{
    struct usb_detector *d = calloc(1, sizeof *d);
    if (!d) {
        drv_usbspec_close(s);
        gonio_err_set(err, ENOMEM, "usb spectrometer: out of memory");
        return NULL;
    }
    d->s = s;
    d->n_bands = cfg->n_bands;
    d->step_nm = cfg->step_nm;
    d->scale = cfg->scale;
    int rc = 0;
    if (cfg->n_bands < 3 || cfg->n_bands > DRV_USBSPEC_MAX_BANDS || !(cfg->step_nm > 0) ||
        !isfinite(cfg->first_nm) || !(cfg->scale > 0) || !isfinite(cfg->scale))
        rc = gonio_err_set(err, EINVAL, "usb spectrometer: bands %d from %g nm by %g nm, "
                           "scale %g", cfg->n_bands, cfg->first_nm, cfg->step_nm, cfg->scale);
    double c[4];
    drv_usbspec_coefficients(s, c);
    drv_usbspec_wavelengths(c, DRV_USBSPEC_PIXELS, d->lambda);
    for (int b = 0; b < d->n_bands && rc == 0; b++)
        d->centres[b] = cfg->first_nm + b * cfg->step_nm;
    if (rc == 0)
        rc = brdf_spectral_rgb_weights(d->centres, (size_t)d->n_bands, d->w, err);
    if (rc == 0) { /* every band within the calibrated range: checked once here */
        double probe[DRV_USBSPEC_MAX_BANDS], flat[DRV_USBSPEC_PIXELS];
        for (int p = 0; p < DRV_USBSPEC_PIXELS; p++)
            flat[p] = 1;
        rc = drv_usbspec_resample(d->lambda, flat, DRV_USBSPEC_PIXELS, d->centres,
                                  (size_t)d->n_bands, d->step_nm, probe, err);
        if (rc < 0) {
            char why[GONIO_ERR_MSG_MAX];
            snprintf(why, sizeof why, "%s", err ? err->msg : "bands not covered");
            rc = gonio_err_set(err, GONIO_EDEVICE, "usb spectrometer: calibration %g %g %g %g: "
                               "%s", c[0], c[1], c[2], c[3], why);
        }
    }
    if (rc < 0) {
        usb_free(d);
        return NULL;
    }
    double lo = d->centres[0] - 0.5 * d->step_nm;
    double hi = d->centres[d->n_bands - 1] + 0.5 * d->step_nm;
    d->p_lo = DRV_USBSPEC_PIXELS;
    for (size_t p = 0; p < DRV_USBSPEC_PIXELS; p++)
        if (d->lambda[p] >= lo - 1 && d->lambda[p] <= hi + 1) {
            if (d->p_lo == DRV_USBSPEC_PIXELS)
                d->p_lo = p;
            d->p_hi = p;
        }
    drv_detector *det = drv_detector_alloc(&usb_detector_ops, d);
    if (!det)
        gonio_err_set(err, ENOMEM, "usb spectrometer: out of memory");
    return det;
}

int drv_usbspec_last_spectrum(const drv_detector *det, const double **centres_nm,
                              const double **spectrum)
{
    if (!det || det->ops != &usb_detector_ops)
        return 0;
    const struct usb_detector *d = det->priv;
    *centres_nm = d->centres;
    *spectrum = d->spectrum;
    return d->have ? d->n_bands : 0;
}
