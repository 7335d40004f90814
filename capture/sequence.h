/* Inside capture/: which point a capture measures next.
 *
 * In a plan's order the answer is the next point the journal lacks. In the
 * adaptive order (adaptive/adaptive.h) the policy chooses it from the
 * samples so far, and it decides while the rig works: sequence_begin
 * starts the decision of the point after k in a second thread as the
 * engine moves to, settles on and integrates point k, and sequence_end
 * collects it once k is journalled. The decision after k sees the samples
 * before k, and k as the pending point: all in the journal, so a capture
 * resumed from it, which makes the journal's decisions again in record
 * order, goes on as one never interrupted (docs/formats.md, "Adaptive
 * captures"). */
#ifndef GONIO_CAPTURE_SEQUENCE_H
#define GONIO_CAPTURE_SEQUENCE_H

#include <stddef.h>

#include "adaptive/adaptive.h"
#include "capture/capture.h"
#include "common/err.h"
#include "journal/journal.h"
#include "planner/planner.h"
#include "rig/rig.h"

typedef struct sequence sequence;

/* The policy's figures, for results.json and the progress display. */
struct sequence_report {
    struct adaptive_status status; /* the latest decision's */
    size_t decisions;               /* made by this run, in the second thread */
    double decision_mean_s, decision_max_s; /* wall time of each (add + next) */
    /* Wall time the engine waited for a decision after its point was
     * journalled: what deciding cost the rig. */
    double wait_s;
};

/* What a sequence runs over: plan's points (plan order, or the adaptive
 * policy for the plan's current order PLAN_ORDER_ADAPTIVE, with opt and
 * the integration the host expects at each point, integration_s, or NULL
 * where it does not know: adaptive_new) on rig. In plan order, a pre-scan
 * of `prescan` points spread over the plan (at most its count; 0: none)
 * comes first: they are measured before the plan's order starts, which
 * then skips them (a resumed capture finishes the pre-scan first, if it
 * was interrupted in it). dir names the capture in messages. */
struct sequence_setup {
    const struct plan *plan;
    const struct rig_profile *rig;
    const double *integration_s;
    const struct adaptive_options *opt;
    size_t prescan;
    const char *dir;
};

/* A sequence of setup (borrowed: it must outlive the sequence) after the
 * n journalled samples js (record order), which must each name a distinct
 * point of the plan (else GONIO_EBADDATA naming the record). *first
 * receives the first point to measure, -1 when there is none (every point
 * done, or the policy stops). */
int sequence_new(const struct sequence_setup *setup, const struct journal_sample *js, size_t n,
                 sequence **out, long *first, struct gonio_err *err);
void sequence_free(sequence *q);

/* Plan order: every point of the plan in the order the sequence measures
 * them, the pre-scan's first (plan_count entries into order; the ETA's
 * moves). O(count x pre-scan). */
void sequence_order(const sequence *q, long *order);

/* Plan order, resumed with the axes at `at` (sample, arm, azimuth), away
 * from where the journal left them: the points not done yet are put in the
 * plan's order mode (plan_order_subset) as a path from there, a pre-scan's
 * points left first. Point numbers stay the plan's (the journal's); only
 * the order they are measured in changes. *first receives the next point
 * (-1: none). A no-op in the as-written and adaptive orders (*first
 * unchanged). */
int sequence_reroute(sequence *q, const struct rig_axes *at, long *first,
                     struct gonio_err *err);

/* Start deciding the point after k while k is measured. */
int sequence_begin(sequence *q, long k, struct gonio_err *err);

/* k's journalled sample s (NULL: k was not measured, the decision is
 * dropped). *next receives the next point, -1 when there is none (every
 * point done, or the policy stops). Returns 0 or a negative code with err
 * filled. */
int sequence_end(sequence *q, const struct journal_sample *s, long *next,
                 struct gonio_err *err);

/* The policy's figures; 0 when the order is not adaptive. */
int sequence_report(const sequence *q, struct sequence_report *r);

/* The adaptive order's options (opt->model borrows cfg->model): the
 * capture's budget and target, refused in a fixed order (where they would
 * mean nothing) rather than ignored; converge: the capture's stop rule. */
int sequence_options(const struct capture_config *cfg, const struct plan *plan, int converge,
                     struct adaptive_options *opt, struct gonio_err *err);

/* After the last point, in the adaptive order: the policy's prediction
 * with every sample in (the last one given to it now; the stop reason
 * stays the one that ended the capture), its options and the decisions'
 * times into out (adaptive set). A no-op in plan order. */
int sequence_summary(sequence *q, const struct adaptive_options *opt,
                     struct capture_summary *out, struct gonio_err *err);

#endif
