/* Pareto front by one sort and one sweep (pareto.h). */
#include "report/pareto.h"

#include <math.h>
#include <stdlib.h>

struct key {
    double x, y;
    size_t i;
};

static int by_x_then_y(const void *pa, const void *pb)
{
    const struct key *a = pa, *b = pb;
    if (a->x != b->x)
        return a->x < b->x ? -1 : 1;
    if (a->y != b->y)
        return a->y < b->y ? -1 : 1;
    return a->i < b->i ? -1 : a->i > b->i;
}

size_t report_pareto_front(const double *x, const double *y, size_t n, size_t *idx)
{
    struct key *k = malloc((n ? n : 1) * sizeof *k);
    if (!k)
        return 0;
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        if (isfinite(x[i]) && isfinite(y[i]))
            k[m++] = (struct key){x[i], y[i], i};
    qsort(k, m, sizeof *k, by_x_then_y);
    /* In ascending x, a point is on the front exactly when its y is below
     * every y seen before it: the earlier points cost no more, so an equal
     * or lower y among them dominates (or duplicates) it. */
    size_t n_front = 0;
    double best = INFINITY;
    for (size_t j = 0; j < m; j++)
        if (k[j].y < best) {
            best = k[j].y;
            idx[n_front++] = k[j].i;
        }
    free(k);
    return n_front;
}
