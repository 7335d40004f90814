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
    struct near *near;
    size_t count;
    long first[RATE_MAP_SPREAD_POINTS];
    size_t n_first, spread_points;
    double spread;
};

rate_map *rate_map_new(const struct plan *plan, struct gonio_err *err)
{
    size_t n = plan_count(plan), k = n ? n : 1;
    rate_map *m = calloc(1, sizeof *m);
    if (m) {
        m->hd = malloc(k * sizeof *m->hd);
        m->log_rate = malloc(k * sizeof *m->log_rate);
        m->near = calloc(k, sizeof *m->near);
    }
    if (!m || !m->hd || !m->log_rate || !m->near) {
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

/* The inverse-square-distance mean of the neighbours' log rates; a
 * neighbour at the same coordinates is the answer itself. */
static double near_mean(const rate_map *m, const struct near *nb)
{
    double sw = 0, sv = 0;
    for (int k = 0; k < nb->n; k++) {
        double v = m->log_rate[nb->at[k]];
        if (nb->d2[k] <= 0)
            return v;
        sw += 1 / nb->d2[k];
        sv += v / nb->d2[k];
    }
    return nb->n ? sv / sw : NAN;
}

/* Leave-one-out over the first points: each predicted from the others. */
static double loo_spread(const rate_map *m)
{
    if (m->n_first < 2)
        return 0;
    double ss = 0;
    for (size_t a = 0; a < m->n_first; a++) {
        struct near nb = {.n = 0};
        for (size_t b = 0; b < m->n_first; b++)
            if (b != a)
                near_add(&nb, m->first[b], dist2(m, (size_t)m->first[a], (size_t)m->first[b]));
        double e = near_mean(m, &nb) - m->log_rate[m->first[a]];
        ss += e * e;
    }
    return sqrt(ss / (double)m->n_first);
}

void rate_map_observe(rate_map *m, size_t point, double rate)
{
    if (point >= m->n || !isnan(m->log_rate[point]) || !(rate > 0) || !isfinite(rate))
        return;
    m->log_rate[point] = log(rate);
    m->count++;
    for (size_t i = 0; i < m->n; i++)
        near_add(&m->near[i], (long)point, dist2(m, i, point));
    if (m->n_first < m->spread_points) {
        m->first[m->n_first++] = (long)point;
        m->spread = loo_spread(m);
    }
}

double rate_map_at(const rate_map *m, size_t point)
{
    if (point >= m->n)
        return NAN;
    if (!isnan(m->log_rate[point]))
        return exp(m->log_rate[point]);
    return exp(near_mean(m, &m->near[point]));
}

double rate_map_spread(const rate_map *m)
{
    return m->spread;
}

size_t rate_map_count(const rate_map *m)
{
    return m->count;
}
