/* Linear RGB to the 8-bit sRGB of a PNG: each channel is scaled by the
 * exposure, negatives are cut to 0, the curve maps [0, inf) into [0, 1]
 * (reinhard: v / (1 + v), keeps highlights apart; clamp: min(v, 1)), and the
 * sRGB transfer function quantises it (brdf_colour_srgb8). */
#ifndef GONIO_RENDER_TONEMAP_H
#define GONIO_RENDER_TONEMAP_H

#include <stddef.h>
#include <stdint.h>

#include "render/scene.h"

uint8_t render_tonemap_value(double linear, double exposure, enum render_curve curve);

/* n pixels of interleaved RGB floats into out[3n]. */
void render_tonemap(const float *rgb, size_t n, double exposure, enum render_curve curve,
                    uint8_t *out);

#endif
