/* The scale a fit divides the data by (fit/fit.h fit_data_scale). */
#include <math.h>
#include <stdlib.h>

#include "fit/fit.h"

/* Calibrated data, whose typical f cos theta_i lies between 10^(centre -
 * 3) and 10^(centre + 3) 1/sr (black paint to a polished metal's
 * off-specular floor), are fitted as they are. */
#define SCALE_CENTRE_LOG10 (-1.5)

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
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
    if (m) {
        qsort(v, m, sizeof *v, cmp_double);
        med = v[m / 2];
    }
    free(v);
    if (!(med > 0) || !isfinite(med))
        return 1.0;
    double k = nearbyint((log10(med) - SCALE_CENTRE_LOG10) / FIT_SCALE_STEP_LOG10);
    return pow(10.0, FIT_SCALE_STEP_LOG10 * k);
}
