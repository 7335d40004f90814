#include "capture/live_fit.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/metrics.h"
#include "capture/job.h"
#include "fit/journal_samples.h"

#define PROGRESS_FIRST 16 /* samples before the first progress round */

/* The in-sample errors of the latest round over the samples so far, for
 * the host. */
static void report_fit(const struct capture_hooks *hooks, struct live_fit *st,
                       const struct journal_sample *js, size_t n)
{
    const struct brdf_abc *p = fit_stream_params(st->fs);
    struct brdf_pair *pairs = malloc(n * sizeof *pairs);
    double *meas = malloc(n * 3 * sizeof *meas), *pred = malloc(n * 3 * sizeof *pred);
    if (p && pairs && meas && pred) {
        for (size_t i = 0; i < n; i++) {
            journal_sample_pair(&js[i], &pairs[i]);
            memcpy(meas + 3 * i, js[i].rgb, sizeof js[i].rgb);
            brdf_abc_eval(p, &pairs[i], pred + 3 * i);
        }
        struct brdf_errors e;
        brdf_errors_compute(pairs, meas, pred, n, &e);
        st->log_error = e.log;
        if (hooks->on_fit)
            hooks->on_fit(hooks->user, &e, n);
    }
    free(pairs);
    free(meas);
    free(pred);
}

int live_fit_feed(struct live_fit *st, const struct plan *plan,
                  const struct capture_hooks *hooks, const struct journal_sample *js,
                  size_t n, struct gonio_err *err)
{
    if (!st->fs)
        return 0;
    const struct journal_sample *last = &js[n - 1];
    if (!journal_sample_has_brdf(last))
        return 0; /* counts not reduced: nothing a fit can take */
    struct fit_sample s;
    fit_journal_samples(last, 1, &s);
    int force;
    if (st->progress) {
        force = n >= PROGRESS_FIRST && (n & (n - 1)) == 0;
    } else {
        const struct plan_point *pt = plan_point(plan, (size_t)last->point),
                                *next = plan_point(plan, (size_t)last->point + 1);
        force = plan_current_order(plan) == PLAN_ORDER_PROGRESSIVE &&
                (!next || next->level != pt->level);
    }
    struct fit_stream_status before, after;
    fit_stream_status(st->fs, &before);
    if (force)
        capture_phase_enter(hooks, CAPTURE_PHASE_FIT, (int)n);
    int rc = fit_stream_add(st->fs, &s, force, err);
    if (force)
        capture_phase_enter(hooks, CAPTURE_PHASE_BETWEEN, (int)n);
    fit_stream_status(st->fs, &after);
    if (rc >= 0 && after.rounds > before.rounds && (hooks->on_fit || hooks->on_progress))
        report_fit(hooks, st, js, n);
    return rc;
}

int live_fit_new(const struct capture_config *cfg, const struct plan *plan,
                 struct live_fit *st, struct gonio_err *err)
{
    memset(st, 0, sizeof *st);
    st->log_error = NAN;
    if (plan_current_order(plan) == PLAN_ORDER_ADAPTIVE)
        return 0; /* the policy stops the capture and predicts its error */
    struct plan_stop stop = *plan_stop(plan);
    stop.kind = capture_stop_kind(cfg, plan);
    struct fit_stream_options so = fit_stream_default_options();
    if (stop.kind == PLAN_STOP_CONVERGE) {
        so.tol = stop.tol;
        so.rounds = stop.rounds;
        so.every = stop.every;
        so.min_points = stop.min_points;
    } else if (cfg->progress_fit && !cfg->measure_only) {
        st->progress = 1;
        so.converge = 0;
        so.every = 0; /* only the rounds stream_feed forces */
    } else {
        return 0;
    }
    return fit_stream_new(&so, &st->fs, err);
}
