/* The worker's state, shared by worker.c (captures, bring-up) and
 * worker_calibrate.c (calibrations): one thread at a time runs on the rig,
 * steered through the same mutex, pause and abort. */
#ifndef GONIO_DAEMON_WORKER_PRIVATE_H
#define GONIO_DAEMON_WORKER_PRIVATE_H

#include <pthread.h>

#include "daemon/worker.h"
#include "sim_source/sim_source.h"

/* A request's capture, prepared once: the job and the rig source it runs
 * on (with the sim driver, or a scene to describe, the source's sim). */
struct prepared {
    char id[128], dir[4096];
    sim_source *sim;
    struct capture_rig rig;
    capture_job *job;
};

struct worker {
    const struct goniod_config *cfg;
    pthread_mutex_t mu;
    pthread_cond_t cv;       /* pause/abort/resume changes */
    int pipe_rd, pipe_wr;
    pthread_t thread;
    int thread_live;         /* started and not joined yet */
    int running;             /* a capture is in capture_run */
    int paused, abort;
    char abort_reason[32];
    struct worker_request req;
    /* The capture worker_check prepared, until worker_start takes it (the
     * main thread's), and the one the worker thread runs. */
    struct prepared *pending, *current;
    size_t done, total;
    double rig_time_s, estimate_s, eta_s;
    double predicted[3]; /* the adaptive order's prediction (worker_msg_sample) */
    int announced; /* this run's start message is queued */
    /* A calibration runs (worker_calibrate): its kind, "" for a capture;
     * and what the operator is asked to do while it waits on them. */
    char calibration[16];
    char prompt[512];
    struct worker_calibration cal;
    /* The last capture's end: "" while none has ended since the current
     * one started (worker_status). */
    int has_capture;
    char end_state[16], end_message[GONIO_ERR_MSG_MAX];
    struct worker_msg *head, *tail;
    void *bus; /* the Modbus bus while a capture holds it */
    /* A bring-up command under way in the thread (bringup_active), its
     * job and ticket. */
    int bringup_active;
    struct bringup_job bringup;
    unsigned long bringup_ticket;
    int has_comm; /* the last capture's bus counts, taken as it closed */
    struct goniod_comm_stats comm;
    int has_fit, fit_final; /* fit_final: the figures are done_fit's */
    char fit_id[128];
    double fit_log, fit_rmse;
    size_t fit_n;
    /* The last completed capture's figures: what status shows again once
     * a capture stops without completing (docs/protocol.md, fit_error). */
    struct {
        int has;
        char id[128];
        double log, rmse;
        size_t n;
        char status[24]; /* its verdict (fit_status_name) */
    } done_fit;
#ifdef GONIO_TEST_HOOKS
    /* Crash torture (docs/torture.md): GONIOD_PHASE_LOG names a file that
     * gets a line per engine phase, GONIOD_PHASE_HOLD pauses in phases. */
    int phase_fd;
    double hold_s[CAPTURE_PHASE_FIT + 1];
#endif
};

/* worker.c's helpers, for worker_calibrate.c. */
void worker_push_msg(worker *w, struct worker_msg *m);
void worker_enqueue_locked(worker *w, struct worker_msg *m);
void worker_wake(worker *w);
enum capture_control worker_hook_control(void *user);
/* The operator must act (capture_hooks.ask, cal_hooks.ask): goniod pauses
 * with the instruction in status until gonio resume, or an abort. */
enum capture_control worker_hook_ask(void *user, const char *instruction);
int worker_hook_open(void *user, const struct rig_profile *rig, const char *dir,
                     struct capture_devices *dev, struct gonio_err *err);
void worker_hook_close(void *user, struct capture_devices *dev);
/* The rig's sample changer on the run's bus (capture_rig.mount,
 * cal_hooks.mount). */
int worker_hook_mount(void *user, struct capture_devices *dev, enum capture_slot slot,
                      const char *standard, struct gonio_err *err);
int worker_hook_cancelled(void *user);
/* One run on the rig at a time: worker_lock_idle takes the lock when
 * nothing runs (else refuses, naming what does), the caller sets the run's
 * state (a capture's or a calibration's from worker_run_begin_locked:
 * running, not paused or aborted, no progress or end yet) and unlocks, and
 * worker_spawn starts its thread. */
int worker_lock_idle(worker *w, struct gonio_err *err);
void worker_run_begin_locked(worker *w);
int worker_spawn(worker *w, void *(*body)(void *), const char *what, struct gonio_err *err);

/* A calibration's run as event-model lines, written to its directory as
 * well (worker_calibrate_documents.c); malloc'd, NULL when out of memory.
 * rc, aborted and err are how it ended. */
struct cal_meta;
struct cal_frame;
char *worker_calibration_documents(worker *w, const struct cal_meta *meta,
                                   const struct cal_frame *frames, size_t n, size_t total,
                                   int rc, int aborted, const struct gonio_err *err,
                                   double t_start);

#endif
