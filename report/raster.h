/* PNG versions of the plots, for viewers that do not show SVG: the SVG
 * document is rasterised by librsvg onto a cairo image surface. librsvg
 * and cairo stay inside raster.c. */
#ifndef GONIO_REPORT_RASTER_H
#define GONIO_REPORT_RASTER_H

#include <stddef.h>

#include "common/err.h"

/* Rasterise an SVG document at scale (1: one pixel per SVG unit) into PNG
 * bytes (malloc'd into *png, length *png_len), on the document's own
 * background. Returns 0, or -GONIO_EBADDATA naming the problem when the
 * document does not parse or has no size. */
int report_svg_to_png(const char *svg, size_t len, double scale, unsigned char **png,
                      size_t *png_len, struct gonio_err *err);

/* Width and height in pixels of PNG bytes, decoded in full (so a
 * truncated or corrupt file is caught). Returns 0, or -GONIO_EBADDATA when
 * the bytes are not a readable PNG. */
int report_png_size(const unsigned char *png, size_t len, unsigned *width, unsigned *height,
                    struct gonio_err *err);

#endif
