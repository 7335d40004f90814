#include "brdf/domain.h"

#include <errno.h>
#include <stdlib.h>

#define PI 3.14159265358979323846
#define N_TH 90
#define N_TD 90
#define N_PD 180

/* Tolerance on the 80 degree limit: rounding in the polar angle must not
 * decide whether a node on the limit is in. */
#define THETA_TOL_DEG 1e-9

int brdf_domain_keeps(const struct brdf_pair *p)
{
    return p->wi[2] > 0 && p->wo[2] > 0 &&
           brdf_pair_theta_i_deg(p) <= BRDF_DOMAIN_MAX_THETA_DEG + THETA_TOL_DEG &&
           brdf_pair_theta_o_deg(p) <= BRDF_DOMAIN_MAX_THETA_DEG + THETA_TOL_DEG;
}

static double node_theta_h(int i)
{
    double u = i / (double)N_TH;
    return u * u * (PI / 2);
}

static double node_theta_d(int j)
{
    return j / (double)N_TD * (PI / 2);
}

/* Append the kept pairs of the given phi_d values over all (i, j). Grows the
 * array geometrically; the caller shrinks it at the end. */
static int build(struct brdf_domain *d, const double *phis, int n_phi, struct gonio_err *err,
                 const char *what)
{
    d->pairs = NULL;
    d->n = 0;
    size_t cap = 1024;
    struct brdf_pair *buf = malloc(cap * sizeof *buf);
    if (!buf)
        return gonio_err_set(err, ENOMEM, "%s domain: out of memory", what);
    size_t n = 0;
    for (int i = 0; i < N_TH; i++) {
        double th = node_theta_h(i);
        for (int j = 0; j < N_TD; j++) {
            double td = node_theta_d(j);
            for (int k = 0; k < n_phi; k++) {
                struct brdf_pair p;
                brdf_pair_from_hd(th, td, phis[k], &p);
                if (!brdf_domain_keeps(&p))
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

int brdf_domain_full(struct brdf_domain *d, struct gonio_err *err)
{
    double phis[N_PD];
    for (int k = 0; k < N_PD; k++)
        phis[k] = k / (double)N_PD * PI;
    return build(d, phis, N_PD, err, "full");
}

int brdf_domain_inplane(struct brdf_domain *d, struct gonio_err *err)
{
    const double phis[2] = {0.0, PI};
    return build(d, phis, 2, err, "in-plane");
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

static int cmp_size(const void *a, const void *b)
{
    size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return (x > y) - (x < y);
}

int brdf_domain_oop_random(struct brdf_domain *d, size_t n, uint64_t seed,
                           struct gonio_err *err)
{
    d->pairs = NULL;
    d->n = 0;
    struct brdf_domain full;
    int rc = brdf_domain_full(&full, err);
    if (rc < 0)
        return rc;
    if (n > full.n) {
        size_t have = full.n;
        brdf_domain_free(&full);
        return gonio_err_set(err, GONIO_EBADCONFIG,
                             "oop random domain: n = %zu: more than the %zu full-domain nodes",
                             n, have);
    }
    size_t *idx = malloc((full.n ? full.n : 1) * sizeof *idx);
    struct brdf_pair *out = malloc((n ? n : 1) * sizeof *out);
    if (!idx || !out) {
        free(idx);
        free(out);
        brdf_domain_free(&full);
        return gonio_err_set(err, ENOMEM, "oop random domain: out of memory");
    }
    for (size_t i = 0; i < full.n; i++)
        idx[i] = i;
    /* Partial Fisher-Yates: position i takes a uniform pick of the rest. */
    uint64_t state = seed;
    for (size_t i = 0; i < n; i++) {
        size_t j = i + (size_t)uniform_below(&state, (uint64_t)(full.n - i));
        size_t t = idx[i];
        idx[i] = idx[j];
        idx[j] = t;
    }
    /* Grid order keeps nearby nodes together for the materials' caches. */
    qsort(idx, n, sizeof *idx, cmp_size);
    for (size_t i = 0; i < n; i++)
        out[i] = full.pairs[idx[i]];
    free(idx);
    brdf_domain_free(&full);
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
