/* Inside capture/: the rig time a capture still needs, metered as it goes
 * (docs/plans.md, "Estimates on a real day").
 *
 * Each point still to measure counts its move from the point before it in
 * the capture's order (the planner's move model, rig/motion.h), the
 * integration the detector chose at the nearest point measured so far
 * (planner/meter.h: the host's expectation until then) and the overhead
 * the run has shown: each measured point's rig time beyond its move
 * estimate and its integration (settle, its spread, retried moves, the
 * bus; auto-ranging's retakes and dark frames: capture/autorange.h), as a
 * mean over the journal. Before the first point the overhead is
 * the rig profile's settle, so the first ETA is the plan's estimate.
 * Everything is learnt from the journal's records, so a resumed capture,
 * which observes the journal first, goes on with the same figures. */
#ifndef GONIO_CAPTURE_ETA_H
#define GONIO_CAPTURE_ETA_H

#include <stddef.h>

#include "common/err.h"
#include "journal/journal.h"
#include "planner/planner.h"
#include "rig/rig.h"

typedef struct capture_eta capture_eta;

/* Over plan's points on rig (borrowed). order: every point once, in the
 * order the capture measures them (plan_count entries, copied; NULL: plan
 * order); expected_s: each point's integration as the host expects it, or
 * NULL (the rig's fixed integration until measured). NULL with err filled
 * when out of memory. */
capture_eta *capture_eta_new(const struct plan *plan, const struct rig_profile *rig,
                             const long *order, const double *expected_s,
                             struct gonio_err *err);
void capture_eta_free(capture_eta *e);

/* A journalled sample, in record order: its point is done, its integration
 * is metered, and its overhead counted (from the record observed before
 * it, or from capture_eta_start's position when that came between them;
 * the first from home, or that position, at rig time 0). A point outside
 * the plan is ignored. */
void capture_eta_observe(capture_eta *e, const struct journal_sample *s);

/* The axes are at `at` (sample, arm, azimuth) before the next point in the
 * order: its move counts from there, not from the point before it (home
 * for the first). A capture calls it once the devices are open, as a
 * capture starts wherever the last one left the axes; before any
 * observation the estimate counts from there too. */
void capture_eta_start(capture_eta *e, const struct rig_axes *at);

/* The capture's auto-ranging (borrowed, outliving e): once a sample of
 * counts is observed, each point left counts the detector time the ladder
 * would take there (capture/autorange.h's model: its tries, from the rung
 * the point before it ended on, and the dark frame of each rung used the
 * first time) at the signal rate of the point measured nearest it; the
 * overhead per point then leaves out each record's tries and dark frames.
 * Call it before observing. */
struct autorange;
void capture_eta_ranging(capture_eta *e, const struct autorange *ar, size_t prescan);

/* The rig time of the points not observed yet. */
double capture_eta_left(const capture_eta *e);

/* capture_eta_left before any observation: the whole capture's estimate in
 * its order (the plan's estimate, plus a pre-scan's detours). */
double capture_eta_estimate(const capture_eta *e);

/* The mean overhead per point so far (the settle before any point). */
double capture_eta_overhead(const capture_eta *e);

#endif
