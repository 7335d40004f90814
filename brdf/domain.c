#include "brdf/domain.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

#define PI 3.14159265358979323846
#define N_TH 90
#define N_TD 90
#define N_PD 180
_Static_assert(N_TH == BRDF_DOMAIN_N_HD && N_TD == BRDF_DOMAIN_N_HD, "brdf_domain_hd_counts");

/* Tolerance on the 80 degree limit: rounding in the polar angle must not
 * decide whether a node on the limit is in. */
#define THETA_TOL_DEG 1e-9

int brdf_domain_keeps(const struct brdf_pair *p)
{
    return p->wi[2] > 0 && p->wo[2] > 0 &&
           brdf_pair_theta_i_deg(p) <= BRDF_DOMAIN_MAX_THETA_DEG + THETA_TOL_DEG &&
           brdf_pair_theta_o_deg(p) <= BRDF_DOMAIN_MAX_THETA_DEG + THETA_TOL_DEG;
}

/* The grid's angles with their cosines and sines, computed once per
 * domain: building a pair from them is the arithmetic of
 * brdf_pair_from_hd without its trigonometry. */
struct grid {
    struct brdf_angle th[N_TH], td[N_TD], pd[N_PD];
    int n_pd;
    double cz; /* cos 80 degrees */
};

static struct brdf_angle angle(double rad)
{
    return (struct brdf_angle){rad, cos(rad), sin(rad)};
}

static void grid_init(struct grid *g, const double *phis, int n_phi)
{
    for (int i = 0; i < N_TH; i++) {
        double u = i / (double)N_TH;
        g->th[i] = angle(u * u * (PI / 2));
    }
    for (int j = 0; j < N_TD; j++)
        g->td[j] = angle(j / (double)N_TD * (PI / 2));
    for (int k = 0; k < n_phi; k++)
        g->pd[k] = angle(phis[k]);
    g->n_pd = n_phi;
    g->cz = cos(BRDF_DOMAIN_MAX_THETA_DEG * BRDF_DEG);
}

static void grid_pair(const struct grid *g, int i, int j, int k, struct brdf_pair *p)
{
    brdf_pair_from_hd_cs(&g->th[i], &g->td[j], &g->pd[k], p);
}

/* brdf_domain_keeps, deciding by the height of the unit directions where
 * it is clear: 1e-10 in cos theta is ~6e-9 degrees near 80, six times the
 * rule's tolerance and a million times the rounding of the directions, so
 * only nodes within that band of the limit take the exact angles. */
static int grid_keeps(const struct grid *g, const struct brdf_pair *p)
{
    double lo = g->cz - 1e-10, hi = g->cz + 1e-10;
    if (p->wi[2] >= hi && p->wo[2] >= hi)
        return 1;
    if (p->wi[2] <= lo || p->wo[2] <= lo)
        return 0;
    return brdf_domain_keeps(p);
}

/* Append the kept pairs over all (i, j, k), i slowest. Grows the array
 * geometrically; shrinks it at the end. */
static int build(struct brdf_domain *d, const double *phis, int n_phi, struct gonio_err *err,
                 const char *what)
{
    d->pairs = NULL;
    d->n = 0;
    struct grid g;
    grid_init(&g, phis, n_phi);
    size_t cap = 1024;
    struct brdf_pair *buf = malloc(cap * sizeof *buf);
    if (!buf)
        return gonio_err_set(err, ENOMEM, "%s domain: out of memory", what);
    size_t n = 0;
    for (int i = 0; i < N_TH; i++) {
        for (int j = 0; j < N_TD; j++) {
            for (int k = 0; k < n_phi; k++) {
                struct brdf_pair p;
                grid_pair(&g, i, j, k, &p);
                if (!grid_keeps(&g, &p))
                    continue;
                if (n == cap) {
                    struct brdf_pair *nb = realloc(buf, 2 * cap * sizeof *buf);
                    if (!nb) {
                        free(buf);
                        return gonio_err_set(err, ENOMEM, "%s domain: out of memory at %zu pairs",
                                             what, n);
                    }
                    buf = nb;
                    cap *= 2;
                }
                buf[n++] = p;
            }
        }
    }
    struct brdf_pair *fit = realloc(buf, (n ? n : 1) * sizeof *buf);
    d->pairs = fit ? fit : buf;
    d->n = n;
    return 0;
}

static void full_phis(double *phis)
{
    for (int k = 0; k < N_PD; k++)
        phis[k] = k / (double)N_PD * PI;
}

int brdf_domain_full(struct brdf_domain *d, struct gonio_err *err)
{
    double phis[N_PD];
    full_phis(phis);
    return build(d, phis, N_PD, err, "full");
}

int brdf_domain_inplane(struct brdf_domain *d, struct gonio_err *err)
{
    const double phis[2] = {0.0, PI};
    return build(d, phis, 2, err, "in-plane");
}

void brdf_domain_hd_place(const struct brdf_pair *p, double *u, double *v)
{
    *u = sqrt(fmax(p->theta_h, 0.0) / (90 * BRDF_DEG));
    *v = p->theta_d / (90 * BRDF_DEG);
}

void brdf_domain_hd_counts(unsigned short counts[BRDF_DOMAIN_N_HD * BRDF_DOMAIN_N_HD])
{
    double phis[N_PD];
    full_phis(phis);
    struct grid g;
    grid_init(&g, phis, N_PD);
    for (int i = 0; i < N_TH; i++)
        for (int j = 0; j < N_TD; j++) {
            unsigned short kept = 0;
            for (int k = 0; k < N_PD; k++) {
                struct brdf_pair p;
                grid_pair(&g, i, j, k, &p);
                kept += (unsigned short)grid_keeps(&g, &p);
            }
            counts[i * BRDF_DOMAIN_N_HD + j] = kept;
        }
}

uint64_t brdf_splitmix64(uint64_t *state)
{
    uint64_t z = (*state += UINT64_C(0x9e3779b97f4a7c15));
    z = (z ^ (z >> 30)) * UINT64_C(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94d049bb133111eb);
    return z ^ (z >> 31);
}

/* Uniform integer in [0, range) without modulo bias: reject the top sliver
 * of the 64-bit range that does not divide evenly. */
static uint64_t uniform_below(uint64_t *state, uint64_t range)
{
    uint64_t limit = UINT64_MAX - UINT64_MAX % range;
    uint64_t x;
    do
        x = brdf_splitmix64(state);
    while (x >= limit);
    return x % range;
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

int brdf_domain_oop_random(struct brdf_domain *d, size_t n, uint64_t seed,
                           struct gonio_err *err)
{
    d->pairs = NULL;
    d->n = 0;
    /* The kept nodes' grid numbers, in full-domain order: the draw permutes
     * these instead of a million built pairs, and only the n drawn are
     * built (the same pairs, bit for bit, as brdf_domain_full's). */
    double phis[N_PD];
    full_phis(phis);
    struct grid g;
    grid_init(&g, phis, N_PD);
    uint32_t *code = malloc((size_t)N_TH * N_TD * N_PD * sizeof *code);
    if (!code)
        return gonio_err_set(err, ENOMEM, "oop random domain: out of memory");
    size_t total = 0;
    for (int i = 0; i < N_TH; i++)
        for (int j = 0; j < N_TD; j++)
            for (int k = 0; k < N_PD; k++) {
                struct brdf_pair p;
                grid_pair(&g, i, j, k, &p);
                if (grid_keeps(&g, &p))
                    code[total++] = (uint32_t)((i * N_TD + j) * N_PD + k);
            }
    if (n > total) {
        free(code);
        return gonio_err_set(err, GONIO_EBADCONFIG,
                             "oop random domain: n = %zu: more than the %zu full-domain nodes",
                             n, total);
    }
    struct brdf_pair *out = malloc((n ? n : 1) * sizeof *out);
    if (!out) {
        free(code);
        return gonio_err_set(err, ENOMEM, "oop random domain: out of memory");
    }
    /* Partial Fisher-Yates: position i takes a uniform pick of the rest. */
    uint64_t state = seed;
    for (size_t i = 0; i < n; i++) {
        size_t j = i + (size_t)uniform_below(&state, (uint64_t)(total - i));
        uint32_t t = code[i];
        code[i] = code[j];
        code[j] = t;
    }
    /* Grid order keeps nearby nodes together for the materials' caches. */
    qsort(code, n, sizeof *code, cmp_u32);
    for (size_t i = 0; i < n; i++) {
        uint32_t c = code[i];
        grid_pair(&g, (int)(c / (N_TD * N_PD)), (int)(c / N_PD % N_TD), (int)(c % N_PD),
                  &out[i]);
    }
    free(code);
    d->pairs = out;
    d->n = n;
    return 0;
}

void brdf_domain_free(struct brdf_domain *d)
{
    if (!d)
        return;
    free(d->pairs);
    d->pairs = NULL;
    d->n = 0;
}

void brdf_domain_turn(struct brdf_domain *d)
{
    const double golden = 180.0 * (3.0 - sqrt(5.0)); /* 137.5... degrees */
    for (size_t n = 0; n < d->n; n++)
        brdf_pair_rotate(&d->pairs[n], fmod((double)n * golden, 360.0));
}
