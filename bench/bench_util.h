/* What the benchmarks share: the ten study materials, a monotonic clock,
 * and the pairs of a named plan exactly as a capture would measure them. */
#ifndef GONIO_BENCH_UTIL_H
#define GONIO_BENCH_UTIL_H

#include <stddef.h>

#include "brdf/angles.h"

/* The materials of the acceptance tables (nbrdf:NAME). */
#define BENCH_N_STUDY 10
extern const char *const bench_study_materials[BENCH_N_STUDY];

double bench_now_s(void);

/* The pairs of plan `name` (ds1, oop200k, a path...) on the default rig, in
 * execution order; *out is malloc'd. Prints the error and returns -1 on
 * failure. */
int bench_plan_pairs(const char *name, struct brdf_pair **out, size_t *n);

#endif
