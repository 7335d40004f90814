/* Pixel spectrum -> band spectrum: the mean of the piecewise-constant
 * pixel spectrum over each band's box (docs/usb-spectrometer.md). A box
 * average keeps what a 10 nm bandpass would see, uses every pixel once per
 * band it overlaps, and is exact for a flat spectrum whatever the pixel
 * spacing (which varies across the detector). */
#include "drivers/drv_usbspec.h"

#include <math.h>

/* Edge between pixel p - 1 and p (p = 0..n): midpoints inside, half a
 * pixel step beyond the ends. */
static double edge(const double *lam, size_t n, size_t p)
{
    if (p == 0)
        return lam[0] - 0.5 * (lam[1] - lam[0]);
    if (p == n)
        return lam[n - 1] + 0.5 * (lam[n - 1] - lam[n - 2]);
    return 0.5 * (lam[p - 1] + lam[p]);
}

int drv_usbspec_resample(const double *lambda_nm, const double *v, size_t n,
                         const double *centres_nm, size_t n_bands, double width_nm,
                         double *out, struct gonio_err *err)
{
    if (n < 2 || !(width_nm > 0))
        return gonio_err_set(err, GONIO_EBADDATA, "resample: %zu pixels, band width %g nm", n,
                             width_nm);
    for (size_t p = 0; p < n; p++)
        if (!isfinite(lambda_nm[p]) || (p && !(lambda_nm[p] > lambda_nm[p - 1])))
            return gonio_err_set(err, GONIO_EBADDATA, "resample: pixel wavelengths do not "
                                 "increase at pixel %zu (%g nm)", p, lambda_nm[p]);
    double lo_all = edge(lambda_nm, n, 0), hi_all = edge(lambda_nm, n, n);
    size_t p = 0;
    for (size_t b = 0; b < n_bands; b++) {
        double lo = centres_nm[b] - 0.5 * width_nm, hi = centres_nm[b] + 0.5 * width_nm;
        if (lo < lo_all || hi > hi_all)
            return gonio_err_set(err, GONIO_EBADDATA, "resample: band %g nm (%g-%g nm) lies "
                                 "beyond the pixels' %g-%g nm", centres_nm[b], lo, hi, lo_all,
                                 hi_all);
        /* bands may overlap or come in any order: restart the scan if needed */
        if (p >= n || edge(lambda_nm, n, p) > lo)
            p = 0;
        while (p + 1 < n && edge(lambda_nm, n, p + 1) <= lo)
            p++;
        double sum = 0, wsum = 0;
        for (size_t q = p; q < n; q++) {
            double a = edge(lambda_nm, n, q), z = edge(lambda_nm, n, q + 1);
            if (a >= hi)
                break;
            double w = fmin(z, hi) - fmax(a, lo);
            if (w > 0) {
                sum += w * v[q];
                wsum += w;
            }
        }
        out[b] = sum / wsum;
    }
    return 0;
}
