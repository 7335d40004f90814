/* The lower bound on the move time of any order of a plan
 * (plan_move_lower_bound, planner/planner.h): Held-Karp's 1-tree bound on
 * the tabulated move times, or the spanning-tree bound for plans too large
 * to tabulate. Paths are open and start at home (all axes at 0). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "planner/plan_private.h"

/* Up to this many points the lower bound tabulates the move times (8 n^2
 * bytes) for its Held-Karp iterations. */
#define MATRIX_MAX 2000

/* Prim's algorithm over home + points: any path from home through all
 * points is a spanning tree, so it costs at least the minimum one. */
static double mst_bound(const struct plan *plan, const struct rig_profile *rig)
{
    size_t n = plan->n;
    double *key = malloc((n ? n : 1) * sizeof *key);
    char *in = calloc(n ? n : 1, 1);
    if (!key || !in) {
        free(key);
        free(in);
        return NAN;
    }
    struct rig_axes home = {0, 0, 0};
    for (size_t i = 0; i < n; i++)
        key[i] = rig_move_time(rig, &home, &plan->pts[i].ax);
    double total = 0;
    for (size_t step = 0; step < n; step++) {
        size_t u = 0;
        double best = INFINITY;
        for (size_t i = 0; i < n; i++)
            if (!in[i] && key[i] < best) {
                best = key[i];
                u = i;
            }
        in[u] = 1;
        total += best;
        for (size_t i = 0; i < n; i++) {
            if (in[i])
                continue;
            double c = rig_move_time(rig, &plan->pts[u].ax, &plan->pts[i].ax);
            if (c < key[i])
                key[i] = c;
        }
    }
    free(key);
    free(in);
    return total;
}

struct hk {
    const double *c; /* m x m move times; node 0 is home */
    size_t m;
    double *pi, *key;
    size_t *parent;
    int *deg;
    char *in;
};

/* The Lagrangian 1-tree value for penalties pi. The open path from home is
 * a cycle through a dummy node D joined to home and to the path's last
 * point at cost 0; a 1-tree is a spanning tree of the other nodes plus two
 * edges at D: the one to home (every such cycle has it) and the cheapest
 * other one. Fills deg with the node degrees (D's edges included). */
static double one_tree(struct hk *h)
{
    size_t m = h->m;
    for (size_t i = 0; i < m; i++) {
        h->in[i] = 0;
        h->deg[i] = 0;
        h->key[i] = INFINITY;
    }
    h->key[0] = 0;
    double total = 0;
    for (size_t step = 0; step < m; step++) {
        size_t u = 0;
        double best = INFINITY;
        for (size_t i = 0; i < m; i++)
            if (!h->in[i] && h->key[i] < best) {
                best = h->key[i];
                u = i;
            }
        h->in[u] = 1;
        total += best;
        if (step) {
            h->deg[u]++;
            h->deg[h->parent[u]]++;
        }
        const double *row = h->c + u * m;
        for (size_t i = 0; i < m; i++) {
            if (h->in[i])
                continue;
            double c = row[i] + h->pi[u] + h->pi[i];
            if (c < h->key[i]) {
                h->key[i] = c;
                h->parent[i] = u;
            }
        }
    }
    size_t v = 1;
    for (size_t i = 2; i < m; i++)
        if (h->pi[i] < h->pi[v])
            v = i;
    total += h->pi[0] + h->pi[v];
    h->deg[0]++;
    h->deg[v]++;
    double sum_pi = 0;
    for (size_t i = 0; i < m; i++)
        sum_pi += h->pi[i];
    return total - 2 * sum_pi;
}

/* Held-Karp bound: the best 1-tree value over node penalties, found by
 * subgradient ascent (steps proportional to the gap to an upper bound, the
 * greedy path, halved when the bound stalls). Every 1-tree value is a lower
 * bound, so stopping early only loosens it; at zero penalties it is the
 * spanning-tree bound, so it is never weaker. */
static double held_karp_bound(const struct plan *plan, const struct rig_profile *rig)
{
    size_t n = plan->n, m = n + 1;
    struct hk h = {0};
    double *c = malloc(m * m * sizeof *c);
    h.pi = calloc(m, sizeof *h.pi);
    h.key = malloc(m * sizeof *h.key);
    h.parent = calloc(m, sizeof *h.parent);
    h.deg = malloc(m * sizeof *h.deg);
    h.in = malloc(m);
    double best = NAN;
    if (!c || !h.pi || !h.key || !h.parent || !h.deg || !h.in)
        goto out;
    struct rig_axes home = {0, 0, 0};
    for (size_t i = 0; i < m; i++)
        for (size_t j = 0; j < m; j++)
            c[i * m + j] = rig_move_time(rig, i ? &plan->pts[i - 1].ax : &home,
                                         j ? &plan->pts[j - 1].ax : &home);
    h.c = c;
    h.m = m;
    /* upper bound: the greedy path from home (h.in as visited flags) */
    double ub = 0;
    memset(h.in, 0, m);
    size_t at = 0;
    h.in[0] = 1;
    for (size_t k = 1; k < m; k++) {
        size_t nb = 0;
        double bc = INFINITY;
        for (size_t j = 1; j < m; j++)
            if (!h.in[j] && c[at * m + j] < bc) {
                bc = c[at * m + j];
                nb = j;
            }
        h.in[nb] = 1;
        ub += bc;
        at = nb;
    }
    best = -INFINITY;
    double lambda = 2.0;
    int stall = 0;
    for (int it = 0; it < 1000 && lambda > 1e-2; it++) {
        double l = one_tree(&h);
        if (l > best + 1e-9) {
            best = l;
            stall = 0;
        } else if (++stall >= 15) {
            lambda /= 2;
            stall = 0;
        }
        double norm = 0;
        for (size_t i = 0; i < m; i++)
            norm += (double)(h.deg[i] - 2) * (h.deg[i] - 2);
        if (norm == 0 || ub - l <= 1e-9)
            break; /* the 1-tree is a path: the bound is exact */
        double step = lambda * (ub - l) / norm;
        for (size_t i = 0; i < m; i++)
            h.pi[i] += step * (h.deg[i] - 2);
    }
out:
    free(c);
    free(h.pi);
    free(h.key);
    free(h.parent);
    free(h.deg);
    free(h.in);
    return best;
}

double plan_move_lower_bound(const struct plan *plan, const struct rig_profile *rig)
{
    if (plan->n > 20000)
        return NAN;
    if (plan->n < 2 || plan->n > MATRIX_MAX)
        return mst_bound(plan, rig);
    double hk = held_karp_bound(plan, rig);
    return isnan(hk) ? mst_bound(plan, rig) : hk;
}
