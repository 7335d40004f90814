/* Inside goniod's control socket: the state its files share.
 *
 *   control.c           the listening socket's life cycle and the poll loop's calls
 *   control_clients.c   connections: bounded buffers, reading lines, rate and idle
 *                       limits (control_tick)
 *   control_commands.c  the command table and what each command does
 *   control_paths.c     what a request may name on disk, and the request record
 *   control_files.c     the plan and rig files a capture request carries
 *   control_stream.c    the documents streamed to watchers during a capture
 *                       (control_dispatch)
 *   control_events.c    the same capture as Bluesky event-model documents
 *
 * Nothing outside these files includes this header: daemon/control.h is the
 * interface. */
#ifndef GONIO_DAEMON_CONTROL_PRIVATE_H
#define GONIO_DAEMON_CONTROL_PRIVATE_H

#include <math.h>
#include <stddef.h>
#include <sys/types.h>

#include <jansson.h>

#include "common/clock.h"
#include "common/err.h"
#include "daemon/bringup.h"
#include "daemon/control.h"
#include "daemon/worker.h"

/* What a watching client subscribed to (bits of control_client.watching):
 * the capture stream's own documents, event-model [name, doc] pairs. */
enum { CONTROL_WATCH_STREAM = 1, CONTROL_WATCH_EVENTS = 2 };

/* The current run as event-model documents (control_events.c): uids the
 * later documents refer to, and the run_start and descriptor lines kept for
 * watchers that subscribe mid-capture. */
struct control_events {
    char run[37], primary[37]; /* "" when no run is open */
    char *start_text, *descriptor_text;
    unsigned long long seq;
    int adaptive;
};

struct control_client {
    int fd;
    size_t max_out;    /* queued output beyond this drops the client */
    char *in;          /* CONTROL_MAX_LINE + 1 bytes */
    size_t in_len;
    char *out;
    size_t out_len, out_cap;
    int watching;      /* CONTROL_WATCH_* bits */
    int closing;       /* close once out is sent */
    int dead;
    double last_active; /* last well-formed request (or the connect) */
    double tokens;      /* rate limit: requests it may send now */
    double tokens_at;   /* when tokens was last refilled */
};

struct control {
    const struct goniod_config *cfg;
    worker *w;
    int listen_fd;
    int lock_fd;        /* holds the socket's lock (daemon/lock.h) */
    uid_t self_uid;     /* goniod's own user: always allowed */
    gid_t allowed_gid;  /* peers in this group are allowed (socket.group, else ours) */
    struct control_client **clients;
    size_t n_clients;
    int shutdown;
    /* The running capture's start and descriptor documents, for watchers
     * that subscribe mid-capture; NULL when idle. */
    char *start_doc, *descriptor_doc;
    unsigned long long seq; /* event sequence number within a capture */
    /* The client waiting for a bring-up command's reply (NULL: none, or it
     * left), the request's id (owned) and the worker's ticket. */
    struct control_client *bringup_client;
    json_t *bringup_id;
    unsigned long bringup_ticket;
    struct control_events ev;
    /* Refused clients in the current log window (control_clients.c): since
     * when, how many logged in full, how many only counted. */
    double refused_since;
    unsigned long refused_logged, refused_unlogged;
};

/* ---- control_clients.c ------------------------------------------------ */

/* The one-line text of doc (compact, keys in insertion order); takes the
 * reference to doc. NULL when out of memory. */
char *control_json_text(json_t *doc);

/* NaN and infinities have no JSON form: they become null. */
static inline json_t *control_json_number(double v)
{
    return isfinite(v) ? json_real(v) : json_null();
}

/* Accept every pending connection: greet it with VERSION, or refuse it
 * (wrong peer, too many clients) with an ERROR and close it. */
void control_accept_clients(control *c);
/* Read what arrived and run each complete line through control_handle_line. */
void control_client_read(control *c, struct control_client *cl);
/* Send what is queued without blocking; a client that closed is marked dead. */
void control_client_try_write(struct control_client *cl);
/* Queue one line (text plus '\n'); a client whose queue would pass its limit
 * is dropped. */
void control_client_send_text(struct control_client *cl, const char *text);
/* Queue doc as one line; takes the reference to doc. */
void control_client_send(struct control_client *cl, json_t *doc);
/* Queue {"class":"ERROR",...}; id (borrowed, may be NULL) is echoed. */
void control_send_error(struct control_client *cl, const char *code, json_t *id,
                        const char *fmt, ...) __attribute__((format(printf, 4, 5)));
/* Queue one line to every client watching the capture stream. */
void control_broadcast(control *c, const char *text);
/* Queue one line to every client watching with format (CONTROL_WATCH_*). */
void control_broadcast_to(control *c, int format, const char *text);
/* Log the count of refused clients not yet logged, if any (at shutdown). */
void control_refusals_flush(control *c);
/* Close and free the dead clients, keeping the others in order. */
void control_reap(control *c);
void control_client_free(struct control_client *cl);

/* ---- control_stream.c ------------------------------------------------- */

/* Tell watchers the capture is now paused or running again (after pause
 * and resume): {"class":"state","capture_id":...,"state":"paused"}. */
void control_broadcast_state(control *c);

/* ---- control_events.c ------------------------------------------------- */

/* The event-model documents of a capture run's start (run_start, the primary
 * stream's descriptor), of each sample (an event) and of its end (the fit
 * stream, run_stop), sent to event-model watchers. */
void control_events_start(control *c, const struct worker_msg_start *m);
void control_events_sample(control *c, const struct worker_msg_sample *m);
void control_events_stop(control *c, const struct worker_msg_stop *m);
/* A watcher that subscribes mid-run: the run's run_start and descriptor. */
void control_events_greet(control *c, struct control_client *cl);
/* Send event-model watchers each line of text ('\n'-terminated lines;
 * NULL: none): a calibration's run (capture/cal_documents.h). */
void control_events_lines(control *c, const char *text);
void control_events_free(control *c);

/* ---- control_commands.c ----------------------------------------------- */

/* Run one request line (without its newline) and queue the reply. Returns
 * 1 when the line was a well-formed request (run, or refused for the rig's
 * state), 0 when it was malformed. */
int control_handle_line(control *c, struct control_client *cl, const char *line, size_t len);
/* ---- control_bringup.c ------------------------------------------------ */

/* A bring-up command (daemon/bringup.h) checked and handed to the worker
 * for cl: 1 (its reply waits for control_bringup_reply), or an error. */
int control_cmd_bringup(control *c, enum bringup_op op, json_t *req, const char **code,
                        struct gonio_err *err, struct control_client *cl);
/* The reply of a bring-up command the worker ended, to the client that
 * asked for it if it is still there. */
void control_bringup_reply(control *c, const struct worker_msg_bringup *m);

/* ---- control_calibrate.c ---------------------------------------------- */

/* The calibrate command: checked, its directory made in the calibration
 * root, its run handed to the worker; reply gets capture_id, dir and
 * calibration (the kind). */
int control_cmd_calibrate(control *c, json_t *req, json_t *reply, const char **code,
                          struct gonio_err *err);
/* Whether id is a calibration goniod started (its record in the
 * calibration root). */
int control_is_calibration(const control *c, const char *id);
/* resume ID of a calibration that did not finish: its journal continued. */
int control_resume_calibration(control *c, const char *id, json_t *reply, const char **code,
                               struct gonio_err *err);

/* ---- control_paths.c -------------------------------------------------- */

/* A capture id: one path component of 1..100 safe characters, not starting
 * with '.' or '-'. */
int control_valid_id(const char *s);
/* A plan, scene or rig named by a request (what names it in messages): a
 * bare name from the configs folder, or a file inside the capture root,
 * written to out as its real path. 0, or a GONIO_EUSAGE error. */
int control_resolve_ref(const control *c, const char *what, const char *v, char *out,
                        size_t size, struct gonio_err *err);
/* A material spec named by a request; a merl: file is held to the capture
 * root like control_resolve_ref's files. 0, or a GONIO_EUSAGE error. */
int control_resolve_material(const control *c, const char *v, char *out, size_t size,
                             struct gonio_err *err);
/* Look for a symbolic link among dir's entries: *link names the first one
 * found (in name), NULL when there is none. Returns -1 when dir cannot be
 * read. */
int control_dir_symlink(const char *dir, char *name, size_t size, const char **link);
/* r->dir/request.json, the record of the request that resume reads back. */
int control_save_request(const struct worker_request *r, struct gonio_err *err);
/* Fill r (id and dir set) from its record, its paths checked again. */
int control_load_request(const control *c, struct worker_request *r, struct gonio_err *err);
/* Undo a capture that did not start: its record and its (empty) directory. */
void control_discard_request(const struct worker_request *r);

/* ---- control_files.c -------------------------------------------------- */

/* The files a capture request carries: plan_text with plan, rig_text with
 * rig, scene_text with scene (docs/protocol.md). */
enum { CONTROL_SENT_MAX = 3 };
struct control_sent_file {
    const char *field; /* "plan", "rig" or "scene" */
    const char *name;  /* the file as the operator named it (messages) */
    const char *base;  /* its last component: the copy's name */
    const char *text;  /* borrowed from the request */
    size_t len;
    char path[2560];   /* the copy in the capture directory, "" until written */
    int written;
};
struct control_sent {
    struct control_sent_file files[CONTROL_SENT_MAX];
    int n;
};
/* The files req carries (none: s->n 0), their names checked. 0, or a
 * GONIO_EUSAGE error naming the field and the file. */
int control_sent_take(json_t *req, struct control_sent *s, struct gonio_err *err);
/* Write each copy into dir/request/FIELD/NAME (dir exists); a plan's
 * progressive levels must be names. On error, control_sent_discard. */
int control_sent_write(struct control_sent *s, const char *dir, struct gonio_err *err);
/* The copy of field ("plan", "rig", "scene") once written, else NULL. */
const char *control_sent_path(const struct control_sent *s, const char *field);
/* Remove the copies written and their folders (dir itself stays). */
void control_sent_discard(const struct control_sent *s, const char *dir);
/* In err's message, each copy's path becomes the file's name as the
 * operator gave it: the message the same file would get from gonio. */
void control_sent_rename(const struct control_sent *s, struct gonio_err *err);

#endif
