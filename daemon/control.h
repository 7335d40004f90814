/* goniod's control socket (docs/protocol.md): a Unix stream socket carrying
 * one JSON object a line each way. Requests go through one command table;
 * capture progress from the worker is streamed to the clients that watch.
 *
 * Nothing here blocks: sockets are non-blocking, every client has a bounded
 * outgoing buffer, and a watcher that cannot keep up is dropped rather than
 * slowing the capture down. */
#ifndef GONIO_DAEMON_CONTROL_H
#define GONIO_DAEMON_CONTROL_H

#include <poll.h>
#include <stddef.h>

#include "common/err.h"
#include "daemon/config.h"
#include "daemon/request.h" /* CONTROL_MAX_LINE */
#include "daemon/worker.h"

#define CONTROL_PROTO_MAJOR 1
#define CONTROL_PROTO_MINOR 0

typedef struct control control;

/* Take the socket's lock (cfg->socket_path + ".lock", daemon/lock.h), then
 * bind and listen on cfg->socket_path, mode 0660, group cfg->socket_group
 * when set. A socket file there is replaced only when it is stale: the
 * lock was free and nothing answers on it. */
control *control_new(const struct goniod_config *cfg, worker *w, struct gonio_err *err);
/* Close every client, remove the socket file, then release its lock. */
void control_free(control *c);

/* The descriptors to poll: at most max entries; returns the count. */
size_t control_pollfds(control *c, struct pollfd *pfd, size_t max);
/* Act on the poll results of the entries control_pollfds filled. */
void control_handle(control *c, const struct pollfd *pfd, size_t n);
/* Stream the worker's messages to the watchers. */
void control_dispatch(control *c, struct worker_msg *msgs);
/* Close idle clients; returns the milliseconds until the next check. */
int control_tick(control *c);
/* Try to send what is queued, for at most timeout_ms (shutdown). */
void control_flush(control *c, int timeout_ms);

/* A client asked the daemon to shut down. */
int control_shutdown_requested(const control *c);

/* A status line for systemd (STATUS=...). */
void control_status_text(control *c, char *buf, size_t size);

#endif
