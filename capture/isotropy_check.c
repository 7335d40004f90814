/* The isotropy check (capture/isotropy_check.h): pair choice, the
 * measurement sequence and the verdict's statistics. */
#include "capture/isotropy_check.h"

#include <gsl/gsl_cdf.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define WINDOW_DEG 15.0 /* the glossy half-width of the DS plans (DESIGN.md) */
#define ROW_TOL_DEG 0.3 /* samples within this of an incidence are its row */
/* The steepest a pair's reading may change, |d ln f / d theta_r| per
 * degree to its row neighbours: beyond it a few hundredths of a degree of
 * the axes' repeatability move the reading by more than the noise (a sharp
 * lobe's flanks, or the peak of one narrower than the row's step), and the
 * repeats would call the check too noisy. */
#define MAX_SLOPE_PER_DEG 0.5

const double iso_check_rotation_deg[ISO_CHECK_ROTATIONS + 1] = {60, 120, 0};

static double value_of(const struct journal_sample *s)
{
    return (s->rgb[0] + s->rgb[1] + s->rgb[2]) / 3.0;
}

static int usable(const struct journal_sample *s)
{
    double ph = fmod(s->phi_o, 180.0);
    int inplane = s->phi_i == 0 && (fabs(ph) < 1e-6 || fabs(ph - 180.0) < 1e-6);
    return inplane && !(s->flags & JOURNAL_FLAG_SATURATED) && value_of(s) > 0 &&
           isfinite(value_of(s));
}

/* The glossy row at incidence ti: indices sorted by theta_r into row. */
static size_t glossy_row(const struct journal_sample *s, size_t n, double ti, size_t *row)
{
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        if (usable(&s[i]) && fabs(s[i].theta_i - ti) < ROW_TOL_DEG &&
            fabs(s[i].theta_r - s[i].theta_i) <= WINDOW_DEG)
            row[m++] = i;
    for (size_t i = 1; i < m; i++) /* insertion sort: rows are short */
        for (size_t k = i; k > 0 && s[row[k]].theta_r < s[row[k - 1]].theta_r; k--) {
            size_t t = row[k];
            row[k] = row[k - 1];
            row[k - 1] = t;
        }
    return m;
}

/* The incidence of a glossy row of at least 3 samples nearest want, or NAN. */
static double incidence_near(const struct journal_sample *s, size_t n, double want,
                             double avoid, size_t *row)
{
    double best = NAN;
    for (size_t i = 0; i < n; i++) {
        double ti = s[i].theta_i;
        if (!usable(&s[i]) || ti < 10 || ti > 65 || fabs(ti - avoid) < 4)
            continue;
        if (!isnan(best) && fabs(ti - want) >= fabs(best - want))
            continue;
        if (glossy_row(s, n, ti, row) >= 3)
            best = ti;
    }
    return best;
}

/* How fast the reading of row sample k changes with theta_r: the steeper
 * of its steps to its neighbours, |d ln f| per degree. */
static double sensitivity(const struct journal_sample *s, const size_t *row, size_t len,
                          size_t k)
{
    double g = 0;
    for (int side = -1; side <= 1; side += 2) {
        if ((side < 0 && k == 0) || (side > 0 && k + 1 >= len))
            continue;
        const struct journal_sample *a = &s[row[k]], *b = &s[row[(long)k + side]];
        double dt = fabs(b->theta_r - a->theta_r);
        if (dt > 1e-6)
            g = fmax(g, fabs(log(value_of(b)) - log(value_of(a))) / dt);
    }
    return g;
}

/* The row sample in k0..k1 (inclusive) on the steepest flank that is no
 * steeper than MAX_SLOPE_PER_DEG; -1 when there is none. */
static long steepest(const struct journal_sample *s, const size_t *row, size_t len, size_t k0,
                     size_t k1)
{
    long best = -1;
    double slope = -1;
    for (size_t k = k0; k <= k1 && k < len; k++) {
        double g = sensitivity(s, row, len, k);
        if (g > slope && g <= MAX_SLOPE_PER_DEG) {
            slope = g;
            best = (long)k;
        }
    }
    return best;
}

static void add_pair(const struct journal_sample *x, struct iso_check_pair *out, size_t *m)
{
    for (size_t i = 0; i < *m; i++)
        if (out[i].theta_i == x->theta_i && out[i].theta_r == x->theta_r)
            return;
    out[(*m)++] = (struct iso_check_pair){x->theta_i, x->theta_r, value_of(x)};
}

size_t iso_check_choose(const struct journal_sample *s, size_t n, struct iso_check_pair *out)
{
    size_t *row = malloc((n ? n : 1) * sizeof *row), m = 0;
    if (!row)
        return 0;
    double ti[2];
    ti[0] = incidence_near(s, n, 30, -100, row);
    ti[1] = incidence_near(s, n, 40, isnan(ti[0]) ? -100 : ti[0], row);
    for (int r = 0; r < 2; r++) {
        if (isnan(ti[r]))
            continue;
        size_t len = glossy_row(s, n, ti[r], row), peak = 0;
        for (size_t k = 1; k < len; k++)
            if (value_of(&s[row[k]]) > value_of(&s[row[peak]]))
                peak = k;
        /* a lobe too sharp for the row's sampling has no peak to re-measure:
         * its reading hangs on hundredths of a degree */
        if (sensitivity(s, row, len, peak) <= MAX_SLOPE_PER_DEG)
            add_pair(&s[row[peak]], out, &m);
        long left = peak > 0 ? steepest(s, row, len, 0, peak - 1) : -1;
        long right = steepest(s, row, len, peak + 1, len - 1);
        if (left >= 0)
            add_pair(&s[row[left]], out, &m);
        if (right >= 0)
            add_pair(&s[row[right]], out, &m);
    }
    free(row);
    for (size_t i = 1; i < m; i++)
        for (size_t k = i; k > 0 && (out[k].theta_i < out[k - 1].theta_i ||
                                     (out[k].theta_i == out[k - 1].theta_i &&
                                      out[k].theta_r < out[k - 1].theta_r));
             k--) {
            struct iso_check_pair t = out[k];
            out[k] = out[k - 1];
            out[k - 1] = t;
        }
    return m;
}

void iso_check_decide(const struct iso_check_pair *p, size_t n, const double *turned,
                      const double *repeat, struct iso_check_result *out)
{
    memset(out, 0, sizeof *out);
    out->alpha = ISO_CHECK_ALPHA;
    out->pairs = n;
    double ss = 0;
    size_t df = 0, m = 0;
    for (size_t j = 0; j < n; j++)
        if (repeat[j] > 0 && p[j].first > 0) {
            double r = log(repeat[j]) - log(p[j].first);
            ss += r * r;
            df++;
        }
    out->noise = fmax(ISO_CHECK_NOISE_FLOOR, df ? sqrt(ss / (double)df) : INFINITY);
    for (size_t j = 0; j < n; j++)
        for (int k = 0; k < ISO_CHECK_ROTATIONS; k++) {
            double v = turned[j * ISO_CHECK_ROTATIONS + k];
            if (!(v > 0) || !(p[j].first > 0))
                continue;
            m++;
            double d = fabs(log(v) - log(p[j].first));
            if (d >= out->max_deviation) {
                out->max_deviation = d;
                out->worst = p[j];
                out->worst_rotation_deg = iso_check_rotation_deg[k];
            }
        }
    out->measurements = m + df;
    if (df < 3 || m < 3) {
        snprintf(out->verdict, sizeof out->verdict, "undetermined");
        snprintf(out->why, sizeof out->why,
                 "too few usable pairs (%zu repeats, %zu turned readings; need 3 of each)", df,
                 m);
        out->threshold = out->significance = out->detectable = NAN;
        return;
    }
    out->threshold = gsl_cdf_tdist_Qinv(ISO_CHECK_ALPHA / (2.0 * (double)m), (double)df);
    out->significance = out->max_deviation / out->noise;
    out->detectable = out->threshold * out->noise;
    if (out->significance > out->threshold) {
        snprintf(out->verdict, sizeof out->verdict, "anisotropic");
        snprintf(out->why, sizeof out->why,
                 "turned %g deg, (%.3g, %.3g) reads %+.1f%%: %.1f noise sd, beyond %.1f",
                 out->worst_rotation_deg, out->worst.theta_i, out->worst.theta_r,
                 100.0 * (exp(out->max_deviation) - 1.0), out->significance, out->threshold);
    } else if (out->detectable > ISO_CHECK_SENSITIVITY) {
        snprintf(out->verdict, sizeof out->verdict, "undetermined");
        snprintf(out->why, sizeof out->why,
                 "too noisy: only a deviation over %.0f%% would show (noise %.1f%%)",
                 100.0 * (exp(out->detectable) - 1.0), 100.0 * out->noise);
    } else {
        snprintf(out->verdict, sizeof out->verdict, "isotropic");
        snprintf(out->why, sizeof out->why,
                 "largest deviation %.1f%% within the noise (%.1f sd of %.1f allowed)",
                 100.0 * (exp(out->max_deviation) - 1.0), out->significance, out->threshold);
    }
}

int iso_check_run(const struct journal_sample *s, size_t n, iso_check_measure_fn measure,
                  void *user, struct iso_check_result *out, struct gonio_err *err)
{
    struct iso_check_pair p[ISO_CHECK_MAX_PAIRS];
    double turned[ISO_CHECK_MAX_PAIRS * ISO_CHECK_ROTATIONS], repeat[ISO_CHECK_MAX_PAIRS];
    size_t np = iso_check_choose(s, n, p);
    for (int k = 0; k <= ISO_CHECK_ROTATIONS; k++)
        for (size_t i = 0; i < np; i++) {
            size_t j = k % 2 ? np - 1 - i : i; /* snake: no long way back */
            double v = NAN;
            int rc = measure(user, &p[j], iso_check_rotation_deg[k], &v, err);
            if (rc < 0)
                return rc;
            if (k < ISO_CHECK_ROTATIONS)
                turned[j * ISO_CHECK_ROTATIONS + (size_t)k] = v;
            else
                repeat[j] = v;
        }
    iso_check_decide(p, np, turned, repeat, out);
    return 0;
}
