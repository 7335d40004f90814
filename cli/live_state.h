/* What `gonio live` shows (docs/live.md): the capture goniod streams, or
 * one read from its directory, kept as the browser pages need it.
 *
 * One thread feeds documents in (live_state_feed, live_state_load_dir,
 * live_state_note); any number of page connections take what is new for
 * them (live_state_next) as server-sent events. The feeder never waits for
 * a page: samples are kept once and every page has a cursor into them, and
 * the progress and the fit curve are single snapshots a slow page skips to
 * the latest of (coalesced), so a page's backlog is bounded whatever its
 * speed. */
#ifndef GONIO_CLI_LIVE_STATE_H
#define GONIO_CLI_LIVE_STATE_H
#include <stddef.h>

#include <jansson.h>

#include "common/err.h"

typedef struct live_state live_state;

/* NULL when out of memory. */
live_state *live_state_new(void);
void live_state_free(live_state *s);

/* One document of goniod's capture stream (docs/protocol.md): start,
 * descriptor, event, state, stop or ERROR; others are ignored. A start
 * begins a new run on every page. The fit curve follows goniod's streaming
 * fit rounds while a capture runs and the capture's model file once it
 * stops (when the directory is readable here). */
void live_state_feed(live_state *s, json_t *doc);

/* A finished (or interrupted) capture from its directory: samples.csv,
 * results.json and its model file when there. 0, or a negative code with
 * err naming the file. */
int live_state_load_dir(live_state *s, const char *dir, struct gonio_err *err);

/* An alarm line shown on the pages (goniod gone, ...). */
void live_state_note(live_state *s, const char *text);

/* Wake every waiting page and end their streams (shutdown). */
void live_state_close(live_state *s);

/* A page's position in the state; zero it for a new page. */
struct live_cursor {
    unsigned long run;      /* the run it shows */
    size_t samples;         /* samples sent of that run */
    unsigned long info_ver; /* progress snapshot sent */
    unsigned long fit_ver;  /* fit curve sent */
};

/* What is new for c as server-sent event text (malloc'd, *len bytes),
 * waiting up to timeout_ms for something; at most max_samples samples at
 * a time. Returns NULL with *len 0 on timeout, NULL with *len 1 once the
 * state is closed. */
char *live_state_next(live_state *s, struct live_cursor *c, int timeout_ms, size_t max_samples,
                      size_t *len);

#endif
