/* The integration a detector will choose at a plan's points, learnt from
 * where it has measured (docs/plans.md, "Estimates on a real day").
 *
 * An auto-exposing detector integrates longer where the material is dark,
 * so a point's integration is best guessed from the point measured nearest
 * it (chordal distance of the pairs' directions). The host's expectation
 * (the simulated rig's, sim/estimate.h) counts until the rig has measured
 * somewhere; then the measurement nearest a point, scaled by how it
 * compared with the expectation there (the expectation knows how the
 * signal varies between the two, the measurement how the day's detector
 * differs), or as measured, never below the rig's fixed integration, where
 * the host expects nothing. The adaptive policy costs its candidates with
 * it, the capture's ETA counts the points left with it. */
#ifndef GONIO_PLANNER_METER_H
#define GONIO_PLANNER_METER_H

#include <stddef.h>

#include "common/err.h"
#include "planner/planner.h"
#include "rig/rig.h"

typedef struct plan_meter plan_meter;

/* Over plan's points on rig (both borrowed, outliving the meter);
 * expected_s: plan_count entries, each finite and >= 0 (copied), or NULL
 * (the rig's fixed integration everywhere, a fallback only). Returns NULL
 * with err filled (out of memory). */
plan_meter *plan_meter_new(const struct plan *plan, const struct rig_profile *rig,
                           const double *expected_s, struct gonio_err *err);
void plan_meter_free(plan_meter *m);

/* The detector chose integration_s at point (< plan_count; others are
 * ignored). O(plan_count). */
void plan_meter_observe(plan_meter *m, size_t point, double integration_s);

/* The integration expected at point i now. */
double plan_meter_integration(const plan_meter *m, size_t i);

/* The point observed nearest i, -1 before any observation. */
long plan_meter_nearest(const plan_meter *m, size_t i);

#endif
