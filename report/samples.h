/* The in-plane samples of a capture journal (samples.csv, docs/formats.md)
 * as the slices plot draws them. */
#ifndef GONIO_REPORT_SAMPLES_H
#define GONIO_REPORT_SAMPLES_H

#include <stddef.h>

#include "common/err.h"
#include "report/slices.h"

/* Read path (a samples.csv, or a capture directory holding one). Samples
 * out of the plane of incidence are left out (counted in *n_out_of_plane
 * when not NULL), and so are records without a BRDF value, dark frames
 * and counts not reduced (in *n_without_value when not NULL). *out is
 * malloc'd. Errors are the journal's (file, line, problem). */
int report_samples_read(const char *path, struct report_sample **out, size_t *n,
                        size_t *n_out_of_plane, size_t *n_without_value,
                        struct gonio_err *err);

#endif
