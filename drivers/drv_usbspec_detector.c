/* The USB spectrometer as the capture engine's detector
 * (drivers/drv_usbspec.h): counts -> electric dark corrected, linearised
 * band spectrum -> three bins of counts for a calibration to reduce; or,
 * with the scale shortcut, -> BRDF -> linear sRGB. */
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
enum { DARK_FIRST = 6, DARK_END = 21 };

/* The counts bins' lower edges (R, G; B is the rest): band centres at or
 * above these nm. */
static const double BIN_FROM_NM[2] = {595, 495};

struct usb_detector {
    drv_usbspec *s;
    int n_bands;
    double step_nm, scale;               /* scale 0: counts */
    double centres[DRV_USBSPEC_MAX_BANDS];
    double w[3 * DRV_USBSPEC_MAX_BANDS]; /* band spectrum -> linear sRGB */
    int bin[DRV_USBSPEC_MAX_BANDS];      /* counts: the channel of each band */
    int n_bin[3];
    double nl[DRV_USBSPEC_NL_MAX + 1];   /* the device's nonlinearity correction */
    int nl_order;
    double top;                          /* counts: the linearised top of the ADC */
    double lambda[DRV_USBSPEC_PIXELS];
    size_t p_lo[3], p_hi[3];             /* pixels within each channel's bands */
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
    int clipped[3] = {0, 0, 0};
    for (size_t p = 0; p < DRV_USBSPEC_PIXELS; p++) {
        v[p] = counts[p] - dark;
        if (d->scale == 0)
            v[p] = drv_usbspec_linearise(d->nl, d->nl_order, v[p]);
        for (int c = 0; c < 3; c++)
            if (p >= d->p_lo[c] && p <= d->p_hi[c] && counts[p] >= DRV_USBSPEC_FULL_SCALE)
                clipped[c] = 1;
    }
    unsigned flags = clipped[0] || clipped[1] || clipped[2] ? DRV_READING_SATURATED : 0;
    double t = d->set_us * 1e-6;
    if ((rc = drv_usbspec_resample(d->lambda, v, DRV_USBSPEC_PIXELS, d->centres,
                                   (size_t)d->n_bands, d->step_nm, d->spectrum, err)) < 0)
        return rc;
    if (d->scale == 0) { /* counts: each bin's mean band, a clipped one at the top */
        for (int c = 0; c < 3; c++)
            out->rgb[c] = 0;
        for (int b = 0; b < d->n_bands; b++)
            out->rgb[d->bin[b]] += d->spectrum[b] / d->n_bin[d->bin[b]];
        for (int c = 0; c < 3; c++)
            if (clipped[c])
                out->rgb[c] = d->top;
        out->unit = DRV_UNIT_COUNTS;
        out->full_scale = d->top;
        out->n_bands = d->n_bands;
        out->bands_nm = d->centres;
        out->bands = d->spectrum;
    } else {
        for (int b = 0; b < d->n_bands; b++)
            d->spectrum[b] *= d->scale / t;
        for (int c = 0; c < 3; c++) {
            double sum = 0;
            for (int b = 0; b < d->n_bands; b++)
                sum += d->w[3 * b + c] * d->spectrum[b];
            out->rgb[c] = sum;
        }
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

/* The band centres, and each band's counts bin: every bin needs a band. */
static int set_bands(struct usb_detector *d, const struct drv_usbspec_cfg *cfg,
                     struct gonio_err *err)
{
    for (int b = 0; b < d->n_bands; b++) {
        d->centres[b] = cfg->first_nm + b * cfg->step_nm;
        d->bin[b] = d->centres[b] >= BIN_FROM_NM[0] ? 0 : d->centres[b] >= BIN_FROM_NM[1] ? 1 : 2;
        d->n_bin[d->bin[b]]++;
    }
    for (int c = 0; c < 3 && d->scale == 0; c++)
        if (!d->n_bin[c])
            return gonio_err_set(err, EINVAL, "usb spectrometer: bands %g-%g nm leave channel %c "
                                 "(%s) empty: counts need bands on both sides of 495 and 595 "
                                 "nm", cfg->first_nm, d->centres[d->n_bands - 1], "RGB"[c],
                                 c == 0   ? "595 nm and up"
                                 : c == 1 ? "495-595 nm"
                                          : "below 495 nm");
    return 0;
}

static void set_pixel_ranges(struct usb_detector *d)
{
    /* The pixels that reach each channel's bands (a nm beyond the boxes,
     * for the pixel straddling an edge): a clip there spoils the channel. */
    for (int c = 0; c < 3; c++) {
        double lo = INFINITY, hi = -INFINITY;
        for (int b = 0; b < d->n_bands; b++)
            if (d->bin[b] == c || d->scale > 0) {
                lo = fmin(lo, d->centres[b] - 0.5 * d->step_nm);
                hi = fmax(hi, d->centres[b] + 0.5 * d->step_nm);
            }
        d->p_lo[c] = DRV_USBSPEC_PIXELS, d->p_hi[c] = 0;
        for (size_t p = 0; p < DRV_USBSPEC_PIXELS; p++)
            if (d->lambda[p] >= lo - 1 && d->lambda[p] <= hi + 1) {
                if (d->p_lo[c] == DRV_USBSPEC_PIXELS)
                    d->p_lo[c] = p;
                d->p_hi[c] = p;
            }
    }
}

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
    drv_usbspec_nonlinearity(s, d->nl, &d->nl_order);
    d->top = drv_usbspec_linearise(d->nl, d->nl_order, DRV_USBSPEC_FULL_SCALE);
    int rc = 0;
    if (cfg->n_bands < 3 || cfg->n_bands > DRV_USBSPEC_MAX_BANDS || !(cfg->step_nm > 0) ||
        !isfinite(cfg->first_nm) || !(cfg->scale >= 0) || !isfinite(cfg->scale))
        rc = gonio_err_set(err, EINVAL, "usb spectrometer: bands %d from %g nm by %g nm, "
                           "scale %g", cfg->n_bands, cfg->first_nm, cfg->step_nm, cfg->scale);
    double wl[4];
    drv_usbspec_coefficients(s, wl);
    drv_usbspec_wavelengths(wl, DRV_USBSPEC_PIXELS, d->lambda);
    if (rc == 0)
        rc = set_bands(d, cfg, err);
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
                               "%s", wl[0], wl[1], wl[2], wl[3], why);
        }
    }
    if (rc < 0) {
        usb_free(d);
        return NULL;
    }
    set_pixel_ranges(d);
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
