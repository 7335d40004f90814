/* The one order a fit sees its samples in.
 *
 * A rig measures in whatever order its plan or policy chose; the same data
 * must give the same model. Fits seed subsets, rank starts, deal folds and
 * sum residuals in sample order, so each fit works on a copy sorted by a
 * total, content-only key (fit_samples_canonical): any permutation of the
 * input gives bit-identical parameters (docs/fitting.md "Sample order"). */
#ifndef GONIO_FIT_SAMPLE_ORDER_H
#define GONIO_FIT_SAMPLE_ORDER_H

#include <stddef.h>

#include "fit/fit.h"

/* Copy the n samples (and their flags, when flags is not NULL: one per
 * sample, e.g. the saturated lower-bound flags) into *sorted (and
 * *sorted_flags, else NULL), ordered by wi, wo, theta_h, theta_d, phi_d,
 * then the RGB values, then the flag, each compared in IEEE total order
 * (-0 before +0, NaNs by their bits): equal keys are equal samples, so the
 * order is total and the copy does not depend on the input's order. Free
 * both with free(). Returns 0, or -1 when out of memory (nothing to free). */
int fit_samples_canonical(const struct fit_sample *s, const unsigned char *flags, size_t n,
                          struct fit_sample **sorted, unsigned char **sorted_flags);

#endif
