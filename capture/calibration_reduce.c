/* A capture's counts reduced with its calibration as they are measured
 * (capture/calibration.h): each record keeps its raw counts and gains the
 * BRDF and its standard uncertainty. */
#include "capture/calibration.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "common/paths.h"
#include "journal/journal.h"

#define NEIGHBOUR_DEG 12.5 /* the angle term's slopes look no further */

/* The raw reading of a journal record at its plan point's angles. */
static const struct plan_point *point_of(const struct journal_plan *jp, int k)
{
    return jp->plan ? plan_point(jp->plan, (size_t)k) : &jp->points[k];
}

static void to_raw(const struct journal_sample *s, const struct journal_plan *plan,
                   const struct cal_loaded *cl, struct rad_raw *r)
{
    const struct plan_point *pt = point_of(plan, s->point);
    memset(r, 0, sizeof *r);
    r->theta_i = pt->theta_i;
    r->theta_r = cal_instrument_theta_r(pt);
    memcpy(r->counts, s->raw, sizeof r->counts);
    r->integration_s = s->integration_s;
    r->gain_state = s->gain_state == JOURNAL_GAIN_NONE ? 0 : s->gain_state;
    r->monitor = s->monitor;
    r->full_scale = cl->full_scale;
    r->nonlinearity = cl->nonlinearity;
    /* The drift at the record's rig time, linear from none at the capture's
     * start to the reference read again at its end; its uncertainty the
     * ratio's, scaled alike, and the drift's departure from the line, taken
     * as a random walk's bridge through the two ends (the one step seen
     * giving its rate): variance (q - 1)^2 w (1 - w). */
    const struct cal_drift *d = &cl->drift;
    double w = !d->on ? 0 : d->t_end_s > 0 ? fmin(fmax(s->rig_time_s / d->t_end_s, 0), 1) : 1;
    for (int c = 0; d->on && c < 3; c++) {
        double step = d->q[c] - 1.0;
        r->drift_rel[c] = w * step;
        r->drift_u[c] = sqrt(w * w * d->u_q[c] * d->u_q[c] + step * step * w * (1.0 - w));
    }
}

double cal_instrument_theta_r(const struct plan_point *pt)
{
    return pt->out_of_plane ? pt->theta_o : pt->theta_r;
}

int cal_reduce_sample(const struct cal_loaded *cl, const struct journal_plan *plan,
                      const struct journal_sample *done, size_t n_done,
                      struct journal_sample *s, struct rad_value *v, struct gonio_err *err)
{
    /* A detector that gave BRDF has nothing to reduce; a dark frame is
     * kept as the counts it is, the dark its neighbours were taken with. */
    if (!s->counts || (s->flags & JOURNAL_FLAG_DARK))
        return 0;
    /* The sample and its neighbours on its lines (same theta_i or same
     * theta_r, within the slope's reach), the sample first. */
    struct rad_raw *raw = malloc((n_done + 1) * sizeof *raw);
    struct rad_value *val = malloc((n_done + 1) * sizeof *val);
    if (!raw || !val) {
        free(raw);
        free(val);
        return gonio_err_set(err, ENOMEM, "calibration: out of memory");
    }
    size_t n = 0;
    to_raw(s, plan, cl, &raw[n++]);
    /* An out-of-plane sample has no neighbours on its lines: the records
     * of its theta_i and theta_o lie at other azimuths, and their slope is
     * not the one its axes' band moves it along. Its angle term is the
     * standard's slopes alone. */
    if (point_of(plan, s->point)->out_of_plane)
        n_done = 0;
    for (size_t k = 0; k < n_done; k++) {
        const struct journal_sample *d = &done[k];
        if (!d->counts || (d->flags & JOURNAL_FLAG_DARK) || d->point < 0 ||
            (size_t)d->point >= plan->count || point_of(plan, d->point)->out_of_plane)
            continue;
        struct rad_raw r;
        to_raw(d, plan, cl, &r);
        int same_i = fabs(r.theta_i - raw[0].theta_i) < 0.01;
        int same_r = fabs(r.theta_r - raw[0].theta_r) < 0.01;
        if ((same_i && fabs(r.theta_r - raw[0].theta_r) <= NEIGHBOUR_DEG) ||
            (same_r && fabs(r.theta_i - raw[0].theta_i) <= NEIGHBOUR_DEG))
            raw[n++] = r;
    }
    int rc = rad_reduce(&cl->cal, raw, n, val, err);
    if (rc >= 0) {
        *v = val[0];
        memcpy(s->rgb, v->brdf, sizeof s->rgb);
        memcpy(s->u, v->u, sizeof s->u);
        /* A reading clipped in one channel has no value in any (the journal
         * takes a counts record's r, g, b all reduced or none): its counts
         * stay, flagged saturated, and the fit takes none of it. */
        if (!isfinite(s->rgb[0]) || !isfinite(s->rgb[1]) || !isfinite(s->rgb[2]))
            for (int c = 0; c < 3; c++)
                s->rgb[c] = s->u[c] = NAN;
    }
    free(raw);
    free(val);
    return rc;
}

int cal_results_budget(const struct cal_loaded *cl, const struct journal_plan *plan,
                       const struct journal_sample *samples, size_t n, const char *dir,
                       struct gonio_err *err)
{
    struct rad_raw *raw = malloc((n ? n : 1) * sizeof *raw);
    struct rad_value *v = malloc((n ? n : 1) * sizeof *v);
    size_t m = 0;
    int rc = raw && v ? 0 : gonio_err_set(err, ENOMEM, "calibration: out of memory");
    for (size_t k = 0; rc == 0 && k < n; k++)
        if (samples[k].counts && !(samples[k].flags & JOURNAL_FLAG_DARK))
            to_raw(&samples[k], plan, cl, &raw[m++]);
    if (rc == 0)
        rc = rad_reduce(&cl->cal, raw, m, v, err);
    char path[4200];
    snprintf(path, sizeof path, "%s/results.json", dir);
    json_error_t je;
    json_t *res = rc == 0 ? json_load_file(path, 0, &je) : NULL;
    json_t *budget = res ? cal_budget_json(cl, v, m) : NULL;
    if (rc == 0 && (!res || !budget))
        rc = gonio_err_set(err, GONIO_EBADDATA, "%s: cannot add the calibration's budget",
                           path);
    if (rc == 0) {
        json_object_set_new(res, "calibration", budget);
        budget = NULL;
        char *text = json_dumps(res, JSON_INDENT(2) | JSON_REAL_PRECISION(12));
        rc = text ? gonio_write_file_atomic(path, text, strlen(text), err)
                  : gonio_err_set(err, ENOMEM, "%s: out of memory", path);
        free(text);
    }
    json_decref(budget);
    json_decref(res);
    free(raw);
    free(v);
    return rc;
}

int cal_reduce_reading(const struct cal_loaded *cl, const struct plan_point *pt,
                       struct journal_sample *s, struct gonio_err *err)
{
    struct journal_plan one = {.points = pt, .count = 1};
    int point = s->point;
    struct rad_value v;
    s->point = 0;
    int rc = cal_reduce_sample(cl, &one, NULL, 0, s, &v, err);
    s->point = point;
    return rc;
}
