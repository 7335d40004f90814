#include "render/tonemap.h"

#include <math.h>

#include "brdf/colour.h"

uint8_t render_tonemap_value(double linear, double exposure, enum render_curve curve)
{
    double v = linear * exposure;
    if (!(v > 0)) /* also NaN */
        return 0;
    v = curve == RENDER_CURVE_REINHARD ? v / (1 + v) : (v < 1 ? v : 1);
    return brdf_colour_srgb8(v);
}

void render_tonemap(const float *rgb, size_t n, double exposure, enum render_curve curve,
                    uint8_t *out)
{
    for (size_t i = 0; i < 3 * n; i++)
        out[i] = render_tonemap_value(rgb[i], exposure, curve);
}
