/* Internal to fit/: the natural log of an array, vectorised. The ABC
 * residuals are one log per sample and channel, most of a DS1 solve's
 * time once the rest is shared per sample (docs/fitting.md). */
#ifndef GONIO_FIT_ABC_VLOG_H
#define GONIO_FIT_ABC_VLOG_H

#include <stddef.h>

/* v[i] = log(v[i]) for i < n. The inputs must be finite and > 0 (callers
 * pass ratios of 1 + f cos theta_i >= 1 terms). Within 4 ulp of log(). */
void abc_vlog(double *v, size_t n);

#endif
