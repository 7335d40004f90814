/* Global start for the ABC fit: the model is linear in kd and A once B, C
 * and eta are fixed, so a coarse grid over (B, C, eta) with kd and A solved
 * exactly at each node covers the non-linear part without guessing. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fit/abc_problem.h"
#include "fit/abc_vmath.h"

#define ABC_PI 3.14159265358979323846

/* Grid: B log-spaced 1 .. 1e7 (half decades), C 0.1 .. 3, eta 1.05 .. 20.
 * Wide enough for the published MERL fits (B 11 .. 8e6, C 0.08 .. 2). */
static const double grid_c[] = {0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.4, 2.0, 3.0};
static const double grid_eta[] = {1.05, 1.2, 1.5, 2.0, 3.0, 6.0, 20.0};
#define N_B 15
#define N_C (int)(sizeof grid_c / sizeof grid_c[0])
#define N_ETA (int)(sizeof grid_eta / sizeof grid_eta[0])

/* Floors for a start: an exact zero from the non-negative solve would sit
 * on the log clamp, where the parameter barely moves. */
#define START_FLOOR 1e-6

struct node {
    int ib, ic, ie;
    int scored; /* 1: score is the true log loss; 0: the linearised one */
    double score;
    double kd[3], A[3];
};

/* The ranking is sorted, not the nodes (80 bytes each): a node's score,
 * whether it is the true loss, its position before this sort (ties keep
 * their order, as a stable sort) and its index. */
struct rank {
    double score;
    int scored, at, node;
};

/* Nodes scored by the true loss first, each group by score. */
static int cmp_rank(const void *a, const void *b)
{
    const struct rank *x = a, *y = b;
    if (x->scored != y->scored)
        return y->scored - x->scored;
    if (x->score != y->score)
        return x->score < y->score ? -1 : 1;
    return (x->at > y->at) - (x->at < y->at);
}

/* The k best of rk[n] (cmp_rank) sorted into rk[0..k), the rest after them
 * in any order: an insertion into the short sorted prefix (sorting all 945
 * ranks was a twentieth of a DS1 fit, and the starts rarely look past the
 * first k). */
static void best_first(struct rank *rk, int n, int k)
{
    if (k <= 0)
        return;
    qsort(rk, (size_t)k, sizeof *rk, cmp_rank);
    for (int i = k; i < n; i++) {
        if (cmp_rank(&rk[i], &rk[k - 1]) >= 0)
            continue;
        struct rank t = rk[i];
        rk[i] = rk[k - 1];
        int j = k - 1;
        while (j > 0 && cmp_rank(&t, &rk[j - 1]) < 0) {
            rk[j] = rk[j - 1];
            j--;
        }
        rk[j] = t;
    }
}

/* One node's residual ratios for the true log loss, channel-major in w[3n]:
 * (1 + fhat cos) / (1 + f cos), to be logged. Vectorised (an AVX2 clone,
 * gathers of the lobe). */
ABC_VCLONES
static void true_rows(size_t n, const double *restrict fr, const double *restrict lobe,
                      const unsigned *restrict xi, const double *restrict cosi,
                      const double *restrict iy, const double kdp[3], const double A[3],
                      double *restrict w)
{
    double k0 = kdp[0], k1 = kdp[1], k2 = kdp[2], a0 = A[0], a1 = A[1], a2 = A[2];
    for (size_t k = 0; k < n; k++) {
        double sk = fr[k] * lobe[(int)xi[k]], ci = cosi[k];
        w[k] = (1.0 + (k0 + a0 * sk) * ci) * iy[k];
        w[n + k] = (1.0 + (k1 + a1 * sk) * ci) * iy[n + k];
        w[2 * n + k] = (1.0 + (k2 + a2 * sk) * ci) * iy[2 * n + k];
    }
}

/* Nodes whose true log loss is computed (at least 8 per start). */
#define GRID_TRUE_SCORED 48

/* Weighted non-negative least squares for f ~ a/pi + b s in one channel,
 * from the accumulated normal equations. */
static void nnls2(double s11, double s12, double s22, double t1, double t2, double *a,
                  double *b)
{
    double det = s11 * s22 - s12 * s12;
    if (det > 1e-14 * s11 * s22) {
        *a = (s22 * t1 - s12 * t2) / det;
        *b = (s11 * t2 - s12 * t1) / det;
        if (*a >= 0 && *b >= 0)
            return;
    }
    /* One of the two is at its bound 0: try both and keep the better. */
    double a1 = s11 > 0 ? fmax(0.0, t1 / s11) : 0.0;
    double b2 = s22 > 0 ? fmax(0.0, t2 / s22) : 0.0;
    double e1 = -2 * a1 * t1 + a1 * a1 * s11; /* weighted SSE minus sum w f^2 */
    double e2 = -2 * b2 * t2 + b2 * b2 * s22;
    if (e1 <= e2) {
        *a = a1;
        *b = 0;
    } else {
        *a = 0;
        *b = b2;
    }
}

double abc_linear_score(const struct abc_problem *pb, double B, double C, double eta,
                        double kd[3], double A[3], double *spec)
{
    size_t n = pb->n;
    double s11[3] = {0}, s12[3] = {0}, s22[3] = {0}, t1[3] = {0}, t2[3] = {0};
    for (size_t k = 0; k < n; k++) {
        double s = brdf_abc_fresnel(eta, pb->vh[k], NULL) * pb->gterm[k] *
                   exp(-C * log1p(B * pb->x[k]));
        spec[k] = s;
        double ci = pb->cosi[k];
        for (int c = 0; c < 3; c++) {
            double d = ci / (1.0 + fmax(pb->f[3 * k + c], 0.0) * ci);
            double sw = abc_row_weight(pb, k, c), wk = d * d * (sw * sw), fk = pb->f[3 * k + c];
            s11[c] += wk / (ABC_PI * ABC_PI);
            s12[c] += wk * s / ABC_PI;
            s22[c] += wk * s * s;
            t1[c] += wk * fk / ABC_PI;
            t2[c] += wk * s * fk;
        }
    }
    for (int c = 0; c < 3; c++)
        nnls2(s11[c], s12[c], s22[c], t1[c], t2[c], &kd[c], &A[c]);
    double score = 0;
    for (size_t k = 0; k < n; k++) {
        double ci = pb->cosi[k];
        for (int c = 0; c < 3; c++) {
            double r = log1p((kd[c] / ABC_PI + A[c] * spec[k]) * ci) - pb->y[3 * k + c];
            double sw = abc_row_weight(pb, k, c);
            score += r * r * (sw * sw);
        }
    }
    return isfinite(score) ? score : INFINITY;
}

/* The nine node sums of every eta at one (B, C): per eta and channel,
 * sum_i agg[ie][c][i] D_i, sum_i agg[ie][3 + c][i] D_i^2 and
 * sum_i agg[ie][6 + c][i] D_i, over the distinct x. Contiguous dot
 * products: vectorised, with an AVX2 clone (945 nodes x 9 sums x 397 terms
 * per DS1 grid). */
ABC_VCLONES
static void node_sums(const double *agg, const double *d, size_t nu, double out[N_ETA][9])
{
    for (int ie = 0; ie < N_ETA; ie++) {
        const double *a = agg + (size_t)ie * 9 * nu;
        /* nine scalar sums: kept in registers, not in arrays */
        double a0 = 0, a1 = 0, a2 = 0, b0 = 0, b1 = 0, b2 = 0, c0 = 0, c1 = 0, c2 = 0;
        for (size_t i = 0; i < nu; i++) {
            double di = d[i], d2 = di * di;
            a0 += a[i] * di;
            a1 += a[nu + i] * di;
            a2 += a[2 * nu + i] * di;
            b0 += a[3 * nu + i] * d2;
            b1 += a[4 * nu + i] * d2;
            b2 += a[5 * nu + i] * d2;
            c0 += a[6 * nu + i] * di;
            c1 += a[7 * nu + i] * di;
            c2 += a[8 * nu + i] * di;
        }
        double *o = out[ie];
        o[0] = a0, o[1] = a1, o[2] = a2, o[3] = b0, o[4] = b1, o[5] = b2;
        o[6] = c0, o[7] = c1, o[8] = c2;
    }
}

/* node_sums for two lobes at once (two values of C at one B): each pass
 * over agg, which is larger than the L1 cache, serves both. */
ABC_VCLONES
static void node_sums2(const double *agg, const double *d, const double *e, size_t nu,
                       double out[N_ETA][9], double out2[N_ETA][9])
{
    for (int ie = 0; ie < N_ETA; ie++) {
        const double *a = agg + (size_t)ie * 9 * nu;
        double a0 = 0, a1 = 0, a2 = 0, b0 = 0, b1 = 0, b2 = 0, c0 = 0, c1 = 0, c2 = 0;
        double p0 = 0, p1 = 0, p2 = 0, q0 = 0, q1 = 0, q2 = 0, r0 = 0, r1 = 0, r2 = 0;
        for (size_t i = 0; i < nu; i++) {
            double di = d[i], d2 = di * di, ei = e[i], e2 = ei * ei;
            double x0 = a[i], x1 = a[nu + i], x2 = a[2 * nu + i];
            double y0 = a[3 * nu + i], y1 = a[4 * nu + i], y2 = a[5 * nu + i];
            double z0 = a[6 * nu + i], z1 = a[7 * nu + i], z2 = a[8 * nu + i];
            a0 += x0 * di, a1 += x1 * di, a2 += x2 * di;
            b0 += y0 * d2, b1 += y1 * d2, b2 += y2 * d2;
            c0 += z0 * di, c1 += z1 * di, c2 += z2 * di;
            p0 += x0 * ei, p1 += x1 * ei, p2 += x2 * ei;
            q0 += y0 * e2, q1 += y1 * e2, q2 += y2 * e2;
            r0 += z0 * ei, r1 += z1 * ei, r2 += z2 * ei;
        }
        double *o = out[ie], *o2 = out2[ie];
        o[0] = a0, o[1] = a1, o[2] = a2, o[3] = b0, o[4] = b1, o[5] = b2;
        o[6] = c0, o[7] = c1, o[8] = c2;
        o2[0] = p0, o2[1] = p1, o2[2] = p2, o2[3] = q0, o2[4] = q1, o2[5] = q2;
        o2[6] = r0, o2[7] = r1, o2[8] = r2;
    }
}

/* The grid search's arrays: per eta F G per sample, per B log1p(B x) per
 * distinct x, the lobe scratch, the node weights aggregated per eta and
 * distinct x (agg), the linearised loss's weights (w, later scratch), F per
 * distinct v.h, and the nodes. */
struct grid {
    struct node *nodes;
    double *fres, *lg, *lobe, *agg, *w, *fu;
    /* node-independent sums of the normal equations, and sum w f^2 */
    double s11[3], t1[3], wff[3];
};

static void grid_free(struct grid *g)
{
    free(g->nodes);
    free(g->fres);
    free(g->lg);
    free(g->lobe);
    free(g->agg);
    free(g->w);
    free(g->fu);
}

/* Allocate the grid and aggregate what the nodes share. Returns 0, -1 on
 * no memory. */
static int grid_init(struct grid *g, const struct abc_problem *pb)
{
    size_t n = pb->n, nu = pb->nux;
    memset(g, 0, sizeof *g);
    g->nodes = malloc((size_t)N_B * N_C * N_ETA * sizeof *g->nodes);
    g->fres = malloc((size_t)N_ETA * n * sizeof *g->fres); /* F * gterm per eta */
    g->lg = malloc((size_t)N_B * nu * sizeof *g->lg);      /* log1p(B x) per B, distinct x */
    g->lobe = malloc(2 * nu * sizeof *g->lobe);            /* two lobes (node_sums2) */
    g->agg = malloc((size_t)N_ETA * nu * 9 * sizeof *g->agg);
    g->w = malloc(n * sizeof *g->w * 3);
    g->fu = malloc((pb->nuv ? pb->nuv : 1) * sizeof *g->fu);
    if (!g->nodes || !g->fres || !g->lg || !g->lobe || !g->agg || !g->w || !g->fu) {
        grid_free(g);
        return -1;
    }
    double *fres = g->fres, *w = g->w, *agg = g->agg;
    for (int ie = 0; ie < N_ETA; ie++) {
        double *fr = fres + (size_t)ie * n;
        for (size_t i = 0; i < pb->nuv; i++) /* F per distinct v.h */
            g->fu[i] = brdf_abc_fresnel(grid_eta[ie], pb->uvh[i], NULL);
        for (size_t k = 0; k < n; k++)
            fr[k] = g->fu[pb->vi[k]] * pb->gterm[k];
    }
    /* Weights of the linearised log loss: d log(1 + f cos) / df = cos / (1 + f cos),
     * squared because the linear solve minimises squared differences in f; times
     * the sample's weight. */
    for (size_t k = 0; k < 3 * n; k++) {
        double ci = pb->cosi[k / 3];
        double d = ci / (1.0 + fmax(pb->f[k], 0.0) * ci) * abc_row_weight(pb, k / 3, (int)(k % 3));
        w[k] = d * d;
    }
    for (size_t k = 0; k < n; k++)
        for (int c = 0; c < 3; c++) {
            double wk = w[3 * k + c], fk = pb->f[3 * k + c];
            g->s11[c] += wk / (ABC_PI * ABC_PI);
            g->t1[c] += wk * fk / ABC_PI;
            g->wff[c] += wk * fk * fk;
        }
    /* The node sums are sums over samples of (weight x F G) times D(x) or
     * D(x)^2, and D depends on the sample only through x: so the weights
     * are summed once per eta and distinct x (agg[ie][j][i], j < 9: per
     * channel w s, w s^2, w f s with s = F G, over distinct x i), and each
     * node's sums are then dot products with D over the distinct x (397 for
     * DS1's 912 samples), contiguous in i so that they vectorise. */
    for (size_t i = 0; i < (size_t)N_ETA * nu * 9; i++)
        agg[i] = 0;
    for (int ie = 0; ie < N_ETA; ie++)
        for (size_t k = 0; k < n; k++) {
            double sk = fres[(size_t)ie * n + k];
            double *ag = agg + (size_t)ie * 9 * nu + pb->xi[k];
            for (int c = 0; c < 3; c++) {
                double ws = w[3 * k + c] * sk;
                ag[(size_t)c * nu] += ws;
                ag[(size_t)(3 + c) * nu] += ws * sk;
                ag[(size_t)(6 + c) * nu] += ws * pb->f[3 * k + c];
            }
        }
    return 0;
}

/* Every node's kd and A by the linear solve, and its linearised weighted
 * SSE as its score (closed form from the node sums). */
static void grid_score_linear(struct grid *g, const struct abc_problem *pb)
{
    size_t nu = pb->nux;
    double *lobe = g->lobe;
    int m = 0;
    for (int ib = 0; ib < N_B; ib++) {
        double B = pow(10.0, 0.5 * ib);
        double *lgb = g->lg + (size_t)ib * nu;
        abc_vlog1p_mul(B, pb->ux, nu, lgb);
        double sums[2][N_ETA][9];
        for (int ic = 0; ic < N_C; ic++) {
            /* the lobe D(x) once per (B, C), shared by the eta nodes; two
             * values of C per pass over the aggregated weights */
            if (ic % 2 == 0) {
                memcpy(lobe, lgb, nu * sizeof *lobe);
                abc_vexp_neg(grid_c[ic], lobe, nu);
                if (ic + 1 < N_C) {
                    memcpy(lobe + nu, lgb, nu * sizeof *lobe);
                    abc_vexp_neg(grid_c[ic + 1], lobe + nu, nu);
                    node_sums2(g->agg, lobe, lobe + nu, nu, sums[0], sums[1]);
                } else {
                    node_sums(g->agg, lobe, nu, sums[0]);
                }
            }
            double (*sm)[9] = sums[ic % 2];
            for (int ie = 0; ie < N_ETA; ie++) {
                double s12[3] = {sm[ie][0], sm[ie][1], sm[ie][2]};
                double s22[3] = {sm[ie][3], sm[ie][4], sm[ie][5]};
                double t2[3] = {sm[ie][6], sm[ie][7], sm[ie][8]};
                struct node *nd = &g->nodes[m++];
                nd->ib = ib;
                nd->ic = ic;
                nd->ie = ie;
                double lin = 0;
                for (int c = 0; c < 3; c++) {
                    double a, bb;
                    s12[c] /= ABC_PI;
                    nnls2(g->s11[c], s12[c], s22[c], g->t1[c], t2[c], &a, &bb);
                    nd->kd[c] = a;
                    nd->A[c] = bb;
                    lin += g->wff[c] - 2 * (a * g->t1[c] + bb * t2[c]) + a * a * g->s11[c] +
                           2 * a * bb * s12[c] + bb * bb * s22[c];
                }
                nd->score = isfinite(lin) ? lin : INFINITY;
                nd->scored = 0;
            }
        }
    }
}

/* The true log loss of the nodes rk[0..ntrue) (the linearised loss's best:
 * it ranks them alike; a log per residual decides among them), into their
 * nodes and ranks. */
static void grid_score_true(struct grid *g, const struct abc_problem *pb, struct rank *rk,
                            int ntrue)
{
    size_t n = pb->n, nu = pb->nux;
    double *w = g->w, *lobe = g->lobe;
    for (int i = 0; i < ntrue; i++) {
        struct node *nd = &g->nodes[rk[i].node];
        if (!isfinite(nd->score))
            break;
        double C = grid_c[nd->ic];
        const double *fr = g->fres + (size_t)nd->ie * n, *lgb = g->lg + (size_t)nd->ib * nu;
        memcpy(lobe, lgb, nu * sizeof *lobe);
        abc_vexp_neg(C, lobe, nu);
        double kdp[3] = {nd->kd[0] / ABC_PI, nd->kd[1] / ABC_PI, nd->kd[2] / ABC_PI};
        /* log(1 + fhat cos) - log(1 + f cos) as one log; w is free by now */
        true_rows(n, fr, lobe, pb->xi, pb->cosi, pb->iy, kdp, nd->A, w);
        abc_vlog(w, 3 * n);
        if (pb->sw || pb->mw) /* w channel-major: w[c n + k] */
            for (size_t k = 0; k < 3 * n; k++)
                w[k] *= abc_row_weight(pb, k % n, (int)(k / n));
        double score = 0;
        for (size_t k = 0; k < 3 * n; k++)
            score += w[k] * w[k];
        nd->score = isfinite(score) ? score : INFINITY;
        nd->scored = 1;
        rk[i].score = nd->score;
        rk[i].scored = 1;
    }
}

/* Best nodes first (rk, its first ntrue sorted), skipping grid neighbours
 * of a node already taken, so the starts probe different basins rather
 * than one basin several times. Returns the starts written. */
static int grid_pick(const struct node *nodes, struct rank *rk, int nnodes, int ntrue,
                     int *taken, int max_starts, double *starts)
{
    int got = 0;
    for (int i = 0; i < nnodes && got < max_starts; i++) {
        if (i == ntrue) /* the starts need nodes beyond the scored ones */
            qsort(rk + ntrue, (size_t)(nnodes - ntrue), sizeof *rk, cmp_rank);
        const struct node *nd = &nodes[rk[i].node];
        if (!isfinite(nd->score))
            continue;
        int near = 0;
        for (int j = 0; j < got && !near; j++) {
            const struct node *o = &nodes[rk[taken[j]].node];
            near = abs(o->ib - nd->ib) <= 1 && abs(o->ic - nd->ic) <= 1 &&
                   abs(o->ie - nd->ie) <= 1;
        }
        if (near)
            continue;
        taken[got] = i;
        struct brdf_abc p;
        for (int c = 0; c < 3; c++) {
            p.kd[c] = fmax(nd->kd[c], START_FLOOR);
            p.A[c] = fmax(nd->A[c], START_FLOOR);
        }
        p.B = pow(10.0, 0.5 * nd->ib);
        p.C = grid_c[nd->ic];
        p.eta = grid_eta[nd->ie];
        abc_params_to_theta(&p, starts + (size_t)got * ABC_NPAR);
        got++;
    }
    return got;
}

int abc_grid_starts(const struct abc_problem *pb, int max_starts, double *starts)
{
    int nnodes = N_B * N_C * N_ETA;
    struct grid g;
    if (grid_init(&g, pb) < 0)
        return -1;
    grid_score_linear(&g, pb);
    /* The true log loss costs a log per residual: score only the nodes the
     * linearised loss ranks best. Nodes not scored keep their linearised
     * rank after these. */
    struct rank *rk = malloc((size_t)nnodes * sizeof *rk);
    int *taken = malloc((size_t)(max_starts > 0 ? max_starts : 1) * sizeof *taken);
    int got = 0;
    if (rk && taken) {
        for (int i = 0; i < nnodes; i++)
            rk[i] = (struct rank){g.nodes[i].score, 0, i, i};
        int ntrue = GRID_TRUE_SCORED > 8 * max_starts ? GRID_TRUE_SCORED : 8 * max_starts;
        if (ntrue > nnodes)
            ntrue = nnodes;
        best_first(rk, nnodes, ntrue);
        grid_score_true(&g, pb, rk, ntrue);
        /* Re-rank: the scored nodes all lie in the first ntrue, and the rest
         * keep their order behind them, so only that prefix moves. */
        for (int i = 0; i < ntrue; i++)
            rk[i].at = i;
        qsort(rk, (size_t)ntrue, sizeof *rk, cmp_rank);
        got = grid_pick(g.nodes, rk, nnodes, ntrue, taken, max_starts, starts);
    }
    free(rk);
    free(taken);
    grid_free(&g);
    return got;
}
