/* goniod's bring-up commands (daemon/bringup.h) on the worker's thread:
 * one run on the rig at a time, a capture's or a command's, and the
 * command's result queued for the loop as a capture's stop is. */
#include <stdlib.h>
#include <string.h>

#include "daemon/worker_private.h"

static void *run_bringup(void *arg)
{
    worker *w = arg;
    struct worker_msg_bringup *m = calloc(1, sizeof *m);
    struct bringup_result res;
    struct rig_profile rig;
    memset(&res, 0, sizeof res);
    if ((res.rc = rig_profile_load(w->cfg->rig, &rig, &res.err)) == 0)
        bringup_run(w->cfg, &rig, &w->bringup, worker_hook_cancelled, w, &res);
    pthread_mutex_lock(&w->mu);
    if (m) { /* queued as it goes idle, as a capture's stop is */
        m->base.kind = WORKER_MSG_BRINGUP;
        m->ticket = w->bringup_ticket;
        m->job = w->bringup;
        m->result = res;
        worker_enqueue_locked(w, &m->base);
    }
    w->bringup_active = 0;
    pthread_mutex_unlock(&w->mu);
    if (m)
        worker_wake(w);
    return NULL;
}

int worker_bringup(worker *w, const struct bringup_job *job, unsigned long ticket,
                   struct gonio_err *err)
{
    int rc = worker_lock_idle(w, err);
    if (rc < 0)
        return rc;
    w->bringup = *job;
    w->bringup_ticket = ticket;
    w->bringup_active = 1;
    w->abort = 0;
    pthread_mutex_unlock(&w->mu);
    if ((rc = worker_spawn(w, run_bringup, "bring-up", err)) < 0) {
        pthread_mutex_lock(&w->mu);
        w->bringup_active = 0;
        pthread_mutex_unlock(&w->mu);
    }
    return rc;
}
