/* The rate map (rate_map.h): log rates interpolated in half and
 * difference angles from the nearest measured points. */
#include "capture/rate_map.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

#include "brdf/angles.h"

#define K RATE_MAP_NEIGHBOURS

/* A point's nearest measured points, nearest first. */
struct near {
    long at[K];
    double d2[K]; /* squared distance in (theta_h, weighted theta_d), degrees */
    int n;
};

struct rate_map {
    size_t n;
    double (*hd)[2];   /* theta_h, RATE_MAP_D_WEIGHT x theta_d, degrees */
    double *log_rate;  /* NAN where not measured */
    double *log_cos;   /* log cos theta_i: the foreshortening */
    struct near *near;
    size_t count;
    long first[RATE_MAP_SPREAD_POINTS];
    size_t n_first, spread_points;
    double spread[RATE_MAP_MODELS];
    double sq_err[RATE_MAP_MODELS]; /* each point after the first ones, predicted before */
    size_t n_scored;
};

rate_map *rate_map_new(const struct plan *plan, struct gonio_err *err)
{
    size_t n = plan_count(plan), k = n ? n : 1;
    rate_map *m = calloc(1, sizeof *m);
    if (m) {
        m->hd = malloc(k * sizeof *m->hd);
        m->log_rate = malloc(k * sizeof *m->log_rate);
        m->log_cos = malloc(k * sizeof *m->log_cos);
        m->near = calloc(k, sizeof *m->near);
    }
    if (!m || !m->hd || !m->log_rate || !m->log_cos || !m->near) {
        rate_map_free(m);
        gonio_err_set(err, ENOMEM, "rate map: out of memory");
        return NULL;
    }
    m->n = n;
    m->spread_points = RATE_MAP_SPREAD_POINTS;
    for (size_t i = 0; i < n; i++) {
        const struct plan_point *pt = plan_point(plan, i);
        struct brdf_pair p;
        if (pt->out_of_plane)
            brdf_pair_spherical(pt->theta_i, pt->phi_i, pt->theta_o, pt->phi_o, &p);
        else
            brdf_pair_inplane(pt->theta_i, pt->theta_r, &p);
        m->hd[i][0] = p.theta_h / BRDF_DEG;
        m->hd[i][1] = RATE_MAP_D_WEIGHT * p.theta_d / BRDF_DEG;
        m->log_rate[i] = NAN;
        m->log_cos[i] = log(fmax(cos(pt->theta_i * BRDF_DEG), 1e-3));
    }
    return m;
}

void rate_map_spread_over(rate_map *m, size_t points)
{
    m->spread_points = points >= 2 && points < RATE_MAP_SPREAD_POINTS ? points
                                                                      : RATE_MAP_SPREAD_POINTS;
}

void rate_map_free(rate_map *m)
{
    if (!m)
        return;
    free(m->hd);
    free(m->log_rate);
    free(m->log_cos);
    free(m->near);
    free(m);
}

static double dist2(const rate_map *m, size_t a, size_t b)
{
    double dh = m->hd[a][0] - m->hd[b][0], dd = m->hd[a][1] - m->hd[b][1];
    return dh * dh + dd * dd;
}

/* Keep j among nb's nearest if it is one of them. */
static void near_add(struct near *nb, long j, double d2)
{
    int k = nb->n < K ? nb->n++ : K;
    if (k == K && d2 >= nb->d2[K - 1])
        return;
    if (k == K)
        k = K - 1;
    while (k > 0 && nb->d2[k - 1] > d2) {
        nb->at[k] = nb->at[k - 1];
        nb->d2[k] = nb->d2[k - 1];
        k--;
    }
    nb->at[k] = j;
    nb->d2[k] = d2;
}

/* What a model interpolates at point i, less the log rate: nothing, or
 * the foreshortening taken off (rate_map.h). */
static double model_off(const rate_map *m, int model, size_t i)
{
    return model == RATE_MAP_FORESHORTENED ? m->log_cos[i] : 0;
}

/* Model `model`'s log rate at `at`: the inverse-square-distance mean of
 * what it interpolates at the neighbours nb; a neighbour at the same
 * coordinates is the answer itself. */
static double near_mean(const rate_map *m, int model, size_t at, const struct near *nb)
{
    double sw = 0, sv = 0;
    for (int k = 0; k < nb->n; k++) {
        size_t b = (size_t)nb->at[k];
        double v = m->log_rate[b] - model_off(m, model, b);
        if (nb->d2[k] <= 0)
            return v + model_off(m, model, at);
        sw += 1 / nb->d2[k];
        sv += v / nb->d2[k];
    }
    return nb->n ? sv / sw + model_off(m, model, at) : NAN;
}

/* Leave-one-out over the first points: each predicted from the others. */
static double loo_spread(const rate_map *m, int model)
{
    if (m->n_first < 2)
        return 0;
    double ss = 0;
    for (size_t a = 0; a < m->n_first; a++) {
        size_t at = (size_t)m->first[a];
        struct near nb = {.n = 0};
        for (size_t b = 0; b < m->n_first; b++)
            if (b != a)
                near_add(&nb, m->first[b], dist2(m, at, (size_t)m->first[b]));
        double e = near_mean(m, model, at, &nb) - m->log_rate[at];
        ss += e * e;
    }
    return sqrt(ss / (double)m->n_first);
}

void rate_map_observe(rate_map *m, size_t point, double rate)
{
    if (point >= m->n || !isnan(m->log_rate[point]) || !(rate > 0) || !isfinite(rate))
        return;
    double lr = log(rate);
    if (m->n_first >= m->spread_points) { /* scored as the points left are predicted */
        for (int j = 0; j < RATE_MAP_MODELS; j++) {
            double e = near_mean(m, j, point, &m->near[point]) - lr;
            m->sq_err[j] += e * e;
        }
        m->n_scored++;
    }
    m->log_rate[point] = lr;
    m->count++;
    for (size_t i = 0; i < m->n; i++)
        near_add(&m->near[i], (long)point, dist2(m, i, point));
    if (m->n_first < m->spread_points) {
        m->first[m->n_first++] = (long)point;
        for (int j = 0; j < RATE_MAP_MODELS; j++)
            m->spread[j] = loo_spread(m, j);
    }
}

double rate_map_at(const rate_map *m, int model, size_t point)
{
    if (point >= m->n)
        return NAN;
    if (!isnan(m->log_rate[point]))
        return exp(m->log_rate[point]);
    return exp(near_mean(m, model, point, &m->near[point]));
}

double rate_map_spread(const rate_map *m, int model)
{
    return m->spread[model];
}

/* A model's log score: the first points' leave-one-out errors and every
 * later point's, each the log density of a normal error of the model's
 * spread (its rms over the first points). */
static double log_score(const rate_map *m, int model)
{
    double s = fmax(m->spread[model], RATE_MAP_MIN_SPREAD);
    double n = (double)(m->n_first + m->n_scored);
    double sq = (double)m->n_first * m->spread[model] * m->spread[model] + m->sq_err[model];
    return -n * log(s) - 0.5 * sq / (s * s);
}

double rate_map_weight(const rate_map *m, int model)
{
    double best = -INFINITY, sum = 0;
    for (int j = 0; j < RATE_MAP_MODELS; j++)
        best = fmax(best, log_score(m, j));
    for (int j = 0; j < RATE_MAP_MODELS; j++)
        sum += exp(log_score(m, j) - best);
    return exp(log_score(m, model) - best) / sum;
}

size_t rate_map_count(const rate_map *m)
{
    return m->count;
}
