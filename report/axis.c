/* Axis ranges and ticks (axis.h). */
#include "report/axis.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* The smallest step of the form {1, 2, 5} x 10^e that is >= raw. */
static double nice_step(double raw)
{
    double e = floor(log10(raw));
    double p = pow(10.0, e), f = raw / p;
    if (f <= 1.0 + 1e-9)
        return p;
    if (f <= 2.0 + 1e-9)
        return 2 * p;
    if (f <= 5.0 + 1e-9)
        return 5 * p;
    return 10 * p;
}

/* The nice step after this one: 1 -> 2 -> 5 -> 10. */
static double next_step(double step)
{
    double p = pow(10.0, floor(log10(step) + 1e-9));
    return step / p < 1.5 ? 2 * p : step / p < 3.5 ? 5 * p : 10 * p;
}

static void label_linear(char *out, double v, double step)
{
    int decimals = (int)-floor(log10(step) + 1e-9);
    if (decimals < 0)
        decimals = 0;
    if (fabs(v) < 0.5 * step)
        v = 0; /* no "-0" from rounding */
    if (fabs(v) >= 1e6)
        snprintf(out, PLOT_LABEL_MAX, "%g", v);
    else
        snprintf(out, PLOT_LABEL_MAX, "%.*f", decimals, v);
}

/* "10⁻⁵", "2×10⁴", or plain digits for 0.01 ... 1000. */
static void label_power(char *out, int mantissa, int e)
{
    static const char *sup[] = {"⁰", "¹", "²", "³", "⁴", "⁵", "⁶", "⁷", "⁸", "⁹"};
    if (e >= -2 && e <= 3) {
        snprintf(out, PLOT_LABEL_MAX, "%g", mantissa * pow(10.0, e));
        return;
    }
    char exp[16] = ""; /* "⁻" and up to three digits, 3 bytes each */
    int a = e < 0 ? -e : e;
    if (e < 0)
        strcat(exp, "⁻");
    char digits[16];
    snprintf(digits, sizeof digits, "%d", a);
    for (const char *d = digits; *d; d++)
        strcat(exp, sup[*d - '0']);
    if (mantissa == 1)
        snprintf(out, PLOT_LABEL_MAX, "10%.13s", exp);
    else
        snprintf(out, PLOT_LABEL_MAX, "%d×10%.13s", mantissa, exp);
}

static int fit_linear(struct plot_axis *a, double lo, double hi, int max_ticks, int fixed)
{
    double step = nice_step((hi - lo) / (max_ticks - 1));
    for (;;) {
        double k0 = fixed ? ceil(lo / step - 1e-9) : floor(lo / step + 1e-9);
        double k1 = fixed ? floor(hi / step + 1e-9) : ceil(hi / step - 1e-9);
        if (k1 - k0 + 1 <= max_ticks) {
            a->lo = fixed ? lo : k0 * step;
            a->hi = fixed ? hi : k1 * step;
            a->n_ticks = 0;
            for (double k = k0; k <= k1 + 0.5; k++) {
                a->ticks[a->n_ticks] = k * step;
                label_linear(a->labels[a->n_ticks], k * step, step);
                a->n_ticks++;
            }
            return 0;
        }
        step = next_step(step);
    }
}

static void add_minor(struct plot_axis *a, double v)
{
    if (a->n_minor < PLOT_TICKS_MAX && v >= a->lo * (1 - 1e-12) && v <= a->hi * (1 + 1e-12))
        a->minor[a->n_minor++] = v;
}

static int fit_log(struct plot_axis *a, double lo, double hi, int max_ticks)
{
    int dlo = (int)floor(log10(lo) + 1e-9), dhi = (int)ceil(log10(hi) - 1e-9);
    if (dhi <= dlo)
        dhi = dlo + 1;
    int nd = dhi - dlo;
    int k = 1; /* decades per labelled tick */
    for (;;) {
        /* Snap the ends to multiples of k so the labels are regular. */
        int slo = (int)floor((double)dlo / k) * k, shi = (int)ceil((double)dhi / k) * k;
        if ((shi - slo) / k + 1 <= max_ticks) {
            dlo = slo;
            dhi = shi;
            break;
        }
        k++;
    }
    a->lo = pow(10.0, dlo);
    a->hi = pow(10.0, dhi);
    a->n_ticks = 0;
    a->n_minor = 0;
    if (nd == 1) {
        static const int m[] = {1, 2, 5, 10};
        for (int i = 0; i < 4; i++) {
            int mant = m[i] == 10 ? 1 : m[i], e = m[i] == 10 ? dhi : dlo;
            a->ticks[a->n_ticks] = mant * pow(10.0, e);
            label_power(a->labels[a->n_ticks], mant, e);
            a->n_ticks++;
        }
        static const int mm[] = {3, 4, 6, 7, 8, 9};
        for (int i = 0; i < 6; i++)
            add_minor(a, mm[i] * a->lo);
        return 0;
    }
    for (int e = dlo; e <= dhi; e += k) {
        a->ticks[a->n_ticks] = pow(10.0, e);
        label_power(a->labels[a->n_ticks], 1, e);
        a->n_ticks++;
    }
    if (k == 1 && nd <= 4)
        for (int e = dlo; e < dhi; e++)
            for (int m = 2; m <= 9; m++)
                add_minor(a, m * pow(10.0, e));
    else if (k > 1)
        for (int e = dlo; e < dhi; e++)
            if ((e - dlo) % k)
                add_minor(a, pow(10.0, e));
    return 0;
}

struct duration_tick {
    double s;
    const char *label;
    int coarse; /* part of the sparse set used for wide ranges */
};

static const struct duration_tick durations[] = {
    {1e-3, "1 ms", 1},    {1e-2, "10 ms", 1},   {0.1, "0.1 s", 1},    {0.2, "0.2 s", 0},
    {0.5, "0.5 s", 0},    {1, "1 s", 1},        {2, "2 s", 0},        {5, "5 s", 0},
    {10, "10 s", 1},      {20, "20 s", 0},      {30, "30 s", 0},      {60, "1 min", 1},
    {120, "2 min", 0},    {300, "5 min", 0},    {600, "10 min", 1},   {1200, "20 min", 0},
    {1800, "30 min", 0},  {3600, "1 h", 1},     {7200, "2 h", 0},     {18000, "5 h", 0},
    {36000, "10 h", 0},   {86400, "1 d", 1},    {172800, "2 d", 0},   {432000, "5 d", 0},
    {864000, "10 d", 1},  {2592000, "30 d", 0}, {8640000, "100 d", 1}, {31557600, "1 yr", 1},
};
#define N_DURATIONS (sizeof durations / sizeof durations[0])

static int fit_duration(struct plot_axis *a, double lo, double hi, int max_ticks)
{
    if (lo < durations[0].s || hi > durations[N_DURATIONS - 1].s)
        return fit_log(a, lo, hi, max_ticks); /* beyond the named units */
    /* The range rounds out to the nearest coarse ticks around the data. */
    size_t i0 = 0, i1 = N_DURATIONS - 1;
    for (size_t i = 0; i < N_DURATIONS; i++)
        if (durations[i].coarse && durations[i].s <= lo * (1 + 1e-9))
            i0 = i;
    for (size_t i = N_DURATIONS; i-- > 0;)
        if (durations[i].coarse && durations[i].s >= hi * (1 - 1e-9))
            i1 = i;
    if (i1 == i0)
        i1++;
    a->lo = durations[i0].s;
    a->hi = durations[i1].s;
    size_t n_coarse = 0;
    for (size_t i = i0; i <= i1; i++)
        n_coarse += durations[i].coarse;
    int all = n_coarse < 3 && i1 - i0 + 1 <= (size_t)max_ticks;
    size_t stride = 1;
    while (!all && (n_coarse + stride - 1) / stride > (size_t)max_ticks)
        stride++;
    a->n_ticks = a->n_minor = 0;
    size_t c = 0;
    for (size_t i = i0; i <= i1; i++) {
        int major = all || (durations[i].coarse && c++ % stride == 0);
        if (major) {
            a->ticks[a->n_ticks] = durations[i].s;
            snprintf(a->labels[a->n_ticks], PLOT_LABEL_MAX, "%s", durations[i].label);
            a->n_ticks++;
        } else {
            add_minor(a, durations[i].s);
        }
    }
    return 0;
}

static int check(struct plot_axis *a, enum plot_scale scale, double *lo, double *hi,
                 int *max_ticks)
{
    if (!isfinite(*lo) || !isfinite(*hi) || *lo > *hi)
        return -1;
    if (scale != PLOT_LINEAR && !(*lo > 0))
        return -1;
    if (*max_ticks < 3)
        *max_ticks = 3;
    if (*max_ticks > PLOT_TICKS_MAX)
        *max_ticks = PLOT_TICKS_MAX;
    memset(a, 0, sizeof *a);
    a->scale = scale;
    if (*lo == *hi) {
        if (scale == PLOT_LINEAR) {
            double d = *lo == 0 ? 1 : 0.1 * fabs(*lo);
            *lo -= d;
            *hi += d;
        } else {
            *lo /= 2;
            *hi *= 2;
        }
    }
    return 0;
}

int plot_axis_fit(struct plot_axis *a, enum plot_scale scale, double lo, double hi,
                  int max_ticks)
{
    if (check(a, scale, &lo, &hi, &max_ticks))
        return -1;
    switch (scale) {
    case PLOT_LINEAR: return fit_linear(a, lo, hi, max_ticks, 0);
    case PLOT_LOG: return fit_log(a, lo, hi, max_ticks);
    case PLOT_DURATION: return fit_duration(a, lo, hi, max_ticks);
    }
    return -1;
}

int plot_axis_fixed(struct plot_axis *a, enum plot_scale scale, double lo, double hi,
                    int max_ticks)
{
    if (check(a, scale, &lo, &hi, &max_ticks))
        return -1;
    if (scale == PLOT_LINEAR)
        return fit_linear(a, lo, hi, max_ticks, 1);
    /* Log and duration: the rounded-out ticks, kept inside [lo, hi]. */
    struct plot_axis full;
    int rc = plot_axis_fit(&full, scale, lo, hi, max_ticks);
    if (rc)
        return rc;
    a->lo = lo;
    a->hi = hi;
    for (size_t i = 0; i < full.n_ticks; i++)
        if (full.ticks[i] >= lo * (1 - 1e-12) && full.ticks[i] <= hi * (1 + 1e-12)) {
            a->ticks[a->n_ticks] = full.ticks[i];
            memcpy(a->labels[a->n_ticks], full.labels[i], PLOT_LABEL_MAX);
            a->n_ticks++;
        }
    for (size_t i = 0; i < full.n_minor; i++)
        add_minor(a, full.minor[i]);
    return 0;
}

double plot_axis_frac(const struct plot_axis *a, double v)
{
    if (!isfinite(v))
        return NAN;
    if (a->scale == PLOT_LINEAR)
        return (v - a->lo) / (a->hi - a->lo);
    if (!(v > 0))
        return NAN;
    return log(v / a->lo) / log(a->hi / a->lo);
}
