/* Streaming fit: refit the ABC model while a capture runs and decide from
 * the measured data alone when more points would no longer change it.
 *
 * Samples arrive one by one (fit_stream_add). A fit round runs every
 * `every` new samples and whenever the caller marks the end of a
 * progressive level. Round 1 uses fit_abc's full robust start; later rounds
 * refine from the previous round's parameters (warm start). A round is
 * "calm" when both
 *   - the model changed little: the mean over the in-plane reference domain
 *     and the channels of |log(1 + f_r cos ti) - log(1 + f_{r-1} cos ti)|
 *     is below tol (the design's log metric between successive models), and
 *   - the previous model predicted the samples that arrived since it was
 *     fitted (held out from it) about as well as it fits its own samples:
 *     held-out log error <= (1 + holdout_tol) x its in-sample log error
 *     + tol (the absolute term keeps exact data, fitted to ~0, decidable).
 * A round with fewer than every/2 new samples (a level end just after a
 * periodic round) can reset the count of calm rounds but not add to it.
 * The stream converges after `rounds` consecutive calm rounds, never with
 * fewer than min_points samples. Neither test looks at the true material:
 * on a real rig there is none (docs/fitting.md, "Stopping on convergence").
 *
 * The stream is deterministic: the same samples in the same order and
 * with the same level marks give the same rounds and the same decision. */
#ifndef GONIO_FIT_STREAM_H
#define GONIO_FIT_STREAM_H

#include <stddef.h>

#include "brdf/abc.h"
#include "common/err.h"
#include "fit/fit.h"

struct fit_stream_options {
    int converge;       /* 0: never decide (stop: all); rounds still run if every > 0 */
    double tol;         /* model change between rounds, log metric */
    double holdout_tol; /* allowed relative excess of held-out over in-sample error */
    long rounds;        /* consecutive calm rounds to converge */
    long every;         /* new samples between rounds */
    long min_points;    /* no decision below this many samples */
    struct fit_options fit; /* passed to fit_abc (warm_start is managed here) */
};

/* Defaults (docs/fitting.md): tol 0.008, holdout_tol 1.0, rounds 2,
 * every 24, min_points 60, fit_default_options(). Captures take tol,
 * rounds, every and min_points from the plan's stop rule instead. */
struct fit_stream_options fit_stream_default_options(void);

/* Where a stream stands; all errors are log errors (NAN before they
 * exist). */
struct fit_stream_status {
    size_t samples;       /* samples received */
    size_t fitted;        /* samples in the latest round's fit */
    int rounds;           /* fit rounds run */
    int calm;             /* consecutive calm rounds so far */
    int converged;        /* the stop rule has decided */
    size_t converged_at;  /* samples when it decided (0: not yet) */
    double change;        /* model change at the latest round */
    double holdout;       /* previous model's error on the samples new in the latest round */
    double fit_error;     /* latest model's in-sample error */
};

typedef struct fit_stream fit_stream;

/* Returns 0, or -ENOMEM / -GONIO_EBADCONFIG (bad options) with err
 * filled. The in-plane reference domain is built once here. */
int fit_stream_new(const struct fit_stream_options *opt, fit_stream **out,
                   struct gonio_err *err);
void fit_stream_free(fit_stream *s);

/* Add one sample. level_end != 0 says the sample ends a progressive level,
 * which forces a round. Returns 1 when the stream has converged (now or
 * before), 0 otherwise, or a negative code with err filled (out of memory).
 * A failed fit round is not an error: it counts as a restless round. */
int fit_stream_add(fit_stream *s, const struct fit_sample *sample, int level_end,
                   struct gonio_err *err);

/* The latest round's parameters, NULL before the first successful round. */
const struct brdf_abc *fit_stream_params(const fit_stream *s);

void fit_stream_status(const fit_stream *s, struct fit_stream_status *st);

#endif
