/* The fit status (fit/fit_status.h). */
#include "fit/fit_status.h"

#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fit/fit.h"
#include "fit/model_file.h"

static const char *const names[] = {"converged", "not-converged", "underdetermined",
                                    "poor-fit",  "at-bound",      "ill-conditioned",
                                    "peak-unbounded"};
#define N_CODES (sizeof names / sizeof names[0])

struct fit_status fit_status_init(void)
{
    return (struct fit_status){.params = -1, .rank = -1, .cond = NAN, .insample = NAN,
                               .heldout = NAN};
}

void fit_status_decide(struct fit_status *st)
{
    unsigned add = 0;
    if (st->params >= 0 &&
        (st->geometries < (size_t)st->params || (st->rank >= 0 && st->rank < st->params)))
        add |= 1u << FIT_STATUS_UNDERDETERMINED;
    if (st->cond > FIT_STATUS_COND_MAX)
        add |= 1u << FIT_STATUS_ILL_CONDITIONED;
    if (st->at_bound[0])
        add |= 1u << FIT_STATUS_AT_BOUND;
    if (fmax(st->heldout, st->insample) > FIT_STATUS_POOR_FACTOR * FIT_STATUS_NOISE_LOG)
        add |= 1u << FIT_STATUS_POOR_FIT;
    st->findings |= add;
}

enum fit_status_code fit_status_code(const struct fit_status *st)
{
    for (unsigned c = 1; c < N_CODES; c++)
        if (st->findings & (1u << c))
            return (enum fit_status_code)c;
    return FIT_STATUS_CONVERGED;
}

const char *fit_status_name(enum fit_status_code c)
{
    return (unsigned)c < N_CODES ? names[c] : "unknown";
}

void fit_status_findings(const struct fit_status *st, char *buf, size_t len)
{
    size_t at = 0;
    if (len)
        buf[0] = '\0';
    for (unsigned c = 1; c < N_CODES && at < len; c++)
        if (st->findings & (1u << c))
            at += (size_t)snprintf(buf + at, len - at, "%s%s", at ? "," : "", names[c]);
    if (!at)
        snprintf(buf, len, "%s", names[FIT_STATUS_CONVERGED]);
}

/* Append printf output to buf at *at, never past len. */
static void add(char *buf, size_t len, size_t *at, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

static void add(char *buf, size_t len, size_t *at, const char *fmt, ...)
{
    if (*at >= len)
        return;
    va_list ap;
    va_start(ap, fmt);
    int k = vsnprintf(buf + *at, len - *at, fmt, ap);
    va_end(ap);
    if (k > 0)
        *at += (size_t)k;
}

void fit_status_line(const struct fit_status *st, char *buf, size_t len)
{
    char f[96];
    size_t at = 0;
    if (len)
        buf[0] = '\0';
    fit_status_findings(st, f, sizeof f);
    add(buf, len, &at, "%s", f);
    if (st->at_bound[0])
        add(buf, len, &at, " (%s)", st->at_bound);
    add(buf, len, &at, "; %zu geometries", st->geometries);
    if (st->params >= 0 && st->rank >= 0)
        add(buf, len, &at, ", rank %d of %d free parameters", st->rank, st->params);
    else if (st->params >= 0)
        add(buf, len, &at, ", %d free parameters", st->params);
    if (!isnan(st->cond))
        add(buf, len, &at, ", condition %.2g", st->cond);
    if (!isnan(st->heldout))
        add(buf, len, &at, ", held-out %.3g vs in-sample %.3g RMS log", st->heldout,
            st->insample);
    else if (!isnan(st->insample))
        add(buf, len, &at, ", in-sample %.3g RMS log (none held out)", st->insample);
}

static int cmp_pair(const void *a, const void *b)
{
    const double *x = a, *y = b;
    for (int k = 0; k < 2; k++)
        if (x[k] != y[k])
            return x[k] < y[k] ? -1 : 1;
    return 0;
}

/* The bits of a rounded value, -0 taken as +0 (which cmp_pair treats alike). */
static uint64_t pair_bits(double v)
{
    uint64_t b;
    v = v == 0 ? 0.0 : v;
    memcpy(&b, &v, sizeof b);
    return b;
}

/* The distinct pairs among p[0..n): an open-addressing hash table (sorting
 * them was a thirtieth of an ABC fit); sorted when there is no memory. */
static size_t count_distinct(double (*p)[2], size_t n)
{
    size_t cap = 4;
    while (cap < 2 * n)
        cap *= 2;
    size_t *slot = calloc(cap, sizeof *slot); /* pair index + 1; 0: empty */
    size_t distinct = 0;
    if (!slot) {
        qsort(p, n, sizeof *p, cmp_pair);
        for (size_t i = 0; i < n; i++)
            distinct += i == 0 || cmp_pair(p[i], p[i - 1]) != 0;
        return distinct;
    }
    for (size_t i = 0; i < n; i++) {
        uint64_t h = (pair_bits(p[i][0]) * 0x9E3779B97F4A7C15u) ^ pair_bits(p[i][1]);
        h *= 0xFF51AFD7ED558CCDu;
        size_t at = (size_t)(h ^ (h >> 32)) & (cap - 1);
        while (slot[at] && cmp_pair(p[slot[at] - 1], p[i]) != 0)
            at = (at + 1) & (cap - 1);
        if (!slot[at]) {
            slot[at] = i + 1;
            distinct++;
        }
    }
    free(slot);
    return distinct;
}

size_t fit_status_distinct_pairs(double (*p)[2], size_t n)
{
    /* on a 1e-9 grid, so that rounding in the angles' computation does
     * not make one geometry two */
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        if (isfinite(p[i][0]) && isfinite(p[i][1])) { /* no geometry without its angles */
            p[m][0] = nearbyint(p[i][0] * 1e9);
            p[m][1] = nearbyint(p[i][1] * 1e9);
            m++;
        }
    return count_distinct(p, m);
}

size_t fit_status_geometries(const struct fit_sample *s, const size_t *idx, size_t n)
{
    double(*p)[2] = malloc((n ? n : 1) * sizeof *p);
    if (!p)
        return (size_t)-1;
    for (size_t k = 0; k < n; k++) {
        const struct fit_sample *x = &s[idx ? idx[k] : k];
        p[k][0] = x->g.theta_h;
        p[k][1] = x->g.theta_d;
    }
    size_t d = fit_status_distinct_pairs(p, n);
    free(p);
    return d;
}

int fit_status_file_keys(struct fit_model_file *f, const struct fit_status *st)
{
    char findings[96];
    fit_status_findings(st, findings, sizeof findings);
    int rc = fit_model_file_set(f, "status", "%s", fit_status_name(fit_status_code(st)));
    rc = rc ? rc : fit_model_file_set(f, "findings", "%s", findings);
    rc = rc ? rc : fit_model_file_set(f, "geometries", "%zu", st->geometries);
    rc = rc ? rc : fit_model_file_set(f, "params", "%d", st->params);
    rc = rc ? rc : fit_model_file_set(f, "rank", "%d", st->rank);
    rc = rc ? rc : fit_model_file_set(f, "condition", "%.4g", st->cond);
    rc = rc ? rc : fit_model_file_set(f, "at_bound", "%s", st->at_bound[0] ? st->at_bound : "-");
    rc = rc ? rc : fit_model_file_set(f, "rms_log_insample", "%.6g", st->insample);
    rc = rc ? rc : fit_model_file_set(f, "rms_log_heldout", "%.6g", st->heldout);
    return rc;
}
