/* Poisson counts for every mean a scene can produce.
 *
 * GSL's sampler is exact, but it counts in unsigned int: from a mean of
 * about 4.3e9 its counts wrap (a mean of 4.4e9 gave 1.05e8), and for means
 * past about 1e10 it does not return. Below SIM_POISSON_GSL_MAX it is used
 * as it is (exact, and under 3 us a draw); above, the count is the normal
 * approximation with continuity correction, floor(mean + sqrt(mean) z +
 * 0.5): its mean is the mean, its variance the mean + 1/12, and only its
 * skewness, 1/sqrt(mean) = 3e-5 and less there, is missing: beyond what a
 * capture could show. The count is
 * a double: a mean of 1e15 electrons gives counts near 1e15, never wrapped. */
#ifndef GONIO_SIM_POISSON_H
#define GONIO_SIM_POISSON_H

#include <gsl/gsl_rng.h>

/* Means up to this use GSL's exact sampler: the count stays far below its
 * unsigned int range (2^32 = 4.3e9 is 100,000 standard deviations away). */
#define SIM_POISSON_GSL_MAX 1e9

/* A Poisson count of the given mean. A mean that is not > 0 (0, negative,
 * NAN) gives 0; an infinite mean gives infinity. */
double sim_poisson(const gsl_rng *r, double mean);

#endif
