/* One goniod per rig: exclusive advisory locks (flock) that goniod holds
 * for its whole life, one on a lock file beside the control socket
 * (SOCKET.lock) and one on the capture root directory itself. A second
 * goniod configured with the same socket or the same capture root is
 * refused before it touches either, however busy, stopped or backlogged
 * the first one is; the kernel drops the locks when a daemon dies, even by
 * SIGKILL, so a crash never leaves a lock behind. */
#ifndef GONIO_DAEMON_LOCK_H
#define GONIO_DAEMON_LOCK_H

#include "common/err.h"

/* Lock the file path (created 0640 if missing) and write our pid into it,
 * for people; what names the lock's purpose in messages ("control
 * socket"). Returns the descriptor that holds the lock (close it to release
 * it), or a negative code with err naming the path and, when it can be
 * found, the pid of the process holding the lock. */
int goniod_lock_file(const char *path, const char *what, struct gonio_err *err);

/* Lock the directory dir itself (created, with its parents, if missing):
 * nothing is written inside it. As goniod_lock_file otherwise. */
int goniod_lock_dir(const char *dir, const char *what, struct gonio_err *err);

#endif
