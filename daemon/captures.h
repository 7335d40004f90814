/* The captures in goniod's capture root, as an operator finds them
 * (docs/protocol.md, "list"): each directory's state, progress and
 * last change, for the control socket's list command.
 *
 * A capture records its end in its directory as stop.json (written
 * atomically when the worker finishes, removed when a resume starts): the
 * state (complete, failed, aborted, or interrupted for a capture stopped by
 * goniod's own shutdown), why, and when. A directory with a journal, no
 * stop record and no worker running it was interrupted by a crash or a
 * kill: `gonio resume ID` continues it. */
#ifndef GONIO_DAEMON_CAPTURES_H
#define GONIO_DAEMON_CAPTURES_H

#include <stddef.h>
#include <time.h>

#include <jansson.h>

#include "capture/capture.h"
#include "common/err.h"

/* The end of a capture's run, as stop.json records it. */
struct captures_stop {
    const char *state;   /* "complete", "failed", "aborted", "interrupted" */
    /* the engine's or goniod's: complete, converged, aborted, shutdown, error */
    const char *reason;
    const char *message; /* why it failed, or "" */
    /* The run's summary (NULL for a failed run): samples, rig time and the
     * final fit's verdict. */
    const struct capture_summary *summary;
};

/* Write dir/stop.json atomically. */
int captures_record_stop(const char *dir, const struct captures_stop *stop,
                         struct gonio_err *err);
/* Remove dir/stop.json: the capture runs again. */
void captures_clear_stop(const char *dir);

/* Remove a capture's directory and everything in it, never following a
 * link out of it: a new capture that failed before its first sample (no
 * rig answering) leaves nothing to find, resume or clean up. 0, or -1
 * when something stayed (errno says why). */
int captures_remove(const char *dir);

/* The state a capture directory says it ended in: stop.json's, else
 * "complete" when it has results.json, else "interrupted"; state is "" when
 * dir is no goniod capture (no request.json). */
void captures_end_state(const char *dir, char *state, size_t size);

/* The live capture's figures (the worker's), which win over its files. */
struct captures_live {
    const char *id;   /* NULL: none runs */
    const char *state; /* "running" or "paused" */
    size_t done, total;
    double rig_time_s;
};

/* Every capture under root, newest change first: an array of objects
 * {id, plan, state, reason, message, samples_done, samples_total,
 * rig_time_s, last_change, fit_status, plan_log_error, sample, operator,
 * note} (docs/protocol.md, "list"). NULL when out of memory; a root that
 * does not exist yet lists nothing. */
json_t *captures_list(const char *root, const struct captures_live *live);

/* One directory's entry for a listing: NULL when root/name is not one
 * (skipped); *changed is its last change, by which the list sorts. */
typedef json_t *captures_entry_fn(const char *root, const char *name, const void *ctx,
                                  struct timespec *changed);
/* Every directory under root that entry_of makes an entry of, newest change
 * first (the same instant: by id, descending). NULL when out of memory; a
 * root that does not exist yet lists nothing. */
json_t *captures_list_dir(const char *root, captures_entry_fn *entry_of, const void *ctx);

#endif
