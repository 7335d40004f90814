/* Execution orders.
 *
 * The metric is the true move time (rig_move_time), not an angular
 * distance: with a trapezoidal profile a 1-degree move costs a third of a
 * second while a 10-degree one costs barely twice that, so short-hop
 * heuristics on degrees mislead. Paths are open and start at home (all axes
 * at 0), where the rig is after homing, or where a capture finds the axes
 * (plan_order_from). */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "planner/plan_private.h"

/* The local search (2-opt and Or-opt) looks at each point's NEIGHBOURS
 * nearest others, so a pass costs O(n NEIGHBOURS) rather than O(n^2) (the
 * full search took 1.5 s on DS1's 912 points, 28 s on 3909); up to
 * SEARCH_MAX points, a bounded number of passes to a local optimum. */
#define NEIGHBOURS 10
#define SEARCH_MAX 20000
#define SEARCH_PASSES 1000
/* Up to this many points the single O(n^2) steps run: the progressive
 * levels' farthest-point order. */
#define QUADRATIC_MAX 4000
#define IMPROVE_EPS 1e-9

struct tour {
    const struct plan_point *pts;
    const struct rig_profile *rig;
    struct rig_axes start;
    size_t n;
};

static double cost(const struct tour *t, size_t i, size_t j)
{
    return rig_move_time(t->rig, &t->pts[i].ax, &t->pts[j].ax);
}

static double cost_from_start(const struct tour *t, size_t j)
{
    return rig_move_time(t->rig, &t->start, &t->pts[j].ax);
}

/* Cost of the edge between sequence positions k and k+1 of seq[0..m), where
 * position -1 is the start; an edge past the end costs nothing (open path). */
static double edge(const struct tour *t, const size_t *seq, long m, long k)
{
    if (k + 1 >= m)
        return 0.0;
    if (k < 0)
        return cost_from_start(t, seq[0]);
    return cost(t, seq[k], seq[k + 1]);
}

static double link(const struct tour *t, const size_t *seq, long m, long x, long y)
{
    /* cost between seq[x] (or the start for x = -1) and seq[y]; y >= m: 0 */
    if (y >= m)
        return 0.0;
    if (x < 0)
        return cost_from_start(t, seq[y]);
    return cost(t, seq[x], seq[y]);
}

/* What the rig pays for the path: the moves with their approach legs
 * (rig_move_time_backlash), as the estimate counts them. The local search
 * works on the symmetric move time (a reversed run costs what it did);
 * the choice between its orders counts the legs, which on a dense grid
 * are most of a move against the approach direction. */
static double path_cost(const struct tour *t, const size_t *seq, size_t m)
{
    double c = 0;
    const struct rig_axes *at = &t->start;
    for (size_t k = 0; k < m; k++) {
        c += rig_move_time_backlash(t->rig, at, &t->pts[seq[k]].ax);
        at = &t->pts[seq[k]].ax;
    }
    return c;
}

/* Keep seq[0..m) as best when it costs the rig less. */
static void keep_cheaper(const struct tour *t, const size_t *seq, size_t m, size_t *best,
                         double *best_c)
{
    double c = path_cost(t, seq, m);
    if (c < *best_c) {
        *best_c = c;
        memcpy(best, seq, m * sizeof *best);
    }
}

static void reverse(size_t *seq, long i, long j)
{
    while (i < j) {
        size_t tmp = seq[i];
        seq[i++] = seq[j];
        seq[j--] = tmp;
    }
}

/* What the local search knows of the points it orders: each one's
 * nearest others in move time (k of them, nearest first, ties by index)
 * with those move times, and its position in the sequence, both by point
 * index (the lists through slot[]). */
struct near {
    size_t k;
    size_t *list; /* m rows of k */
    double *dist; /* the move time to each, m rows of k */
    long *slot;   /* point -> row of list */
    long *pos;    /* point -> sequence position */
};

static const size_t *neighbours(const struct near *nr, size_t p)
{
    return nr->list + nr->k * (size_t)nr->slot[p];
}

static const double *neighbour_times(const struct near *nr, size_t p)
{
    return nr->dist + nr->k * (size_t)nr->slot[p];
}

/* A point by its sample-axis position. */
struct by_s {
    double s;
    size_t point;
};

/* By sample-axis position, then by index: a total order, so the same
 * points always sort the same way. */
static int cmp_s(const void *x, const void *y)
{
    const struct by_s *a = x, *b = y;
    if (a->s != b->s)
        return a->s < b->s ? -1 : 1;
    return (a->point > b->point) - (a->point < b->point);
}

static void near_free(struct near *nr)
{
    free(nr->list);
    free(nr->dist);
    free(nr->slot);
    free(nr->pos);
}

/* The lists of seq[0..m) (m >= 2), by a scan outwards from each point in
 * order of the sample axis: a move takes at least the sample axis's time
 * for its distance, so the scan stops where that alone reaches the k-th
 * nearest so far. */
static int near_init(struct near *nr, const struct tour *t, const size_t *seq, size_t m)
{
    nr->k = m - 1 < NEIGHBOURS ? m - 1 : NEIGHBOURS;
    nr->list = malloc(m * nr->k * sizeof *nr->list);
    nr->dist = malloc(m * nr->k * sizeof *nr->dist);
    nr->slot = malloc(t->n * sizeof *nr->slot);
    nr->pos = malloc(t->n * sizeof *nr->pos);
    struct by_s *by_s = malloc(m * sizeof *by_s);
    if (!nr->list || !nr->dist || !nr->slot || !nr->pos || !by_s) {
        near_free(nr);
        free(by_s);
        return -ENOMEM;
    }
    for (size_t i = 0; i < m; i++)
        nr->slot[seq[i]] = (long)i;
    for (size_t i = 0; i < m; i++)
        by_s[i] = (struct by_s){t->pts[seq[i]].ax.s, seq[i]};
    qsort(by_s, m, sizeof *by_s, cmp_s);
    const struct rig_axis *sample = &t->rig->sample;
    for (long r = 0; r < (long)m; r++) {
        size_t p = by_s[r].point, row = nr->k * (size_t)nr->slot[p];
        size_t *list = nr->list + row, have = 0;
        double *dist = nr->dist + row;
        for (long dir = -1; dir <= 1; dir += 2) {
            for (long q = r + dir; q >= 0 && q < (long)m; q += dir) {
                size_t o = by_s[q].point;
                int full = have == nr->k;
                if (full && rig_axis_time(t->pts[o].ax.s - t->pts[p].ax.s, sample->speed,
                                          sample->accel) >= dist[have - 1])
                    break;
                double d = cost(t, p, o);
                if (full && (d > dist[have - 1] || (d == dist[have - 1] && o > list[have - 1])))
                    continue;
                size_t at = full ? have - 1 : have++;
                while (at > 0 && (dist[at - 1] > d || (dist[at - 1] == d && list[at - 1] > o))) {
                    dist[at] = dist[at - 1];
                    list[at] = list[at - 1];
                    at--;
                }
                dist[at] = d;
                list[at] = o;
            }
        }
    }
    free(by_s);
    return 0;
}

/* 2-opt on the open path: reverse seq[x+1..y] (x may be -1, the start), so
 * that seq[x] joins seq[y] and seq[x+1] joins seq[y+1]; the metric is
 * symmetric, so only these edges change. Returns whether it paid. */
static int try_two_opt(const struct tour *t, size_t *seq, long m, long *pos, long x, long y)
{
    if (x >= y)
        return 0;
    double gain = edge(t, seq, m, x) + edge(t, seq, m, y) - link(t, seq, m, x, y) -
                  link(t, seq, m, x + 1, y + 1);
    if (gain <= IMPROVE_EPS)
        return 0;
    reverse(seq, x + 1, y);
    for (long k = x + 1; k <= y; k++)
        pos[seq[k]] = k;
    return 1;
}

/* 2-opt moves that add an edge from a point to one of its neighbours: an
 * improving move adds at least one edge shorter than an edge it removes at
 * the same point (otherwise it could not gain), so scanning each point's
 * neighbours nearer than its own path edges finds the improving moves
 * whose new edges are among the neighbour lists. The start has no list:
 * its moves are tried against every position. */
static int two_opt(const struct tour *t, size_t *seq, long m, const struct near *nr)
{
    int improved = 0;
    for (long y = 0; y < m; y++)
        improved |= try_two_opt(t, seq, m, nr->pos, -1, y);
    for (long i = 0; i < m; i++) {
        size_t a = seq[i];
        double next = edge(t, seq, m, i), prev = edge(t, seq, m, i - 1);
        const size_t *list = neighbours(nr, a);
        const double *times = neighbour_times(nr, a);
        for (size_t r = 0; r < nr->k; r++) {
            size_t c = list[r];
            double d = times[r];
            if (d >= next && d >= prev)
                break;
            long j = nr->pos[c], lo = i < j ? i : j, hi = i < j ? j : i;
            /* a joins c in place of their successors' edges, or of their
             * predecessors' */
            if ((d < next && try_two_opt(t, seq, m, nr->pos, lo, hi)) ||
                (d < prev && try_two_opt(t, seq, m, nr->pos, lo - 1, hi - 1))) {
                improved = 1;
                i--; /* the point at i changed: look again from there */
                break;
            }
        }
    }
    return improved;
}

/* Or-opt: move the run seq[i..last] (1 to 3 points) between seq[k] and
 * seq[k+1], forwards or reversed, where one of its ends lands beside one of
 * that end's neighbours. */
static int or_opt(const struct tour *t, size_t *seq, long m, const struct near *nr)
{
    int improved = 0;
    for (long len = 1; len <= 3; len++) {
        for (long i = 0; i + len <= m; i++) {
            long last = i + len - 1;
            double gain = link(t, seq, m, i - 1, i) + link(t, seq, m, last, last + 1) -
                          link(t, seq, m, i - 1, last + 1);
            if (gain <= IMPROVE_EPS)
                continue;
            long best_k = -2;
            int best_rev = 0;
            double best = gain - IMPROVE_EPS;
            for (int end = 0; end < 2; end++) {
                size_t e = seq[end ? last : i];
                const size_t *list = neighbours(nr, e);
                const double *times = neighbour_times(nr, e);
                for (size_t r = 0; r < nr->k && times[r] < gain; r++) {
                    /* the neighbour before the run, or after it */
                    for (long k = nr->pos[list[r]] - 1; k <= nr->pos[list[r]]; k++) {
                        if (k >= i - 1 && k <= last)
                            continue;
                        for (int rev = 0; rev < 2; rev++) {
                            long a = rev ? last : i, b = rev ? i : last;
                            double added = link(t, seq, m, k, a) - edge(t, seq, m, k);
                            if (k + 1 < m)
                                added += cost(t, seq[b], seq[k + 1]);
                            if (added < best) {
                                best = added;
                                best_k = k;
                                best_rev = rev;
                            }
                        }
                    }
                }
            }
            if (best_k == -2)
                continue;
            size_t run[3];
            memcpy(run, seq + i, (size_t)len * sizeof *seq);
            if (best_rev)
                reverse(run, 0, len - 1);
            long from, to;
            if (best_k > last) { /* shift the points between left */
                memmove(seq + i, seq + last + 1, (size_t)(best_k - last) * sizeof *seq);
                memcpy(seq + best_k - len + 1, run, (size_t)len * sizeof *seq);
                from = i, to = best_k;
            } else { /* best_k < i - 1: shift right */
                memmove(seq + best_k + 1 + len, seq + best_k + 1,
                        (size_t)(i - best_k - 1) * sizeof *seq);
                memcpy(seq + best_k + 1, run, (size_t)len * sizeof *seq);
                from = best_k + 1, to = last;
            }
            for (long k = from; k <= to; k++)
                nr->pos[seq[k]] = k;
            improved = 1;
        }
    }
    return improved;
}

/* 2-opt and Or-opt over the neighbour lists to a local optimum (or
 * SEARCH_PASSES passes). */
static void local_search(const struct tour *t, size_t *seq, size_t m, const struct near *nr)
{
    for (size_t i = 0; i < m; i++)
        nr->pos[seq[i]] = (long)i;
    for (int pass = 0; pass < SEARCH_PASSES; pass++) {
        int a = two_opt(t, seq, (long)m, nr);
        int b = or_opt(t, seq, (long)m, nr);
        if (!a && !b)
            break;
    }
}

/* A point's place in the sweep, worked out once per point rather than in
 * every comparison (the comparisons were most of a 1.5-million-point
 * plan's load). pos, its place in the order given, breaks ties, so the
 * sweep is the same whatever sort the C library has. */
struct sweep_key {
    long row, band;          /* bands of the sample axis and of the azimuth */
    int down_band, down_arm; /* this row's bands, this band's arm, descending */
    double a;
    size_t point, pos;
};

/* The raster: rows, then azimuth bands, then the arm, all upwards. */
static int cmp_raster(const void *x, const void *y)
{
    const struct sweep_key *a = x, *b = y;
    if (a->row != b->row)
        return a->row < b->row ? -1 : 1;
    if (a->band != b->band)
        return a->band < b->band ? -1 : 1;
    if (a->a != b->a)
        return a->a < b->a ? -1 : 1;
    return a->pos < b->pos ? -1 : a->pos > b->pos;
}

/* The boustrophedon: the raster with the flips sweep_keys set. */
static int cmp_sweep(const void *x, const void *y)
{
    const struct sweep_key *a = x, *b = y;
    if (a->row != b->row)
        return a->row < b->row ? -1 : 1;
    if (a->band != b->band)
        return (a->band < b->band) != a->down_band ? -1 : 1;
    if (a->a != b->a)
        return (a->a < b->a) != a->down_arm ? -1 : 1;
    return a->pos < b->pos ? -1 : a->pos > b->pos;
}

static long band_of(double v, double band)
{
    return (long)floor(v / band + 1e-9);
}

/* Rows are bands of the sample axis, taken upwards; within a row, bands of
 * the azimuth; within those, the arm. A raster takes every band and the
 * arm upwards, the way the drives approach their targets, and pays one
 * long move back per band; a boustrophedon alternates the azimuth bands
 * row by row and the arm band by band, so consecutive points are
 * neighbours, and pays the approach legs of every move down (on a grid of
 * 0.05-degree steps, 2312 s of moves against 3624 s; on rows of 5-degree
 * steps the other way round). key[0..m) gets seq's points in raster order
 * with the boustrophedon's flips, which go by the rank of a row or band
 * among the occupied ones: the parity of a band's own number does not
 * alternate (rows 0.81 degrees apart fall in bands 1 apart or 2, and in
 * 1e-6 bands any even number apart). */
static void sweep_keys(const struct plan_point *pts, const size_t *seq, size_t m, double band,
                       struct sweep_key *key)
{
    for (size_t k = 0; k < m; k++) {
        const struct rig_axes *ax = &pts[seq[k]].ax;
        key[k] = (struct sweep_key){.row = band_of(ax->s, band), .band = band_of(ax->az, band),
                                    .a = ax->a, .point = seq[k], .pos = k};
    }
    qsort(key, m, sizeof *key, cmp_raster);
    long row_rank = -1, band_rank = -1;
    for (size_t k = 0; k < m; k++) {
        if (k == 0 || key[k].row != key[k - 1].row) {
            row_rank++;
            band_rank = -1;
        }
        if (band_rank < 0 || key[k].band != key[k - 1].band)
            band_rank++;
        key[k].down_band = (int)(row_rank & 1);
        key[k].down_arm = (int)((row_rank + band_rank) & 1);
    }
}

/* Grids have rows of exactly equal s (the first width); domain plans have
 * scattered values, where wider bands pay off. */
static const double sweep_widths[] = {1e-6, 0.5, 1, 2, 5, 10};
#define N_SWEEP_WIDTHS (sizeof sweep_widths / sizeof sweep_widths[0])

/* The sweep of the first n_widths band widths, raster or boustrophedon,
 * that costs the rig least. */
static int sweep_best(const struct tour *t, size_t *out, size_t m, const size_t *in,
                      size_t n_widths)
{
    struct sweep_key *key = malloc((m ? m : 1) * sizeof *key);
    if (!key)
        return -ENOMEM;
    double best = INFINITY;
    size_t *try = out + m; /* out has room for 2m */
    for (size_t w = 0; w < n_widths; w++) {
        sweep_keys(t->pts, in, m, sweep_widths[w], key);
        for (int boustrophedon = 0; boustrophedon < 2; boustrophedon++) {
            if (boustrophedon)
                qsort(key, m, sizeof *key, cmp_sweep);
            for (size_t k = 0; k < m; k++)
                try[k] = key[k].point;
            keep_cheaper(t, try, m, out, &best);
        }
    }
    free(key);
    return 0;
}

/* Nearest neighbour in move time from the start (ties keep the earlier
 * written point) from the neighbour lists: the first unvisited point of the
 * list is the nearest unvisited one, and only when the whole list is
 * visited are all the rest scanned. */
static void greedy_near(const struct tour *t, size_t *seq, size_t m, const struct near *nr)
{
    for (size_t i = 0; i < m; i++)
        nr->pos[seq[i]] = (long)i;
    for (size_t k = 0; k < m; k++) { /* seq[k..m) is unvisited */
        long best = -1;
        if (k) {
            const size_t *list = neighbours(nr, seq[k - 1]);
            for (size_t r = 0; r < nr->k && best < 0; r++)
                if (nr->pos[list[r]] >= (long)k)
                    best = nr->pos[list[r]];
        }
        if (best < 0) {
            double bc = INFINITY;
            for (size_t j = k; j < m; j++) {
                double c = k ? cost(t, seq[k - 1], seq[j]) : cost_from_start(t, seq[j]);
                if (c < bc || (c == bc && seq[j] < seq[best])) {
                    bc = c;
                    best = (long)j;
                }
            }
        }
        size_t tmp = seq[k];
        seq[k] = seq[best];
        seq[best] = tmp;
        nr->pos[seq[k]] = (long)k;
        nr->pos[seq[best]] = best;
    }
}

/* Nearest neighbour in move time from the start; for dense domain plans
 * (beyond SEARCH_MAX points) the sweep stands in. */
static int greedy(const struct tour *t, size_t *seq, size_t m)
{
    if (m > SEARCH_MAX) {
        size_t *buf = malloc(2 * m * sizeof *buf);
        if (!buf)
            return -ENOMEM;
        int rc = sweep_best(t, buf, m, seq, 1);
        if (rc == 0)
            memcpy(seq, buf, m * sizeof *seq);
        free(buf);
        return rc;
    }
    if (m < 2)
        return 0;
    struct near nr;
    if (near_init(&nr, t, seq, m) < 0)
        return -ENOMEM;
    greedy_near(t, seq, m, &nr);
    near_free(&nr);
    return 0;
}

/* The cheapest for the rig (path_cost) of three starts (written order,
 * sweep, greedy), each as built and after local search: never dearer than
 * the written or the greedy order. Beyond SEARCH_MAX points (dense domain
 * plans) the cheaper of the written order and the sweep. */
static int travel(const struct tour *t, size_t *seq, size_t m)
{
    if (m < 2)
        return 0;
    /* best | work | orig | scratch (2m for the sweep search) */
    size_t *buf = malloc(5 * m * sizeof *buf);
    if (!buf)
        return -ENOMEM;
    size_t *best = buf, *work = buf + m, *orig = buf + 2 * m, *scratch = buf + 3 * m;
    double best_c = INFINITY;
    struct near nr = {0};
    int search = m <= SEARCH_MAX;
    if (search && near_init(&nr, t, seq, m) < 0) {
        free(buf);
        return -ENOMEM;
    }
    memcpy(orig, seq, m * sizeof *seq);
    for (int start = 0; start < 3; start++) {
        if (start == 2 && !search)
            continue;
        memcpy(work, orig, m * sizeof *work);
        if (start == 1) {
            if (sweep_best(t, scratch, m, work, N_SWEEP_WIDTHS) < 0) {
                near_free(&nr);
                free(buf);
                return -ENOMEM;
            }
            memcpy(work, scratch, m * sizeof *work);
        } else if (start == 2) {
            greedy_near(t, work, m, &nr);
        }
        keep_cheaper(t, work, m, best, &best_c);
        if (search && m >= 3) {
            local_search(t, work, m, &nr);
            keep_cheaper(t, work, m, best, &best_c);
        }
    }
    memcpy(seq, best, m * sizeof *seq);
    near_free(&nr);
    free(buf);
    return 0;
}

/* Without a ladder in the file, progressive levels come from a
 * farthest-point order in axis space: level 0 is the first 6 points (a
 * six-pair plan), each further level four times larger, so every level
 * boundary is a well-spread prefix. */
static int farthest_levels(const struct plan_point *pts, size_t n, int *level)
{
    double *dist = malloc(n * sizeof *dist);
    if (!dist)
        return -ENOMEM;
    for (size_t i = 0; i < n; i++) {
        dist[i] = INFINITY;
        level[i] = -1;
    }
    size_t size = 6, lev = 0, taken = 0, cur = 0;
    while (taken < n) {
        size_t far = 0;
        double fd = -1;
        for (size_t i = 0; i < n; i++) {
            if (level[i] >= 0)
                continue;
            if (taken) {
                double ds = pts[i].ax.s - pts[cur].ax.s, da = pts[i].ax.a - pts[cur].ax.a,
                       dz = pts[i].ax.az - pts[cur].ax.az;
                double d = sqrt(ds * ds + da * da + dz * dz);
                if (d < dist[i])
                    dist[i] = d;
            }
            if (dist[i] > fd) {
                fd = dist[i];
                far = i;
            }
        }
        if (taken == size) {
            lev++;
            size *= 4;
        }
        level[far] = (int)lev;
        cur = far;
        taken++;
    }
    free(dist);
    return 0;
}

/* The finest level of a ladder holds most of the points (DS1's is 752 of
 * 912); travel order would sweep it row by row from one end, so a capture
 * stopped inside it would have the full density at some theta_i and none
 * at others. Split it into sub-levels of whole sample-axis rows taken
 * coarse to fine: the two extreme rows, the middle one, then the quarter
 * rows and so on (a van der Corput sequence over the row ranks), each
 * sub-level doubling the rows so far. Every sub-level prefix then has the
 * plan's own density along theta_r at evenly spread theta_i, which is what
 * the fit of the whole plan sees. Writes sub-level numbers from `base` on
 * into level[]. */
static int split_rows(const struct plan_point *pts, const size_t *idx, size_t m, int base,
                      int *level)
{
    struct by_s *sorted = malloc((m ? m : 1) * sizeof *sorted);
    size_t *row_of = malloc((m ? m : 1) * sizeof *row_of);
    if (!sorted || !row_of) {
        free(sorted);
        free(row_of);
        return -ENOMEM;
    }
    for (size_t k = 0; k < m; k++)
        sorted[k] = (struct by_s){pts[idx[k]].ax.s, idx[k]};
    qsort(sorted, m, sizeof *sorted, cmp_s);
    size_t rows = 0;
    for (size_t k = 0; k < m; k++) {
        if (k && sorted[k].s - sorted[k - 1].s > 1e-6)
            rows++;
        row_of[k] = rows;
    }
    rows++;
    /* rank -> sub-level: extremes 0 and rows-1 first, then dyadic midpoints */
    int *sub = malloc(rows * sizeof *sub);
    if (!sub) {
        free(sorted);
        free(row_of);
        return -ENOMEM;
    }
    for (size_t r = 0; r < rows; r++)
        sub[r] = -1;
    size_t placed = 0, group_end = 1;
    int group = 0;
    for (unsigned den = 2; placed < rows && den < (1u << 30); den *= 2) {
        for (unsigned num = 1; num < den && placed < rows; num += 2) {
            size_t r = (size_t)floor((double)num / den * (double)(rows - 1) + 0.5);
            if (sub[r] >= 0 || r == 0 || r == rows - 1)
                continue;
            sub[r] = group;
            if (++placed == group_end) {
                group++;
                group_end = 2 * group_end + 1; /* 1, 3, 7, 15 rows: halved steps */
            }
        }
        if ((size_t)den > 2 * rows) /* every interior rank offered */
            break;
    }
    group++; /* the extreme rows last: the most atypical (grazing, normal) */
    for (size_t r = 0; r < rows; r++)
        if (sub[r] < 0)
            sub[r] = group;
    for (size_t k = 0; k < m; k++)
        level[sorted[k].point] = base + sub[row_of[k]];
    free(sub);
    free(sorted);
    free(row_of);
    return 0;
}

static int progressive(const struct tour *t, size_t *seq, size_t n)
{
    int *level = malloc((n ? n : 1) * sizeof *level);
    if (!level)
        return -ENOMEM;
    int max_level = 0;
    for (size_t i = 0; i < n; i++) {
        level[i] = t->pts[i].level;
        if (level[i] > max_level)
            max_level = level[i];
    }
    if (max_level == 0 && n > 6 && n <= QUADRATIC_MAX && farthest_levels(t->pts, n, level) < 0) {
        free(level);
        return -ENOMEM;
    } else if (max_level > 0 && n <= QUADRATIC_MAX) {
        size_t m = 0;
        for (size_t i = 0; i < n; i++)
            if (level[i] == max_level)
                seq[m++] = i;
        if (split_rows(t->pts, seq, m, max_level, level) < 0) {
            free(level);
            return -ENOMEM;
        }
    }
    max_level = 0;
    for (size_t i = 0; i < n; i++)
        if (level[i] > max_level)
            max_level = level[i];
    struct tour sub = *t;
    size_t k = 0;
    for (int l = 0; l <= max_level; l++) {
        size_t begin = k;
        for (size_t i = 0; i < n; i++)
            if (level[i] == l)
                seq[k++] = i;
        /* each level continues from where the previous one ended */
        int rc = travel(&sub, seq + begin, k - begin);
        if (rc < 0) {
            free(level);
            return rc;
        }
        if (k > begin)
            sub.start = t->pts[seq[k - 1]].ax;
    }
    free(level);
    return 0;
}

int plan_order_indices(const struct plan_point *pts, size_t n, enum plan_order_mode mode,
                       const struct rig_profile *rig, const struct rig_axes *start,
                       size_t *order)
{
    struct tour t = {pts, rig, *start, n};
    for (size_t i = 0; i < n; i++)
        order[i] = i;
    if (mode == PLAN_ORDER_AS_WRITTEN || mode == PLAN_ORDER_ADAPTIVE)
        return 0;
    int rc = -EINVAL;
    switch (mode) {
    case PLAN_ORDER_AS_WRITTEN:
    case PLAN_ORDER_ADAPTIVE: rc = 0; break;
    case PLAN_ORDER_GREEDY: rc = greedy(&t, order, n); break;
    case PLAN_ORDER_TRAVEL: rc = travel(&t, order, n); break;
    case PLAN_ORDER_PROGRESSIVE: rc = progressive(&t, order, n); break;
    }
    return rc;
}

int plan_order_subset(const struct plan *plan, enum plan_order_mode mode,
                      const struct rig_profile *rig, const struct rig_axes *start, long *ids,
                      size_t m)
{
    if (m < 2 || mode == PLAN_ORDER_AS_WRITTEN || mode == PLAN_ORDER_ADAPTIVE)
        return 0;
    struct plan_point *pts = malloc(m * sizeof *pts);
    size_t *order = malloc(m * sizeof *order);
    long *was = malloc(m * sizeof *was);
    int rc = pts && order && was ? 0 : -ENOMEM;
    for (size_t k = 0; rc == 0 && k < m; k++) {
        pts[k] = *plan_point(plan, (size_t)ids[k]);
        was[k] = ids[k];
    }
    if (rc == 0)
        rc = plan_order_indices(pts, m, mode, rig, start, order);
    for (size_t k = 0; rc == 0 && k < m; k++)
        ids[k] = was[order[k]];
    free(pts);
    free(order);
    free(was);
    return rc;
}
