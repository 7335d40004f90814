/* The capture worker: one thread that runs capture_run (capture/capture.h)
 * for goniod, so the poll loop never waits on a device.
 *
 * The fit error a watcher sees while a capture runs is the engine's own
 * streaming fit (capture_config.progress_fit, the on_fit hook): one fit
 * path, over the samples the engine already holds.
 *
 * The worker reports to the loop through a queue of messages and a wake-up
 * pipe the loop polls; the loop steers the worker (pause, resume, abort)
 * through a mutex and a condition variable that the engine's control hook
 * waits on at every point boundary. One capture runs at a time. */
#ifndef GONIO_DAEMON_WORKER_H
#define GONIO_DAEMON_WORKER_H

#include <stddef.h>

#include "common/err.h"
#include "capture/capture.h"
#include "daemon/bringup.h"
#include "daemon/config.h"
#include "daemon/devices.h"
#include "journal/journal.h"

/* What to capture. Names and paths are already checked and resolved. */
struct worker_request {
    char id[128];
    char dir[2048];
    /* scene: the simulator's, "" on hardware when the request names none;
     * material: "" for the scene's (sim) or unknown (hardware); truth: the
     * reference of the truth errors, "" for none (docs/protocol.md). */
    char plan[1024], scene[1024], rig[1024], material[1024], truth[1024], model[32], order[32];
    char stop[16]; /* "all", "converge" or "" (the plan's rule) */
    /* The operator's metadata, "" when not given: the sample's name, who
     * ran it, a note (docs/protocol.md). */
    char sample[128], operator_name[128], note[1024];
    double budget_min, stop_target; /* the adaptive order's stops, 0: none */
    int prescan; /* capture_config.prescan: 0 the engine's default */
    int uncalibrated; /* capture_config.uncalibrated */
    int reference_after; /* capture_config.reference_after */
    /* The reference calibration in the configured calibration_root: an
     * id, "newest", or "" for none (capture_config.calibration). */
    char calibration[128];
    unsigned checks; /* capture_config.checks: the request's check (capture/checks.h) */
    int resume; /* the directory exists: continue from its journal */
};

/* A calibration to measure on the rig (gonio calibrate through goniod;
 * capture/calibration.h): written to dir, its calibration_root/id, with
 * request.json recording this for a resume. */
struct worker_calibration {
    char id[64], dir[2048]; /* cal_meta's id */
    int kind;               /* enum cal_kind */
    char plan[1024], rig[1024], standard[1024]; /* resolved references */
    char dark[64];          /* reference, stray: the dark it is taken with (resolved) */
    char stray[64];         /* reference: the stray light it subtracts (resolved; "": none) */
    double integration_s;   /* dark: an integration besides the rig's, 0: none */
    int ladder;             /* dark: at every rung of the rig's ranging ladder too */
    int per_point;          /* dark: frames per integration; reference, stray: repeats */
    double valid_s;
    int underfilled;        /* the spot (cal_meta.spot) */
    long long created;      /* unix seconds: the id's and calibration.json's */
    char rig_name[64], detector[32]; /* what it is of (worker_calibrate_check) */
};

enum worker_state { WORKER_IDLE, WORKER_RUNNING, WORKER_PAUSED };

struct worker_status {
    enum worker_state state;
    char id[128];
    size_t done, total;
    double rig_time_s;
    /* The current capture, else the last one (has_capture 0 before any):
     * its id, "running", "paused", "complete", "failed" or "aborted", why
     * it failed, its progress, the plan's rig-time estimate and the rig
     * time still to go (capture_progress). */
    int has_capture;
    char cap_id[128], cap_state[16], cap_message[GONIO_ERR_MSG_MAX];
    size_t cap_done, cap_total;
    double cap_rig_time_s, cap_estimate_s, cap_eta_s;
    /* The latest fit error known: the running capture's streaming fit
     * once it has one, else the last finished capture's fit. */
    int has_fit;
    char fit_id[128];
    double fit_log_error, fit_rel_rmse;
    size_t fit_samples;
    /* A bring-up command under way ("move arm"), "" when none. */
    char bringup[48];
    /* The final fit's verdict (fit_status_name), "" for a streaming fit's. */
    char fit_status[24];
    /* What runs or ran last: "capture", or a calibration's kind ("dark",
     * "reference"); while it waits on the operator, cap_message says what
     * they are to do. */
    char cap_kind[16];
};

/* PROMPT: a calibration waits on the operator (worker_status.cap_message
 * says for what); a bare struct worker_msg. */
enum worker_msg_kind {
    WORKER_MSG_START,
    WORKER_MSG_SAMPLE,
    WORKER_MSG_STOP,
    WORKER_MSG_BRINGUP,
    WORKER_MSG_PROMPT
};

/* The queue's link: every message begins with it, and its kind says which
 * of the structs below it is. */
struct worker_msg {
    enum worker_msg_kind kind;
    struct worker_msg *next;
};

struct worker_msg_start {
    struct worker_msg base;
    struct worker_request req;
    char plan_name[128];
    size_t total, already_done;
    double estimate_s; /* the plan's rig-time estimate (capture_progress) */
    int adaptive;      /* the adaptive order: total is the pool's size */
    size_t prescan;    /* the pre-scan's points (capture_progress) */
};

struct worker_msg_sample {
    struct worker_msg base;
    struct journal_sample sample;
    size_t done, total;
    double fit_log_error; /* the streaming fit's in-sample error, NAN before a round */
    double eta_s;         /* rig time still to go (capture_progress) */
    /* The adaptive order's prediction (capture_progress.policy): the
     * full-domain log error now, and predicted_next after predicted_next_s
     * more rig time; NAN in other orders. */
    double predicted, predicted_next, predicted_next_s;
};

struct worker_msg_stop {
    struct worker_msg base;
    char id[128], dir[2048];
    int rc;                      /* capture_run's result */
    char reason[32];             /* complete, converged, aborted, shutdown, error */
    struct gonio_err err;
    struct capture_summary summary;
    int has_comm; /* the capture ran on a bus: its exchange counts */
    struct goniod_comm_stats comm;
    /* A calibration's stop: its kind ("" for a capture); summary.samples
     * and rig_time_s are its frames and the last one's rig time. */
    char calibration[16];
    /* A calibration's run as event-model lines (capture/cal_documents.h),
     * each ending in '\n'; malloc'd, NULL: none. */
    char *documents;
    /* A new capture failed before its first sample: nothing in its
     * directory is worth keeping, and the loop removes it once the stop
     * is sent (captures_remove). */
    int discard_dir;
};

/* A bring-up command ended (worker_bringup): its ticket and result. */
struct worker_msg_bringup {
    struct worker_msg base;
    unsigned long ticket;
    struct bringup_job job;
    struct bringup_result result;
};

typedef struct worker worker;

/* The worker for a daemon configured by cfg (which must outlive it).
 * Returns NULL on failure with err filled. */
worker *worker_new(const struct goniod_config *cfg, struct gonio_err *err);
/* Stops a running capture (reason "shutdown") and waits for it. */
void worker_free(worker *w);

/* The read end of the wake-up pipe: readable when messages are queued. */
int worker_wake_fd(const worker *w);

/* Prepare a request's capture as the run will (capture_prepare) without
 * writing anything; err names the field and value of what is wrong. The
 * prepared capture is kept for worker_start of the same request (id and
 * directory), which runs it as it is: one resolution per capture. */
int worker_check(worker *w, const struct worker_request *req, struct gonio_err *err);

/* Start a capture, the one worker_check prepared for req if any (else the
 * worker thread prepares it: a resume); refused (GONIO_EUSAGE, err naming
 * the capture that runs) while one runs. */
int worker_start(worker *w, const struct worker_request *req, struct gonio_err *err);

/* Pause/resume take effect at the next point boundary. They return
 * -GONIO_EUSAGE with err filled when there is nothing to pause/resume. */
int worker_pause(worker *w, struct gonio_err *err);
int worker_continue(worker *w, struct gonio_err *err);
/* Abort the running capture at the next point boundary; reason goes into
 * the stop document ("aborted", "shutdown"). A running bring-up command
 * ends at once instead, its axes stopped (daemon/bringup.h). */
int worker_abort(worker *w, const char *reason, struct gonio_err *err);

void worker_get_status(worker *w, struct worker_status *st);

/* Run a bring-up command (daemon/bringup.h) on the configured drives in
 * the worker's thread; its end is a WORKER_MSG_BRINGUP with ticket.
 * Refused (GONIO_EUSAGE) while a capture or another one runs. */
int worker_bringup(worker *w, const struct bringup_job *job, unsigned long ticket,
                   struct gonio_err *err);

/* Check a calibration as its run will (rig profile, plan, standard, and a
 * reference's dark, which c->dark gets resolved), without measuring or
 * writing anything (c->rig_name and c->detector get what it is of); err
 * names the field and value of what is wrong. */
int worker_calibrate_check(worker *w, struct worker_calibration *c, struct gonio_err *err);

/* Start measuring calibration c (new, or continuing its journal) in the
 * worker's thread: pause, resume and abort steer it as they do a
 * capture, status shows it, the stop document ends it. */
int worker_calibrate(worker *w, const struct worker_calibration *c, struct gonio_err *err);

/* Take every queued message (oldest first); free each with free(). Joins
 * the capture thread once its STOP message has been taken. */
struct worker_msg *worker_take(worker *w);

#endif
