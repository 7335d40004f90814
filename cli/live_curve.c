/* The fit curves of `gonio live` (cli/live_curve.h). */
#include <math.h>

#include "brdf/angles.h"
#include "cli/live_curve.h"

#define CURVE_FROM_DEG (-88)
#define CURVE_TO_DEG 88

static json_t *one_curve(const brdf_material *m, double ti)
{
    enum { N = CURVE_TO_DEG - CURVE_FROM_DEG + 1 };
    struct brdf_pair pairs[N];
    double rgb[3 * N];
    for (int k = 0; k < N; k++)
        brdf_pair_inplane(ti, CURVE_FROM_DEG + k, &pairs[k]);
    brdf_material_eval(m, pairs, N, rgb);
    json_t *x = json_array(), *y = json_array();
    for (int k = 0; k < N; k++) {
        double f = (rgb[3 * k] + rgb[3 * k + 1] + rgb[3 * k + 2]) / 3.0;
        json_array_append_new(x, json_integer(CURVE_FROM_DEG + k));
        /* a model may be zero or undefined past grazing: a gap, not -inf */
        json_array_append_new(y, f > 0 && isfinite(f) ? json_real(log10(f)) : json_null());
    }
    return json_pack("{s:f,s:o,s:o}", "theta_i", ti, "theta_r", x, "log10_f", y);
}

json_t *live_curve_json(const brdf_material *m, const double *theta_i, size_t n_ti,
                        const char *source, size_t n)
{
    json_t *curves = json_array();
    for (size_t k = 0; k < n_ti && k < LIVE_CURVE_INCIDENCES; k++)
        json_array_append_new(curves, one_curve(m, theta_i[k]));
    return json_pack("{s:s,s:I,s:o}", "source", source, "samples", (json_int_t)n, "curves",
                     curves);
}
