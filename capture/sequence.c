#include "capture/sequence.h"

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "common/clock.h"
#include "fit/journal_samples.h"

/* One decision of the adaptive policy: give it the sample measured before
 * the pending point (when it has not had it yet), then ask for the next. */
struct decision {
    const struct journal_sample *add; /* NULL: nothing new */
    double add_rig_s; /* the rig time add took, from the record before it */
    long pending;
    struct rig_axes at;
    double rig_time_s;
    long next; /* the answer: a point, -1 (stop), or a negative code */
    struct adaptive_status st;
    struct gonio_err err;
    double wall_s;
};

struct sequence {
    const struct plan *plan;
    const struct rig_profile *rig;
    size_t count;
    unsigned char *done; /* journalled points */
    adaptive *policy;    /* NULL: plan order */
    /* Plan order: the pre-scan's points, measured first; the walk through
     * the rest (route: the plan's order, or a resumed capture's points
     * left travelled from where its axes stood: sequence_reroute), and
     * the first step of it that may not be done yet (those before it are). */
    long *prescan;
    size_t n_prescan;
    long *route;
    size_t cursor;
    /* The adaptive order: the sample journalled before the pending point
     * (has_prev), which the policy gets in the next decision unless
     * prev_added; prev_start_s: the rig time of the record before prev
     * (0 for the first). */
    struct journal_sample prev;
    double prev_start_s;
    int has_prev, prev_added;
    struct decision d;
    pthread_t thread;
    int running;
    struct sequence_report report;
    double decision_sum_s;
};

static const struct rig_axes home = {0, 0, 0};

/* The sample, and what the rig did to take it: what the policy learns
 * of the rig's time comes from the journal only, so a replay learns the
 * same. */
static int policy_add(adaptive *a, const struct journal_sample *s, double rig_s,
                      struct gonio_err *err)
{
    struct fit_sample fs;
    fit_journal_samples(s, 1, &fs);
    int rc = adaptive_add(a, (size_t)s->point, &fs, (s->flags & JOURNAL_FLAG_SATURATED) != 0,
                          err);
    return rc < 0 ? rc : adaptive_observe(a, (size_t)s->point, s->integration_s, rig_s, err);
}

/* s journalled after prev. */
static void set_prev(sequence *q, const struct journal_sample *s)
{
    q->prev_start_s = q->has_prev ? q->prev.rig_time_s : 0;
    q->prev = *s;
    q->has_prev = 1;
    q->prev_added = 0;
}

static void decide(sequence *q, struct decision *d)
{
    double t0 = gonio_monotonic_s();
    int rc = d->add ? policy_add(q->policy, d->add, d->add_rig_s, &d->err) : 0;
    d->next = rc < 0 ? rc
                     : adaptive_next(q->policy, &d->at, d->rig_time_s, d->pending, &d->st,
                                     &d->err);
    d->wall_s = gonio_monotonic_s() - t0;
}

static void *decide_thread(void *arg)
{
    sequence *q = arg;
    decide(q, &q->d);
    return NULL;
}

/* The decision with `pending` being measured, after prev (NULL: the first
 * point); prev is given to the policy unless it already has it. The axes
 * and the rig clock are prev's as the journal has them (home and 0 before
 * the first point), from which the policy counts the pending point's
 * cost: a resumed capture passes what the uninterrupted one did. */
static void decision_set(sequence *q, long pending)
{
    const struct journal_sample *prev = q->has_prev ? &q->prev : NULL;
    memset(&q->d, 0, sizeof q->d);
    q->d.add = prev && !q->prev_added ? prev : NULL;
    q->d.add_rig_s = prev ? prev->rig_time_s - q->prev_start_s : 0;
    q->d.pending = pending;
    q->d.at = prev ? plan_point(q->plan, (size_t)prev->point)->ax : home;
    q->d.rig_time_s = prev ? prev->rig_time_s : 0;
    q->prev_added = 1;
}

/* The decision's answer as the engine takes it. */
static int decision_take(sequence *q, long *next, struct gonio_err *err)
{
    q->report.status = q->d.st;
    if (q->d.next < -1) {
        if (err)
            *err = q->d.err;
        return (int)q->d.next;
    }
    *next = q->d.next;
    return 0;
}

/* Plan order: the next point the journal lacks, the pre-scan's first. */
static long next_undone(sequence *q)
{
    for (size_t j = 0; j < q->n_prescan; j++)
        if (!q->done[q->prescan[j]])
            return q->prescan[j];
    while (q->cursor < q->count && q->done[q->route[q->cursor]])
        q->cursor++;
    return q->cursor < q->count ? q->route[q->cursor] : -1;
}

/* The pre-scan's points: one in each of n equal stretches of the plan's
 * order. The order is a tour (or levels of tours) that keeps neighbours
 * together, so the stretches spread over the plan's domain in proportion
 * to its density of points: each pre-scanned point stands for its stretch,
 * which is what a sum over the points (the ETA) weighs it by. In each
 * stretch the point the axes reach soonest from the one before (where the
 * order starts for the first): the pre-scan crosses the domain once, in as little rig time
 * as the stretches allow, rather than zigzagging through their middles. */
static int prescan_points(sequence *q, size_t n, struct gonio_err *err)
{
    if (n > q->count)
        n = q->count;
    if (n == 0)
        return 0;
    if (!(q->prescan = malloc(n * sizeof *q->prescan)))
        return gonio_err_set(err, ENOMEM, "out of memory");
    struct rig_axes at;
    plan_order_start(q->plan, &at); /* home, or where the capture found the axes */
    for (size_t j = 0; j < n; j++) {
        size_t lo = j * q->count / n, hi = (j + 1) * q->count / n;
        double best = INFINITY;
        for (size_t i = lo; i < hi; i++) {
            double t = rig_move_time_backlash(q->rig, &at, &plan_point(q->plan, i)->ax);
            if (t < best) {
                best = t;
                q->prescan[j] = (long)i;
            }
        }
        at = plan_point(q->plan, (size_t)q->prescan[j])->ax;
    }
    q->n_prescan = n;
    return 0;
}

/* The policy's first decision, and a resumed capture's replay: the
 * journal's samples in record order, each decision made again as the
 * uninterrupted capture made it while the point was measured (the policy
 * refits in every decision, warm-starting from the one before, so the
 * samples alone would not bring it to the same state). The last decision
 * gives the point that comes next. */
static int replay(sequence *q, const struct journal_sample *js, size_t n, long *first,
                  struct gonio_err *err)
{
    decision_set(q, -1);
    decide(q, &q->d);
    int rc = decision_take(q, first, err);
    for (size_t i = 0; i < n && rc == 0; i++) {
        decision_set(q, js[i].point);
        decide(q, &q->d);
        set_prev(q, &js[i]);
        rc = decision_take(q, first, err);
    }
    return rc;
}

int sequence_new(const struct sequence_setup *su, const struct journal_sample *js, size_t n,
                 sequence **out, long *first, struct gonio_err *err)
{
    const struct plan *plan = su->plan;
    const struct rig_profile *rig = su->rig;
    *out = NULL;
    sequence *q = calloc(1, sizeof *q);
    size_t count = plan_count(plan);
    if (!q || !(q->done = calloc(count ? count : 1, 1)) ||
        !(q->route = malloc((count ? count : 1) * sizeof *q->route))) {
        if (q)
            free(q->done);
        free(q);
        return gonio_err_set(err, ENOMEM, "out of memory");
    }
    for (size_t i = 0; i < count; i++)
        q->route[i] = (long)i;
    q->plan = plan;
    q->rig = rig;
    q->count = count;
    for (size_t i = 0; i < n; i++) {
        int p = js[i].point;
        if (p < 0 || (size_t)p >= count || q->done[p]) {
            sequence_free(q);
            return gonio_err_set(err, GONIO_EBADDATA,
                                 "%s: journal record %zu names point %d, which the plan (%zu "
                                 "points) does not have or has twice",
                                 su->dir, i + 1, p, count);
        }
        q->done[p] = 1;
    }
    int rc = 0;
    if (plan_current_order(plan) != PLAN_ORDER_ADAPTIVE) {
        rc = prescan_points(q, su->prescan, err);
        *first = next_undone(q);
    } else if (!(q->policy = adaptive_new(plan, rig, su->integration_s, su->opt, err))) {
        rc = -abs(err && err->code ? err->code : ENOMEM);
    } else {
        rc = replay(q, js, n, first, err);
    }
    if (rc < 0) {
        sequence_free(q);
        return rc;
    }
    *out = q;
    return 0;
}

static void join(sequence *q)
{
    if (!q->running)
        return;
    double t0 = gonio_monotonic_s();
    pthread_join(q->thread, NULL);
    q->running = 0;
    q->report.wait_s += gonio_monotonic_s() - t0;
    q->report.decisions++;
    q->decision_sum_s += q->d.wall_s;
    q->report.decision_mean_s = q->decision_sum_s / (double)q->report.decisions;
    if (q->d.wall_s > q->report.decision_max_s)
        q->report.decision_max_s = q->d.wall_s;
}

void sequence_free(sequence *q)
{
    if (!q)
        return;
    join(q);
    adaptive_free(q->policy);
    free(q->prescan);
    free(q->route);
    free(q->done);
    free(q);
}

int sequence_begin(sequence *q, long k, struct gonio_err *err)
{
    if (!q->policy)
        return 0;
    decision_set(q, k);
    int rc = pthread_create(&q->thread, NULL, decide_thread, q);
    if (rc != 0)
        return gonio_err_set(err, rc, "adaptive decision thread: %s", strerror(rc));
    q->running = 1;
    return 0;
}

int sequence_end(sequence *q, const struct journal_sample *s, long *next,
                 struct gonio_err *err)
{
    *next = -1;
    if (s)
        q->done[s->point] = 1;
    if (!q->policy) {
        if (s)
            *next = next_undone(q);
        return 0;
    }
    join(q);
    if (!s)
        return 0;
    set_prev(q, s);
    return decision_take(q, next, err);
}

static int in_prescan(const sequence *q, long i)
{
    for (size_t j = 0; j < q->n_prescan; j++)
        if (q->prescan[j] == i)
            return 1;
    return 0;
}

/* The points measured already first (their moves are history), then those
 * left in the order they will be measured: each counts its move from the
 * one before it on the path the rig takes. */
void sequence_order(const sequence *q, long *order)
{
    size_t k = 0;
    for (int left = 0; left < 2; left++) {
        for (size_t j = 0; j < q->n_prescan; j++)
            if ((!q->done[q->prescan[j]]) == left)
                order[k++] = q->prescan[j];
        for (size_t i = 0; i < q->count; i++)
            if ((!q->done[q->route[i]]) == left && !in_prescan(q, q->route[i]))
                order[k++] = q->route[i];
    }
}

/* The points of ids (m) not done yet, in place; their count. */
static size_t keep_left(const sequence *q, long *ids, size_t m)
{
    size_t n = 0;
    for (size_t k = 0; k < m; k++)
        if (!q->done[ids[k]])
            ids[n++] = ids[k];
    return n;
}

int sequence_reroute(sequence *q, const struct rig_axes *at, long *first,
                     struct gonio_err *err)
{
    enum plan_order_mode mode = plan_current_order(q->plan);
    if (q->policy || mode == PLAN_ORDER_AS_WRITTEN)
        return 0; /* *first stays the one the sequence gave */
    /* The pre-scan's points left, from the axes; the rest from the last of
     * them (or the axes). The points done keep their places before them. */
    long *pre = malloc((q->n_prescan ? q->n_prescan : 1) * sizeof *pre);
    long *rest = malloc((q->count ? q->count : 1) * sizeof *rest);
    int rc = pre && rest ? 0 : -ENOMEM;
    size_t n_pre = 0, n_rest = 0, n_done = 0;
    if (rc == 0) {
        if (q->n_prescan)
            memcpy(pre, q->prescan, q->n_prescan * sizeof *pre);
        n_pre = keep_left(q, pre, q->n_prescan);
        rc = plan_order_subset(q->plan, mode, q->rig, at, pre, n_pre);
    }
    for (size_t i = 0; rc == 0 && i < q->count; i++)
        if (!q->done[q->route[i]] && !in_prescan(q, q->route[i]))
            rest[n_rest++] = q->route[i];
    struct rig_axes from = n_pre ? plan_point(q->plan, (size_t)pre[n_pre - 1])->ax : *at;
    if (rc == 0)
        rc = plan_order_subset(q->plan, mode, q->rig, &from, rest, n_rest);
    if (rc == 0) {
        for (size_t j = 0, k = 0; j < q->n_prescan; j++)
            if (!q->done[q->prescan[j]])
                q->prescan[j] = pre[k++];
        for (size_t i = 0; i < q->count; i++)
            if (q->done[q->route[i]] || in_prescan(q, q->route[i]))
                q->route[n_done++] = q->route[i];
        memcpy(q->route + n_done, rest, n_rest * sizeof *rest);
        q->cursor = 0;
        *first = next_undone(q);
    }
    free(pre);
    free(rest);
    return rc < 0 ? gonio_err_set(err, -rc, "ordering the points left: %s", strerror(-rc)) : 0;
}

int sequence_report(const sequence *q, struct sequence_report *r)
{
    if (!q->policy)
        return 0;
    *r = q->report;
    return 1;
}

int sequence_options(const struct capture_config *cfg, const struct plan *plan, int converge,
                     struct adaptive_options *opt, struct gonio_err *err)
{
    int in_order = plan_current_order(plan) == PLAN_ORDER_ADAPTIVE;
    const char *name[2] = {"--budget", "--stop-target"};
    const double v[2] = {cfg->budget_min, cfg->stop_target};
    for (int i = 0; i < 2; i++) {
        if (!isfinite(v[i]) || v[i] < 0)
            return gonio_err_set(err, GONIO_EUSAGE, "%s %g: %s", name[i], v[i],
                                 i ? "a full-domain log error, a positive number"
                                   : "a rig-time budget, a positive number of minutes");
        if (v[i] > 0 && !in_order)
            return gonio_err_set(err, GONIO_EUSAGE,
                                 "%s %g: only the adaptive order stops on it (--order adaptive; "
                                 "plan '%s' is in %s order)",
                                 name[i], v[i], plan_name(plan),
                                 plan_order_name(plan_current_order(plan)));
    }
    *opt = adaptive_default_options();
    opt->model = cfg->model;
    opt->budget_s = 60 * cfg->budget_min;
    opt->target = cfg->stop_target;
    opt->converge = converge;
    return 0;
}

int sequence_summary(sequence *q, const struct adaptive_options *opt,
                     struct capture_summary *out, struct gonio_err *err)
{
    if (!q->policy)
        return 0;
    if (q->has_prev) { /* the prediction with the last sample in */
        char stop[sizeof q->report.status.stop];
        memcpy(stop, q->report.status.stop, sizeof stop);
        decision_set(q, -1);
        decide(q, &q->d);
        long ignored;
        int rc = decision_take(q, &ignored, err);
        memcpy(q->report.status.stop, stop, sizeof stop);
        if (rc < 0)
            return rc;
    }
    const struct sequence_report *r = &q->report;
    out->adaptive = 1;
    out->budget_s = opt->budget_s;
    out->target = opt->target;
    out->converge = opt->converge;
    out->policy = r->status;
    out->decisions = r->decisions;
    out->decision_mean_s = r->decision_mean_s;
    out->decision_max_s = r->decision_max_s;
    out->decision_wait_s = r->wait_s;
    return 0;
}
