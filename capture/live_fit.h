/* Inside capture/: the capture's streaming fit (fit/stream.h) as it
 * measures: the stop rule of stop: converge, or with progress_fit the
 * rounds behind a host's progress figures. */
#ifndef GONIO_CAPTURE_LIVE_FIT_H
#define GONIO_CAPTURE_LIVE_FIT_H

#include "capture/capture.h"
#include "fit/stream.h"
#include "journal/journal.h"
#include "planner/planner.h"

struct live_fit {
    fit_stream *fs;   /* NULL: no streaming fit */
    int progress;     /* rounds at 16, 32, 64... samples only */
    double log_error; /* the latest round's in-sample log error, NAN before one */
};

/* The streaming fit a capture runs: its plan's stop rule (or cfg->stop)
 * converge, or rounds for a host's progress figures; none otherwise, and
 * none in the adaptive order. Free st->fs with fit_stream_free. */
int live_fit_new(const struct capture_config *cfg, const struct plan *plan,
                 struct live_fit *st, struct gonio_err *err);

/* Feed the journalled sample js[n - 1] to the streaming fit. A round is
 * forced (and announced as the FIT phase) where a progressive level ends,
 * or, for progress, where the count reaches 16, 32, 64... After a round,
 * the host's on_fit hears its in-sample errors. Returns 1 once the stop
 * rule has decided. */
int live_fit_feed(struct live_fit *st, const struct plan *plan,
                  const struct capture_hooks *hooks, const struct journal_sample *js,
                  size_t n, struct gonio_err *err);

#endif
