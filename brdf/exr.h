/* OpenEXR images of linear RGB (BRDF slices, renders): 32-bit float R, G, B
 * channels, scanlines, ZIP compression, through the OpenEXR Core C API.
 * openexr.h stays inside brdf/exr.c. */
#ifndef GONIO_BRDF_EXR_H
#define GONIO_BRDF_EXR_H

#include "common/err.h"

/* Write width x height pixels of interleaved, row-major RGB (top row first).
 * The image goes to a temporary file renamed into place on success, so a
 * failed write leaves no file (and an existing file untouched). Returns 0 or
 * a negative code with err naming the path and the problem. */
int brdf_exr_write_rgb(const char *path, int width, int height, const float *rgb,
                       struct gonio_err *err);

/* Read the first part of a scanline file with R, G and B channels (any
 * pixel type, converted to float) into a new malloc'd interleaved buffer
 * *rgb (free it with free()). Returns 0 or a negative code. */
int brdf_exr_read_rgb(const char *path, int *width, int *height, float **rgb,
                      struct gonio_err *err);

#endif
