/* The scale a fit divides the data by (fit/fit.h fit_data_scale). */
#include <math.h>
#include <stdlib.h>

#include "fit/fit.h"

/* Calibrated data, whose typical f cos theta_i lies between 10^(centre -
 * 3) and 10^(centre + 3) 1/sr (black paint to a polished metal's
 * off-specular floor), are fitted as they are. */
#define SCALE_CENTRE_LOG10 (-1.5)

/* The k-th smallest of v[0..m) (k < m), v reordered: Hoare's selection,
 * linear on average where sorting the 3n values was a tenth of a fit. */
static double kth_smallest(double *v, size_t m, size_t k)
{
    size_t lo = 0, hi = m - 1;
    while (lo < hi) {
        double pivot = v[lo + (hi - lo) / 2];
        size_t i = lo, j = hi;
        while (i <= j) {
            while (v[i] < pivot)
                i++;
            while (v[j] > pivot)
                j--;
            if (i <= j) {
                double t = v[i];
                v[i] = v[j];
                v[j] = t;
                i++;
                if (j == 0)
                    break;
                j--;
            }
        }
        if (k <= j)
            hi = j;
        else if (k >= i)
            lo = i;
        else
            return v[k];
    }
    return v[k];
}

double fit_data_scale(const struct fit_sample *s, const size_t *idx, size_t n)
{
    double *v = malloc((n ? 3 * n : 1) * sizeof *v);
    if (!v)
        return 1.0;
    size_t m = 0;
    for (size_t k = 0; k < n; k++) {
        const struct fit_sample *x = &s[idx ? idx[k] : k];
        for (int c = 0; c < 3; c++) {
            double a = fabs(x->rgb[c] * x->g.wi[2]);
            if (isfinite(a))
                v[m++] = a;
        }
    }
    double med = 0;
    if (m)
        med = kth_smallest(v, m, m / 2);
    free(v);
    if (!(med > 0) || !isfinite(med))
        return 1.0;
    double k = nearbyint((log10(med) - SCALE_CENTRE_LOG10) / FIT_SCALE_STEP_LOG10);
    return pow(10.0, FIT_SCALE_STEP_LOG10 * k);
}
