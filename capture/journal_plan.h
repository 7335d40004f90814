/* A journal checked against the plan it was captured on: every record names
 * a point of the plan, no point twice, and was measured where that point
 * puts the axes (within the rig's in-position band), its angles the ones
 * its axes give. What a resume checks before it trusts a journal, and what
 * `gonio journal check` reports. */
#ifndef GONIO_CAPTURE_JOURNAL_PLAN_H
#define GONIO_CAPTURE_JOURNAL_PLAN_H

#include <stddef.h>

#include "common/err.h"
#include "journal/journal.h"
#include "planner/planner.h"

/* The points a journal's `point` indexes: a loaded plan's (plan_point) when
 * plan is set, else points[0..count-1] (a capture directory's plan.json,
 * journal_plan_read). */
struct journal_plan {
    const struct plan *plan;
    const struct plan_point *points;
    size_t count;
};

/* Check the n samples read from the journal at path (named in errors) against
 * the plan, the axes within band_deg of each point's. 0, or -GONIO_EBADDATA
 * with err = "path:LINE: what is wrong" (LINE counts the header as 1). */
int journal_plan_check(const char *path, const struct journal_sample *s, size_t n,
                       const struct journal_plan *plan, double band_deg, struct gonio_err *err);

/* The points of a capture directory's plan.json (docs/formats.md), in its
 * order: *points malloc'd, caller frees. 0, or -GONIO_EBADDATA /
 * -GONIO_ENOTFOUND with err naming the file and field. */
int journal_plan_read(const char *plan_json, struct plan_point **points, size_t *count,
                      struct gonio_err *err);

#endif
