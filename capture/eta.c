#include "capture/eta.h"

#include <errno.h>
#include <stdlib.h>

#include <math.h>

#include "capture/autorange.h"
#include "capture/rate_map.h"
#include "planner/meter.h"

/* Metering a record and counting the points left each cost O(points): a
 * large plan meters every stride-th record and recounts then, counting
 * off each other record's own share in between, so that a capture does
 * about METER_RECORDS of each (oop200k: a minute of CPU on every record,
 * a second this way); a plan of fewer points meters every record. */
#define METER_RECORDS 2048
#define ETA_MIN_WEIGHT 1e-3

struct capture_eta {
    const struct plan *plan;
    const struct rig_profile *rig;
    size_t n;
    plan_meter *meter;
    double *move;          /* point i's move from its predecessor in the order */
    long *order;           /* the order the capture measures the points in */
    unsigned char *done;
    /* Where the axes were before the first record (home until
     * capture_eta_start says otherwise), or before the next one when
     * from_start (a resumed capture's axes, read again). */
    struct rig_axes start;
    int from_start;
    /* The record observed last (-1: none; the axes at start, rig time 0),
     * and the overheads summed over n_obs records. */
    long last;
    double last_rig_s;
    double overhead_sum;
    size_t n_obs;
    double estimate_s; /* capture_eta_left before any observation */
    size_t stride;     /* meter and recount every stride-th record */
    double left;       /* the points left, as last counted and counted off */
    /* A detector of counts (capture_eta_ranging): the ranging, the signal
     * rates measured (capture/rate_map.h) and the dark frames' time as
     * last seen. */
    const struct autorange *ar;
    rate_map *rates;
    double dark_seen_s;
};

static double count_left(const capture_eta *e);

capture_eta *capture_eta_new(const struct plan *plan, const struct rig_profile *rig,
                             const long *order, const double *expected_s,
                             struct gonio_err *err)
{
    size_t n = plan_count(plan);
    capture_eta *e = calloc(1, sizeof *e);
    if (e) {
        e->move = malloc((n ? n : 1) * sizeof *e->move);
        e->order = malloc((n ? n : 1) * sizeof *e->order);
        e->done = calloc(n ? n : 1, 1);
        e->rates = rate_map_new(plan, err);
        e->meter = plan_meter_new(plan, rig, expected_s, err);
    }
    if (!e || !e->move || !e->order || !e->done || !e->rates || !e->meter) {
        capture_eta_free(e);
        gonio_err_set(err, ENOMEM, "ETA: out of memory");
        return NULL;
    }
    e->plan = plan;
    e->rig = rig;
    e->n = n;
    e->last = -1;
    const struct rig_axes *at = &e->start;
    for (size_t k = 0; k < n; k++) {
        size_t i = order ? (size_t)order[k] : k;
        e->order[k] = (long)i;
        const struct rig_axes *to = &plan_point(plan, i)->ax;
        e->move[i] = rig_move_time_backlash(rig, at, to);
        at = to;
    }
    e->stride = n / METER_RECORDS + 1;
    e->left = e->estimate_s = count_left(e);
    return e;
}

void capture_eta_free(capture_eta *e)
{
    if (!e)
        return;
    plan_meter_free(e->meter);
    free(e->move);
    free(e->order);
    free(e->done);
    rate_map_free(e->rates);
    free(e);
}

void capture_eta_observe(capture_eta *e, const struct journal_sample *s)
{
    if (s->point < 0 || (size_t)s->point >= e->n)
        return;
    size_t i = (size_t)s->point;
    const struct rig_axes *from = e->last >= 0 && !e->from_start
                                      ? &plan_point(e->plan, (size_t)e->last)->ax
                                      : &e->start;
    e->from_start = 0;
    double move = rig_move_time_backlash(e->rig, from, &plan_point(e->plan, i)->ax);
    double share = e->done[i] ? 0
                              : e->move[i] + capture_eta_overhead(e) +
                                    plan_meter_integration(e->meter, i);
    /* The detector's time is every try's and the dark frames' since the
     * record before: the ranging model counts them, not the overhead. */
    double detector_s = s->integration_total_s > 0 ? s->integration_total_s : s->integration_s;
    double rate = NAN;
    if (e->ar) {
        detector_s += e->ar->dark_total_s - e->dark_seen_s;
        e->dark_seen_s = e->ar->dark_total_s;
        rate = autorange_rate(e->ar, s);
    }
    e->overhead_sum += s->rig_time_s - e->last_rig_s - move - detector_s;
    e->n_obs++;
    e->last = s->point;
    e->last_rig_s = s->rig_time_s;
    e->done[i] = 1;
    if (e->n_obs % e->stride == 0) {
        plan_meter_observe(e->meter, i, s->integration_s);
        /* a reading at or below its dark is as dark as one count over
         * its integration: what the reading resolves */
        if (!isnan(rate))
            rate_map_observe(e->rates, i, fmax(rate, 1 / s->integration_s));
        e->left = count_left(e);
    } else {
        e->left = e->left > share ? e->left - share : 0;
    }
}

void capture_eta_start(capture_eta *e, const struct rig_axes *at)
{
    e->start = *at;
    e->from_start = 1;
    for (size_t k = 0; k < e->n; k++) {
        size_t i = (size_t)e->order[k];
        if (!e->done[i]) {
            e->move[i] = rig_move_time_backlash(e->rig, at, &plan_point(e->plan, i)->ax);
            break;
        }
    }
    e->left = count_left(e);
    if (e->n_obs == 0)
        e->estimate_s = e->left;
}

void capture_eta_ranging(capture_eta *e, const struct autorange *ar, size_t prescan)
{
    e->ar = ar;
    rate_map_spread_over(e->rates, prescan);
    e->dark_seen_s = 0;
}

double capture_eta_estimate(const capture_eta *e)
{
    return e->estimate_s;
}

double capture_eta_overhead(const capture_eta *e)
{
    return e->n_obs ? e->overhead_sum / (double)e->n_obs : e->rig->settle_s;
}

double capture_eta_left(const capture_eta *e)
{
    return e->left;
}

/* Gauss-Hermite nodes and weights for a standard normal variable. */
static const double SPREAD_Z[] = {-2.856970013872806, -1.355626179974266, 0,
                                  1.355626179974266, 2.856970013872806};
static const double SPREAD_W[] = {0.011257411327721, 0.222075922005613, 0.533333333333333,
                                  0.222075922005613, 0.011257411327721};

/* The detector time of the points left on a detector of counts, in the
 * capture's order, on one rate model's rates: the ladder walked from the
 * rung the last point ended on, each point at its interpolated rate
 * (capture/rate_map.h). Where the walk changes rung is a threshold on the
 * rate (the floor, the clip), so the time of one walk on the rates as
 * interpolated jumps when a rate does: a glossy material whose peak sits
 * a few per cent under the clip costs a longer rung on every point left,
 * or none. The time counted is the mean over the interpolation's spread
 * instead, the rates scaled together by exp(spread z) for z normal
 * (Gauss-Hermite, five walks): the error of an interpolation is shared by
 * a region, not drawn per point. */
static double model_left(const capture_eta *e, int model)
{
    double spread = rate_map_spread(e->rates, model), sum = 0;
    for (size_t q = 0; q < sizeof SPREAD_Z / sizeof *SPREAD_Z; q++) {
        struct autorange_model m;
        autorange_model_start(e->ar, &m);
        double scale = exp(spread * SPREAD_Z[q]), walk = 0;
        for (size_t k = 0; k < e->n; k++) {
            size_t i = (size_t)e->order[k];
            if (!e->done[i])
                walk += autorange_model_point(e->ar, &m, scale * rate_map_at(e->rates, model, i));
        }
        sum += SPREAD_W[q] * walk;
        if (spread == 0)
            return walk;
    }
    return sum;
}

/* The rate models' detector times, each by its weight (rate_map.h); a
 * model weighing less than ETA_MIN_WEIGHT is not walked, which is most
 * of a capture once one has shown the better. */
static double detector_left(const capture_eta *e)
{
    double sum = 0, sw = 0;
    for (int j = 0; j < RATE_MAP_MODELS; j++) {
        double w = rate_map_weight(e->rates, j);
        if (w >= ETA_MIN_WEIGHT) {
            sum += w * model_left(e, j);
            sw += w;
        }
    }
    return sum / sw;
}

static double count_left(const capture_eta *e)
{
    struct autorange_model m;
    int ranged = e->ar && rate_map_count(e->rates) > 0 && autorange_model_start(e->ar, &m);
    double overhead = capture_eta_overhead(e), left = 0;
    for (size_t i = 0; i < e->n; i++)
        if (!e->done[i])
            left += e->move[i] + overhead + (ranged ? 0 : plan_meter_integration(e->meter, i));
    return ranged ? left + detector_left(e) : left;
}
