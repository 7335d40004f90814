/* Adaptive acquisition: a capture's next pair chosen from the samples so
 * far (docs/adaptive.md).
 *
 * A plan's pairs are the candidate pool. After each sample the policy
 * refits its models and scores every candidate not yet measured by the
 * expected reduction of the model's full-domain error per second of rig
 * time it costs: the move from the axes' present positions (with the
 * rig's backlash), the settle and the integration the host expects there.
 * It also predicts the error the capture has reached and what more points
 * would buy, and says when to stop: at an operator's target error, at a
 * rig-time budget, or when the predicted gain per minute falls below a
 * tolerance. Nothing here reads a true material: a capture on hardware
 * has none.
 *
 * The policy is deterministic: the same pool, options and samples in the
 * same order give the same decisions, so a resumed capture that replays
 * its journal continues the same sequence. */
#ifndef GONIO_ADAPTIVE_ADAPTIVE_H
#define GONIO_ADAPTIVE_ADAPTIVE_H

#include <stddef.h>
#include <stdint.h>

#include "common/err.h"
#include "fit/fit.h"
#include "planner/planner.h"
#include "rig/rig.h"

struct adaptive_options {
    const char *model;  /* the capture's model (fit/models.h name, or "auto"):
                           the policy predicts the error of this model */
    double budget_s;    /* stop before a point would end past this rig time; 0: none */
    double target;      /* stop once the predicted full-domain log error is at most
                           this; 0: none */
    int converge;       /* stop once the predicted gain per minute is below gain_tol */
    double gain_tol;    /* full-domain log error per minute of rig time */
    uint64_t seed;      /* every randomised step derives from it */
};

/* Defaults: model "abc", no budget, no target, converge off, the gain
 * tolerance of docs/adaptive.md, seed 1. */
struct adaptive_options adaptive_default_options(void);

/* Where the policy stands; NAN where not known yet. */
struct adaptive_status {
    size_t samples;          /* samples received */
    double predicted_error;  /* predicted full-domain log error of the model fitted now */
    double predicted_next;   /* the same after predicted_next_s more rig time: NAN
                                unless the gain is positive, and never below half
                                the prediction */
    double predicted_next_s;
    double gain_per_min;     /* predicted error reduction per minute of rig time now */
    double decision_s;       /* wall time the latest adaptive_next took */
    char model[32];          /* the model the prediction is for (auto: the one chosen) */
    char stop[16];           /* "" (go on), "target", "budget", "converged", "exhausted" */
};

/* Whether a prediction from this many samples is only rough: below 40 the
 * calibration (docs/adaptive.md, "Predicting the error") found it within
 * 1.5x of the truth on fewer than half its checkpoints, and at six samples
 * it was 1.5-7x below the truth on the held-out materials. */
#define ADAPTIVE_CALIBRATED_SAMPLES 40
static inline int adaptive_prediction_rough(size_t samples)
{
    return samples < ADAPTIVE_CALIBRATED_SAMPLES;
}

typedef struct adaptive adaptive;

/* A policy over the pool's points (plan_point(pool, i), i < plan_count),
 * on rig; integration_s[i] is the integration the host expects at point i
 * (NULL: rig->integration_s everywhere; adaptive_observe corrects it). The pool and rig must outlive the
 * policy. Returns NULL with err filled on bad options or out of memory. */
adaptive *adaptive_new(const struct plan *pool, const struct rig_profile *rig,
                       const double *integration_s, const struct adaptive_options *opt,
                       struct gonio_err *err);
void adaptive_free(adaptive *a);

/* The measured sample of pool point `point` (the fit sample of journal
 * record; saturated: the reading is a lower bound). A point given twice,
 * or not in the pool, is a GONIO_EUSAGE error. Returns 0 or a negative
 * code with err filled. */
int adaptive_add(adaptive *a, size_t point, const struct fit_sample *s, int saturated,
                 struct gonio_err *err);

/* What the rig did at pool point `point`: the integration its detector
 * chose (journal_sample.integration_s) and the rig time the point took
 * from the end of the point observed before it (from 0 for the first).
 * The policy then costs candidates with the integration measured nearest
 * them, and multiplies every cost it checks against the budget by the
 * largest ratio of a point's rig time to its own cost of that point seen
 * so far (at least 1), so that the budget holds where the rig is slower
 * than the rig profile says (auto-exposure, a bad day). Give every
 * measured point, in the order measured; a resumed capture gives the
 * journal's in record order. A point outside the pool or a time that is
 * not finite and >= 0 is a GONIO_EUSAGE error. */
int adaptive_observe(adaptive *a, size_t point, double integration_s, double point_rig_s,
                     struct gonio_err *err);

/* The next point to measure, from the samples added so far, with the axes
 * at `at` and the rig clock at rig_time_s. pending: a point being measured
 * while this decides (not offered again, its cost counted from its axes),
 * or -1. Returns the pool index, -1 when the policy stops (st->stop says
 * why), or another negative code with err filled. st may be NULL. Safe to
 * run in another thread than adaptive_add's, never at the same time. */
long adaptive_next(adaptive *a, const struct rig_axes *at, double rig_time_s, long pending,
                   struct adaptive_status *st, struct gonio_err *err);

#endif
