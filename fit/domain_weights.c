/* Sample weights by domain share (fit/domain_weights.h). */
#include "fit/domain_weights.h"

#include <math.h>
#include <pthread.h>
#include <stdlib.h>

#include "brdf/domain.h"

#define N_HD BRDF_DOMAIN_N_HD

/* The cells' node counts depend on nothing: worked out once per process
 * (1.5 million directions). */
static unsigned short cell_nodes[N_HD * N_HD];
static pthread_once_t cell_nodes_once = PTHREAD_ONCE_INIT;

static void cell_nodes_init(void)
{
    brdf_domain_hd_counts(cell_nodes);
}

/* A sample's place (brdf_domain_hd_place): node (i, j) sits at
 * (i / 90, j / 90). */
struct point {
    double u, v;
    size_t k; /* the sample's position in the caller's list */
};

static int cmp_point(const void *a, const void *b)
{
    const struct point *x = a, *y = b;
    if (x->u != y->u)
        return x->u < y->u ? -1 : 1;
    if (x->v != y->v)
        return x->v < y->v ? -1 : 1;
    return (x->k > y->k) - (x->k < y->k);
}

/* The first of pts[0..n) (sorted by u) nearest (u, v): a scan outwards in
 * u from where u would sort, stopped on each side once the gap in u alone
 * rules out a nearer point (and, going down, a tie: ties go to the first
 * in sorted order). */
static size_t nearest(const struct point *pts, size_t n, double u, double v)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (pts[mid].u < u)
            lo = mid + 1;
        else
            hi = mid;
    }
    size_t best = lo < n ? lo : n - 1;
    double best_d2 = INFINITY;
    for (size_t m = lo; m < n; m++) {
        double du = pts[m].u - u, dv = pts[m].v - v;
        if (du * du >= best_d2)
            break;
        double d2 = du * du + dv * dv;
        if (d2 < best_d2) {
            best_d2 = d2;
            best = m;
        }
    }
    for (size_t m = lo; m-- > 0;) {
        double du = u - pts[m].u, dv = pts[m].v - v;
        if (du * du > best_d2)
            break;
        double d2 = du * du + dv * dv;
        if (d2 <= best_d2) { /* ties to the first in sorted order */
            best_d2 = d2;
            best = m;
        }
    }
    return best;
}

int fit_domain_weights(const struct fit_sample *s, const size_t *idx, size_t n, double *w)
{
    if (!n)
        return 0;
    struct point *pts = malloc(n * sizeof *pts);
    double *share = calloc(n, sizeof *share);
    if (!pts || !share) {
        free(pts);
        free(share);
        return -1;
    }
    pthread_once(&cell_nodes_once, cell_nodes_init);
    for (size_t k = 0; k < n; k++) {
        pts[k].k = k;
        brdf_domain_hd_place(&s[idx ? idx[k] : k].g, &pts[k].u, &pts[k].v);
    }
    qsort(pts, n, sizeof *pts, cmp_point);
    /* Samples denser than the cells would leave most of them nearest to
     * none: then each cell's nodes are spread over sub x sub points round
     * it, enough for four per sample (a few hundred samples: sub = 1, the
     * cells themselves). */
    int sub = 1;
    while ((double)N_HD * N_HD * sub * sub < 4.0 * (double)n)
        sub++;
    double total = 0;
    for (int i = 0; i < N_HD; i++)
        for (int j = 0; j < N_HD; j++) {
            unsigned short c = cell_nodes[i * N_HD + j];
            if (!c)
                continue;
            for (int a = 0; a < sub; a++)
                for (int b = 0; b < sub; b++) {
                    double u = (i + (a + 0.5) / sub - 0.5) / N_HD;
                    double v = (j + (b + 0.5) / sub - 0.5) / N_HD;
                    share[nearest(pts, n, u, v)] += c / (double)(sub * sub);
                }
            total += c;
        }
    /* samples at one point split what is nearest to it */
    for (size_t a = 0, b; a < n; a = b) {
        double sum = 0;
        for (b = a; b < n && pts[b].u == pts[a].u && pts[b].v == pts[a].v; b++)
            sum += share[b];
        for (size_t m = a; m < b; m++)
            w[pts[m].k] = sum / (double)(b - a) * (double)n / total;
    }
    free(pts);
    free(share);
    return 0;
}
