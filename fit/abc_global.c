/* Differential evolution for the ABC start (the in-plane study's global
 * search was a genetic algorithm; DE is its continuous-parameter form).
 *
 * Only (log10 B, log C, logit of eta) are searched: kd and A enter the model
 * linearly and are solved exactly for every candidate (abc_linear_score), as
 * at the grid's nodes. DE/rand/1/bin with a seeded GSL stream: the same
 * samples and seed give the same starts. The final population, best first,
 * gives the starts, skipping candidates close to one already taken. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_rng.h>

#include "fit/abc_problem.h"

#define DE_DIM 3
#define DE_POP 24
#define DE_GENS 50
#define DE_F 0.7   /* differential weight */
#define DE_CR 0.9  /* crossover probability */
/* Two candidates closer than this (in units of each range) are one basin. */
#define DE_DISTINCT 0.08
#define START_FLOOR 1e-6

/* Search box: B 1 .. 10^7.5, C 0.08 .. 3.3, eta 1.02 .. 30 (as logit of
 * (eta - 1) / (ABC_ETA_MAX - 1)): the published MERL fits and a margin. */
static const double lo[DE_DIM] = {0.0, -2.53, 0};
static const double hi[DE_DIM] = {7.5, 1.19, 0};

static double eta_at(double u)
{
    return 1.0 + (ABC_ETA_MAX - 1.0) / (1.0 + exp(-u));
}

static double logit_eta(double eta)
{
    double s = (eta - 1.0) / (ABC_ETA_MAX - 1.0);
    return log(s / (1.0 - s));
}

struct cand {
    double x[DE_DIM];
    double score;
    double kd[3], A[3];
};

static void score(const struct abc_problem *pb, struct cand *c, double *spec)
{
    c->score = abc_linear_score(pb, pow(10.0, c->x[0]), exp(c->x[1]), eta_at(c->x[2]), c->kd,
                                c->A, spec);
}

static int cmp_cand(const void *a, const void *b)
{
    double sa = ((const struct cand *)a)->score, sb = ((const struct cand *)b)->score;
    return (sa > sb) - (sa < sb);
}

int abc_de_starts(const struct abc_problem *pb, unsigned seed, int max_starts, double *starts)
{
    double l[DE_DIM] = {lo[0], lo[1], logit_eta(1.02)};
    double h[DE_DIM] = {hi[0], hi[1], logit_eta(30.0)};
    struct cand *pop = malloc(DE_POP * sizeof *pop);
    double *spec = malloc((pb->n ? pb->n : 1) * sizeof *spec);
    gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
    int got = -1;
    if (!pop || !spec || !rng)
        goto done;
    gsl_rng_set(rng, seed);
    for (int i = 0; i < DE_POP; i++) {
        for (int d = 0; d < DE_DIM; d++)
            pop[i].x[d] = l[d] + (h[d] - l[d]) * gsl_rng_uniform(rng);
        score(pb, &pop[i], spec);
    }
    for (int g = 0; g < DE_GENS; g++) {
        for (int i = 0; i < DE_POP; i++) {
            int a, b, c;
            do
                a = (int)gsl_rng_uniform_int(rng, DE_POP);
            while (a == i);
            do
                b = (int)gsl_rng_uniform_int(rng, DE_POP);
            while (b == i || b == a);
            do
                c = (int)gsl_rng_uniform_int(rng, DE_POP);
            while (c == i || c == a || c == b);
            int jr = (int)gsl_rng_uniform_int(rng, DE_DIM);
            struct cand t = pop[i];
            for (int d = 0; d < DE_DIM; d++) {
                if (d == jr || gsl_rng_uniform(rng) < DE_CR) {
                    double v = pop[a].x[d] + DE_F * (pop[b].x[d] - pop[c].x[d]);
                    /* reflect into the box rather than clip: clipping piles
                     * candidates on the faces */
                    if (v < l[d])
                        v = l[d] + fmod(l[d] - v, h[d] - l[d]);
                    if (v > h[d])
                        v = h[d] - fmod(v - h[d], h[d] - l[d]);
                    t.x[d] = v;
                }
            }
            score(pb, &t, spec);
            if (t.score <= pop[i].score)
                pop[i] = t;
        }
    }
    qsort(pop, DE_POP, sizeof *pop, cmp_cand);
    got = 0;
    for (int i = 0; i < DE_POP && got < max_starts; i++) {
        if (!isfinite(pop[i].score))
            break;
        int near = 0;
        for (int j = 0; j < got && !near; j++) {
            /* compare against the candidates already taken, in range units */
            const double *o = starts + (size_t)j * ABC_NPAR;
            struct brdf_abc q;
            abc_theta_to_params(o, &q);
            double dx[DE_DIM] = {log10(q.B) - pop[i].x[0], log(q.C) - pop[i].x[1],
                                 logit_eta(q.eta) - pop[i].x[2]};
            near = 1;
            for (int d = 0; d < DE_DIM; d++)
                if (fabs(dx[d]) > DE_DISTINCT * (h[d] - l[d]))
                    near = 0;
        }
        if (near)
            continue;
        struct brdf_abc p;
        for (int c = 0; c < 3; c++) {
            p.kd[c] = fmax(pop[i].kd[c], START_FLOOR);
            p.A[c] = fmax(pop[i].A[c], START_FLOOR);
        }
        p.B = pow(10.0, pop[i].x[0]);
        p.C = exp(pop[i].x[1]);
        p.eta = eta_at(pop[i].x[2]);
        abc_params_to_theta(&p, starts + (size_t)got * ABC_NPAR);
        got++;
    }
done:
    free(pop);
    free(spec);
    gsl_rng_free(rng);
    return got;
}
