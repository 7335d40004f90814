/* PNG images of 8-bit sRGB pixels through libpng: the renderings' PNGs and
 * any other raster a viewer needs (the report embeds them). png.h of libpng
 * stays inside render/png.c. */
#ifndef GONIO_RENDER_PNG_H
#define GONIO_RENDER_PNG_H

#include <stddef.h>
#include <stdint.h>

#include "common/err.h"

/* Encode width x height pixels of interleaved 8-bit RGB (row-major, top row
 * first) as a PNG in memory, tagged sRGB: *out is malloc'd (free it), *len
 * its size. For embedding (a data: URI) without a file. Returns 0 or a
 * negative code with err filled. */
int render_png_encode(int width, int height, const uint8_t *rgb, uint8_t **out, size_t *len,
                      struct gonio_err *err);

/* The same written to path atomically (temporary file, fsync, rename), so a
 * failed write leaves no file. */
int render_png_write(const char *path, int width, int height, const uint8_t *rgb,
                     struct gonio_err *err);

#endif
