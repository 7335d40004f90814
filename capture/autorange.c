/* Auto-ranging (autorange.h): a ladder of integrations, a dark frame per
 * rung, retakes until the peak sits between the floor and the clip. */
#include "capture/autorange.h"
#include "capture/capture.h"

#include <errno.h>
#include <math.h>
#include <string.h>

void autorange_init(struct autorange *a, const struct rig_profile *rig)
{
    memset(a, 0, sizeof *a);
    a->fixed_s = rig->integration_s > 0 ? rig->integration_s : rig->auto_min_s;
    a->min_s = rig->auto_min_s;
    a->max_s = rig->auto_max_s;
    a->no_shutter = !rig->shutter; /* the profile says there is nothing to close */
}

static double held(const struct autorange *a, double t)
{
    return fmin(fmax(t, a->min_s), a->max_s);
}

static double rung_of(const struct autorange *a, double k)
{
    return held(a, a->fixed_s * pow(AUTORANGE_STEP, k));
}

static double index_of(const struct autorange *a, double t)
{
    return log(t / a->fixed_s) / log(AUTORANGE_STEP);
}

size_t autorange_ladder(const struct autorange *a, double *out, size_t max)
{
    size_t n = 0;
    for (double k = floor(index_of(a, a->min_s)); n < max; k++) {
        double t = rung_of(a, k);
        if (n == 0 || t > out[n - 1])
            out[n++] = t;
        if (t >= a->max_s)
            break;
    }
    return n;
}

double capture_ranging_bound_s(const struct rig_profile *rig, size_t points)
{
    struct autorange a;
    autorange_init(&a, rig);
    double ladder[AUTORANGE_RUNGS], darks = 0;
    size_t n = autorange_ladder(&a, ladder, AUTORANGE_RUNGS);
    for (size_t k = 0; k < n; k++)
        darks += ladder[k];
    return a.max_s > a.fixed_s ? (double)points * (a.max_s - a.fixed_s) + darks : 0;
}

double autorange_rung(const struct autorange *a, double t, int dir)
{
    return rung_of(a, round(index_of(a, t)) + dir);
}

static const double *dark_at(const struct autorange *a, double t)
{
    for (size_t i = 0; i < a->n_dark; i++)
        if (fabs(a->dark_s[i] - t) <= 1e-9 * t)
            return a->dark[i];
    return NULL;
}

static void keep_dark(struct autorange *a, double t, const double counts[3])
{
    if (a->n_dark < AUTORANGE_RUNGS && !dark_at(a, t)) {
        a->dark_s[a->n_dark] = t;
        memcpy(a->dark[a->n_dark++], counts, 3 * sizeof *counts);
    }
}

void autorange_note(struct autorange *a, const struct journal_sample *s)
{
    if (s->flags & JOURNAL_FLAG_DARK) {
        keep_dark(a, s->integration_s, s->raw);
        a->dark_total_s += s->integration_s;
    } else if (s->integration_s > 0)
        a->next_s = s->integration_s;
}

/* The dark frame at t, the first time t is used: shutter closed, read,
 * opened again, handed to the caller. */
static int take_dark(struct autorange *a, drv_detector *d, double t, autorange_dark_fn dark,
                     void *user, struct gonio_err *err)
{
    if (a->no_shutter || dark_at(a, t))
        return 0;
    int rc = drv_detector_shutter(d, 1, err);
    if (rc == -ENOTSUP) { /* nothing to close: no dark frames on this rig */
        a->no_shutter = 1;
        if (err)
            memset(err, 0, sizeof *err);
        return 0;
    }
    struct drv_reading r;
    if (rc == 0)
        rc = drv_detector_acquire(d, t, &r, err);
    int reopen = drv_detector_shutter(d, 0, rc == 0 ? err : NULL);
    rc = rc < 0 ? rc : reopen;
    if (rc == 0) {
        keep_dark(a, r.integration_s, r.rgb);
        a->dark_total_s += r.integration_s;
        rc = dark ? dark(user, &r, err) : 0;
    }
    return rc;
}

/* A spectral detector's bands held in the take (beyond its room: none). */
static void keep_bands(struct autorange_take *out)
{
    struct drv_reading *r = &out->r;
    if (r->n_bands > AUTORANGE_MAX_BANDS || !r->bands)
        r->n_bands = 0;
    if (r->n_bands) {
        memcpy(out->bands_nm, r->bands_nm, (size_t)r->n_bands * sizeof *out->bands_nm);
        memcpy(out->bands, r->bands, (size_t)r->n_bands * sizeof *out->bands);
    }
    r->bands_nm = r->n_bands ? out->bands_nm : NULL;
    r->bands = r->n_bands ? out->bands : NULL;
}

/* The peak channel's signal: counts less the dark at the reading's
 * integration, where it is known (else the offset counts as signal, which
 * only errs towards fewer retakes). */
static double peak_signal(const struct autorange *a, const struct drv_reading *r)
{
    const double *dk = dark_at(a, r->integration_s);
    double peak = -INFINITY;
    for (int c = 0; c < 3; c++)
        peak = fmax(peak, r->rgb[c] - (dk ? dk[c] : 0));
    return peak;
}

/* The integration to try after a reading at t whose peak channel's signal
 * is peak (saturated or not): t itself when it is to be kept. The one rule
 * of the ladder, which a point's readings follow and autorange_model
 * predicts with. */
static double decide(const struct autorange *a, double t, double peak, int saturated,
                     double full_scale, int went_down)
{
    if (saturated)
        return autorange_rung(a, t, -1); /* t at the shortest: kept, flagged */
    if (went_down || peak >= AUTORANGE_FLOOR * full_scale)
        return t;
    double k = round(index_of(a, t));
    double want = index_of(a, t * AUTORANGE_AIM * full_scale / fmax(peak, 1.0));
    return rung_of(a, fmax(k + 1, floor(want)));
}

/* The integration to try after r at t: t itself when r is to be kept. */
static double next_try(const struct autorange *a, const struct drv_reading *r, double t,
                       int went_down)
{
    return decide(a, t, peak_signal(a, r), (r->flags & DRV_READING_SATURATED) != 0,
                  r->full_scale, went_down);
}

int autorange_acquire(struct autorange *a, drv_detector *d, autorange_dark_fn dark,
                      void *user, struct autorange_take *out, struct gonio_err *err)
{
    memset(out, 0, sizeof *out);
    /* A detector that reduces its readings itself is read at the fixed
     * integration, as it always was; counts start where the last point
     * ended, on the ladder. */
    double t = a->next_s > 0 ? a->next_s : a->fixed_s;
    int went_down = 0, rc;
    for (;;) {
        if ((rc = drv_detector_acquire(d, t, &out->r, err)) < 0)
            return rc;
        keep_bands(out);
        out->total_s += out->r.integration_s;
        out->tries++;
        if (out->r.unit != DRV_UNIT_COUNTS || !(out->r.full_scale > 0))
            return 0; /* a detector that reduces its readings itself: read once */
        a->full_scale = out->r.full_scale;
        if ((rc = take_dark(a, d, t, dark, user, err)) < 0)
            return rc;
        double next = t != autorange_rung(a, t, 0) ? autorange_rung(a, t, 0)
                                                   : next_try(a, &out->r, t, went_down);
        if (next == t || out->tries >= AUTORANGE_TRIES)
            break;
        went_down |= next < t;
        a->retakes++;
        t = next;
    }
    a->next_s = t;
    return 0;
}

double autorange_rate(const struct autorange *a, const struct journal_sample *s)
{
    if (!s->counts || (s->flags & JOURNAL_FLAG_DARK) || !(s->integration_s > 0))
        return NAN;
    const double *dk = dark_at(a, s->integration_s);
    double peak = -INFINITY;
    for (int c = 0; c < 3; c++)
        peak = fmax(peak, s->raw[c] - (dk ? dk[c] : 0));
    return fmax(peak, 0.0) / s->integration_s;
}

int autorange_model_start(const struct autorange *a, struct autorange_model *m)
{
    memset(m, 0, sizeof *m);
    if (!(a->full_scale > 0))
        return 0;
    m->t = autorange_rung(a, a->next_s > 0 ? a->next_s : a->fixed_s, 0);
    m->n_dark = a->n_dark;
    memcpy(m->dark_s, a->dark_s, sizeof m->dark_s);
    return 1;
}

/* The dark offset a reading at t carries on its peak channel: the dark
 * frame's at t, else the nearest shorter one's (the offset dominates). */
static double model_offset(const struct autorange *a, double t)
{
    double off = 0, best = -1;
    for (size_t i = 0; i < a->n_dark; i++)
        if (a->dark_s[i] <= t * (1 + 1e-9) && a->dark_s[i] > best) {
            best = a->dark_s[i];
            off = fmax(fmax(a->dark[i][0], a->dark[i][1]), a->dark[i][2]);
        }
    return off;
}

/* A rung's dark frame, the first time the walk uses it: its time. */
static double model_dark(const struct autorange *a, struct autorange_model *m, double t)
{
    if (a->no_shutter)
        return 0;
    for (size_t i = 0; i < m->n_dark; i++)
        if (fabs(m->dark_s[i] - t) <= 1e-9 * t)
            return 0;
    if (m->n_dark < AUTORANGE_RUNGS)
        m->dark_s[m->n_dark++] = t;
    return t;
}

double autorange_model_point(const struct autorange *a, struct autorange_model *m, double rate)
{
    double t = m->t, cost = 0, fs = a->full_scale;
    int went_down = 0;
    for (int tries = 1;; tries++) {
        double signal = rate * t;
        int saturated = signal + model_offset(a, t) >= fs;
        cost += t + model_dark(a, m, t);
        double next = decide(a, t, fmin(signal, fs), saturated, fs, went_down);
        if (next == t || tries >= AUTORANGE_TRIES)
            break;
        went_down |= next < t;
        t = next;
    }
    m->t = t;
    return cost;
}
