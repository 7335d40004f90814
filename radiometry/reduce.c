/* The relative method and its budget (radiometry/reduce.h). */
#include "radiometry/reduce.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define GEOM_TOL_DEG 0.01 /* two geometries within this are the same point */

static const char *const term_names[RAD_N_TERMS] = {
    "counting", "dark", "reference", "reference_noise", "drift", "nonlinearity", "angle",
    "geometry", "stray", "solid_angle", "attenuator",
};

const char *rad_term_name(enum rad_term t)
{
    return t >= 0 && t < RAD_N_TERMS ? term_names[t] : "?";
}

/* The standard's certificate and shape, relative, for channel c. */
static double reference_rel_u(const struct rad_calibration *cal, int c)
{
    double cert = cal->standard.rho[c] > 0 ? cal->standard.u_rho[c] / cal->standard.rho[c] : 0.0;
    return sqrt(cert * cert + cal->standard.u_shape * cal->standard.u_shape);
}

void rad_systematic_rel_u(const struct rad_calibration *cal, double out[3])
{
    const struct rad_beam *b = &cal->beam;
    for (int c = 0; c < 3; c++) {
        double ref = b->on ? 0.0 : reference_rel_u(cal, c), geo = cal->setup.geometry_rel_u;
        double om = b->on ? b->omega_rel_u : 0.0, at = b->on ? b->attenuation_rel_u : 0.0;
        out[c] = sqrt(ref * ref + geo * geo + om * om + at * at);
    }
}

int rad_term_systematic(enum rad_term t)
{
    return t == RAD_U_REFERENCE || t == RAD_U_GEOMETRY || t == RAD_U_SOLID_ANGLE ||
           t == RAD_U_ATTENUATOR;
}

static int same_integration(double a, double b)
{
    return fabs(a - b) <= 1e-9 * fmax(1.0, fabs(a));
}

const struct rad_dark *rad_find_dark(const struct rad_calibration *cal, double integration_s,
                                     int gain_state)
{
    for (size_t k = 0; k < cal->n_darks; k++)
        if (cal->darks[k].gain_state == gain_state &&
            same_integration(cal->darks[k].integration_s, integration_s))
            return &cal->darks[k];
    return NULL;
}

int rad_covers(const struct rad_calibration *cal, double integration_s, int gain_state,
               struct gonio_err *err)
{
    if (!rad_find_dark(cal, integration_s, gain_state))
        return gonio_err_set(err, GONIO_EBADCONFIG,
                             "no dark frame at integration %g s, gain state %d", integration_s,
                             gain_state);
    for (size_t k = 0; k < cal->n_refs; k++)
        if (cal->refs[k].gain_state == gain_state)
            return 0;
    return gonio_err_set(err, GONIO_EBADCONFIG, "no reference readings at gain state %d",
                         gain_state);
}

double rad_linearise(double y, double k, double full_scale)
{
    if (!(k > 0.0) || !(full_scale > 0.0))
        return y;
    double disc = 1.0 - 4.0 * k * y / full_scale;
    if (disc <= 0.0)
        return full_scale / (2.0 * k); /* the top of the response: nothing reads higher */
    /* The smaller root, in the form without cancellation for small y. */
    return 2.0 * y / (1.0 + sqrt(disc));
}

/* The geometric factor the spot puts into a reading besides the BRDF. */
static double spot_factor(enum rad_spot spot, double theta_i, double theta_r)
{
    const double d2r = 3.14159265358979323846 / 180.0;
    return spot == RAD_SPOT_OVERFILLED ? cos(theta_i * d2r) : cos(theta_r * d2r);
}

/* One reference reading's response per channel: linearised counts above
 * its dark per monitor count (or per second), or -1 when it has no dark. */
struct response {
    double k[3];               /* x_r / m_r */
    double x[3];               /* x_r (its stray light taken off) */
    double stray_var[3];       /* the variance of the stray light taken off x_r */
    const struct rad_ref *ref; /* the (nearest) reading */
    const struct rad_dark *dark;
};

static int stray_at(const struct rad_calibration *cal, const struct rad_raw *s, int mon,
                    double ti, double tr, double rate[3], double var[3], struct gonio_err *err);

static int ref_response(const struct rad_calibration *cal, const struct rad_ref *r,
                        const struct rad_raw *s, int use_monitor, struct response *out,
                        struct gonio_err *err)
{
    const struct rad_dark *d = rad_find_dark(cal, r->integration_s, r->gain_state);
    if (!d)
        return gonio_err_set(err, GONIO_EBADCONFIG, "reference at (%g, %g) deg: no dark frame "
                             "at integration %g s, gain state %d", r->theta_i, r->theta_r,
                             r->integration_s, r->gain_state);
    double m = use_monitor ? r->monitor : r->integration_s;
    double stray[3], stray_var[3];
    int rc = stray_at(cal, s, use_monitor, r->theta_i, r->theta_r, stray, stray_var, err);
    if (rc < 0)
        return rc;
    for (int c = 0; c < 3; c++) {
        out->x[c] = rad_linearise(r->counts[c] - d->mean[c], s->nonlinearity, s->full_scale) -
                    m * stray[c];
        out->stray_var[c] = m * m * stray_var[c];
        if (!(out->x[c] > 0.0))
            return gonio_err_set(err, GONIO_EBADDATA, "reference at (%g, %g) deg: channel %d "
                                 "reads %g counts, not above its dark %g", r->theta_i,
                                 r->theta_r, c, r->counts[c], d->mean[c]);
        out->k[c] = out->x[c] / m;
    }
    out->ref = r;
    out->dark = d;
    return 0;
}

/* The reference response normalised by the standard and the spot, which
 * varies slowly with geometry, at reading r. */
static void normalised(const struct rad_calibration *cal, const struct response *resp,
                       double n[3])
{
    const struct rad_ref *r = resp->ref;
    double f[3];
    brdf_standard_brdf(&cal->standard, r->theta_i, r->theta_r, f);
    double g = spot_factor(cal->setup.spot, r->theta_i, r->theta_r);
    for (int c = 0; c < 3; c++)
        n[c] = resp->k[c] / (f[c] * g);
}

/* The two reference readings of gain state g at incidence ti bracketing tr
 * (lo == hi on an exact match); -1 when tr is outside the row. */
static int bracket_row(const struct rad_ref *refs, size_t n, int g, double ti, double tr,
                       const struct rad_ref **lo, const struct rad_ref **hi)
{
    *lo = *hi = NULL;
    for (size_t k = 0; k < n; k++) {
        const struct rad_ref *r = &refs[k];
        if (r->gain_state != g || fabs(r->theta_i - ti) > GEOM_TOL_DEG)
            continue;
        if (fabs(r->theta_r - tr) <= GEOM_TOL_DEG) {
            *lo = *hi = r;
            return 0;
        }
        if (r->theta_r < tr && (!*lo || r->theta_r > (*lo)->theta_r))
            *lo = r;
        if (r->theta_r > tr && (!*hi || r->theta_r < (*hi)->theta_r))
            *hi = r;
    }
    return *lo && *hi ? 0 : -1;
}

/* The incidence rows of gain state g bracketing ti (equal on a match). */
static int bracket_incidence(const struct rad_ref *refs, size_t n, int g, double ti,
                             double *lo, double *hi)
{
    *lo = -INFINITY, *hi = INFINITY;
    for (size_t k = 0; k < n; k++) {
        const struct rad_ref *r = &refs[k];
        if (r->gain_state != g)
            continue;
        if (fabs(r->theta_i - ti) <= GEOM_TOL_DEG) {
            *lo = *hi = r->theta_i;
            return 0;
        }
        if (r->theta_i < ti && r->theta_i > *lo)
            *lo = r->theta_i;
        if (r->theta_i > ti && r->theta_i < *hi)
            *hi = r->theta_i;
    }
    return isfinite(*lo) && isfinite(*hi) ? 0 : -1;
}

/* The stray rate of one stray reading (linearised counts above its dark
 * per monitor count or per second) and that rate's variance: the
 * readings' shot and read noise over their number, and the dark mean's. */
static int stray_rate(const struct rad_calibration *cal, const struct rad_ref *r,
                      const struct rad_raw *s, int mon, double rate[3], double var[3],
                      struct gonio_err *err)
{
    const struct rad_dark *d = rad_find_dark(cal, r->integration_s, r->gain_state);
    if (!d)
        return gonio_err_set(err, GONIO_EBADCONFIG, "stray light at (%g, %g) deg: no dark "
                             "frame at integration %g s, gain state %d", r->theta_i,
                             r->theta_r, r->integration_s, r->gain_state);
    double m = mon ? r->monitor : r->integration_s;
    for (int c = 0; c < 3; c++) {
        double x = rad_linearise(r->counts[c] - d->mean[c], s->nonlinearity, s->full_scale);
        double sd2 = d->sd[c] * d->sd[c];
        rate[c] = x / m;
        var[c] = ((cal->setup.adu_per_electron[c] * fmax(x, 0.0) + sd2) / r->n + sd2 / d->n) /
                 (m * m);
    }
    return 0;
}

/* The stray rate at (ti, tr) from one incidence row of the stray readings,
 * linear in theta_r between the two around it. */
static int stray_row(const struct rad_calibration *cal, const struct rad_raw *s, int mon,
                     double ti, double tr, double rate[3], double var[3], struct gonio_err *err)
{
    const struct rad_ref *lo, *hi;
    if (bracket_row(cal->strays, cal->n_strays, s->gain_state, ti, tr, &lo, &hi) < 0)
        return gonio_err_set(err, GONIO_EBADCONFIG, "(%g, %g) deg: outside the stray light's "
                             "geometries at incidence %g deg (gain state %d)", s->theta_i, tr,
                             ti, s->gain_state);
    double ra[3], va[3], rb[3], vb[3];
    int rc = stray_rate(cal, lo, s, mon, ra, va, err);
    if (rc < 0 || (rc = stray_rate(cal, hi, s, mon, rb, vb, err)) < 0)
        return rc;
    double t = lo == hi ? 0.0 : (tr - lo->theta_r) / (hi->theta_r - lo->theta_r);
    for (int c = 0; c < 3; c++) {
        rate[c] = ra[c] * (1 - t) + rb[c] * t;
        var[c] = va[c] * (1 - t) * (1 - t) + (lo == hi ? 0.0 : vb[c] * t * t);
    }
    return 0;
}

/* The stray rate at (ti, tr), bilinear in the stray readings' grid, and
 * its variance; 0 and 0 for a calibration without stray readings. */
static int stray_at(const struct rad_calibration *cal, const struct rad_raw *s, int mon,
                    double ti, double tr, double rate[3], double var[3], struct gonio_err *err)
{
    for (int c = 0; c < 3; c++)
        rate[c] = var[c] = 0.0;
    if (!cal->n_strays)
        return 0;
    double lo_i, hi_i, ra[3], va[3], rb[3], vb[3];
    if (bracket_incidence(cal->strays, cal->n_strays, s->gain_state, ti, &lo_i, &hi_i) < 0)
        return gonio_err_set(err, GONIO_EBADCONFIG, "(%g, %g) deg: no stray-light readings "
                             "around incidence %g deg at gain state %d", ti, tr, ti,
                             s->gain_state);
    int rc = stray_row(cal, s, mon, lo_i, tr, ra, va, err);
    if (rc < 0 || (rc = stray_row(cal, s, mon, hi_i, tr, rb, vb, err)) < 0)
        return rc;
    double t = lo_i == hi_i ? 0.0 : (ti - lo_i) / (hi_i - lo_i);
    for (int c = 0; c < 3; c++) {
        rate[c] = ra[c] * (1 - t) + rb[c] * t;
        var[c] = va[c] * (1 - t) * (1 - t) + (lo_i == hi_i ? 0.0 : vb[c] * t * t);
    }
    return 0;
}

/* The normalised response at (ti, tr) from one incidence row. */
static int row_value(const struct rad_calibration *cal, const struct rad_raw *s, int mon,
                     double ti, double n[3], struct response *nearest, struct gonio_err *err)
{
    const struct rad_ref *lo, *hi;
    if (bracket_row(cal->refs, cal->n_refs, s->gain_state, ti, s->theta_r, &lo, &hi) < 0)
        return gonio_err_set(err, GONIO_EBADCONFIG, "sample at (%g, %g) deg: outside the "
                             "reference's geometries at incidence %g deg (gain state %d)",
                             s->theta_i, s->theta_r, ti, s->gain_state);
    struct response a, b;
    double na[3], nb[3];
    int rc;
    if ((rc = ref_response(cal, lo, s, mon, &a, err)) < 0 ||
        (rc = ref_response(cal, hi, s, mon, &b, err)) < 0)
        return rc;
    normalised(cal, &a, na);
    normalised(cal, &b, nb);
    double t = lo == hi ? 0.0 : (s->theta_r - lo->theta_r) / (hi->theta_r - lo->theta_r);
    for (int c = 0; c < 3; c++)
        n[c] = na[c] * (1 - t) + nb[c] * t;
    *nearest = t <= 0.5 ? a : b;
    return 0;
}

/* The reference response at the sample's geometry: the reading itself
 * when there is one, else interpolated in the normalised response. */
static int reference_at(const struct rad_calibration *cal, const struct rad_raw *s, int mon,
                        struct response *out, struct gonio_err *err)
{
    double lo_i, hi_i;
    if (bracket_incidence(cal->refs, cal->n_refs, s->gain_state, s->theta_i, &lo_i, &hi_i) < 0)
        return gonio_err_set(err, GONIO_EBADCONFIG, "sample at (%g, %g) deg: no reference "
                             "readings around incidence %g deg at gain state %d", s->theta_i,
                             s->theta_r, s->theta_i, s->gain_state);
    double na[3], nb[3];
    struct response near_a, near_b;
    int rc = row_value(cal, s, mon, lo_i, na, &near_a, err);
    if (rc < 0 || (rc = row_value(cal, s, mon, hi_i, nb, &near_b, err)) < 0)
        return rc;
    const struct rad_ref *r = near_a.ref;
    if (lo_i == hi_i && fabs(r->theta_r - s->theta_r) <= GEOM_TOL_DEG) {
        *out = near_a; /* measured at this very geometry: no model in between */
        return 0;
    }
    double t = lo_i == hi_i ? 0.0 : (s->theta_i - lo_i) / (hi_i - lo_i);
    *out = t <= 0.5 ? near_a : near_b;
    double f[3];
    brdf_standard_brdf(&cal->standard, s->theta_i, s->theta_r, f);
    double g = spot_factor(cal->setup.spot, s->theta_i, s->theta_r);
    for (int c = 0; c < 3; c++)
        out->k[c] = (na[c] * (1 - t) + nb[c] * t) * f[c] * g;
    return 0;
}

/* d ln f_ref / d theta for the standard at the reference's geometry, per
 * degree, along theta_i and theta_r. */
static void standard_slopes(const struct brdf_standard *st, double ti, double tr, double sl[2])
{
    const double h = 0.5;
    sl[0] = log(brdf_standard_shape(st, ti + h, tr) / brdf_standard_shape(st, ti - h, tr)) /
            (2 * h);
    sl[1] = log(brdf_standard_shape(st, ti, tr + h) / brdf_standard_shape(st, ti, tr - h)) /
            (2 * h);
}

/* The relative variance an angle error adds to a reading whose log varies
 * with slopes sl (per degree): theta_i = s, theta_r = a - s, the axes'
 * errors s and a independent and uniform within the band. */
static double angle_var(const double sl[2], double band_deg)
{
    double u2 = band_deg * band_deg / 3.0;
    double ds = sl[0] - sl[1], da = sl[1];
    return (ds * ds + da * da) * u2;
}

/* The absolute method's "reference" at the sample's geometry: the beam's
 * response (linearised counts above its dark per monitor count, or per
 * second) through the attenuator undone, times what a BRDF of 1/sr puts
 * into the detector of that beam, cos(theta_r) omega (spot underfilled). */
static int beam_at(const struct rad_calibration *cal, const struct rad_raw *s, int mon,
                   struct response *out, struct gonio_err *err)
{
    const struct rad_ref *r = NULL;
    for (size_t k = 0; k < cal->n_refs && !r; k++)
        if (cal->refs[k].gain_state == s->gain_state)
            r = &cal->refs[k];
    if (!r)
        return gonio_err_set(err, GONIO_EBADCONFIG, "sample at (%g, %g) deg: no beam reading "
                             "at gain state %d", s->theta_i, s->theta_r, s->gain_state);
    const struct rad_dark *d = rad_find_dark(cal, r->integration_s, r->gain_state);
    if (!d)
        return gonio_err_set(err, GONIO_EBADCONFIG, "beam: no dark frame at integration %g s, "
                             "gain state %d", r->integration_s, r->gain_state);
    double m = mon ? r->monitor : r->integration_s;
    double geom = spot_factor(RAD_SPOT_UNDERFILLED, s->theta_i, s->theta_r) *
                  cal->beam.omega_sr / cal->beam.attenuation;
    for (int c = 0; c < 3; c++) {
        out->x[c] = rad_linearise(r->counts[c] - d->mean[c], s->nonlinearity, s->full_scale);
        out->stray_var[c] = 0.0;
        if (!(out->x[c] > 0.0))
            return gonio_err_set(err, GONIO_EBADDATA, "beam: channel %d reads %g counts, not "
                                 "above its dark %g", c, r->counts[c], d->mean[c]);
        out->k[c] = out->x[c] / m * geom;
    }
    out->ref = r;
    out->dark = d;
    return 0;
}

static int reduce_one(const struct rad_calibration *cal, const struct rad_raw *s,
                      struct rad_value *v, struct gonio_err *err)
{
    const struct rad_setup *su = &cal->setup;
    const struct rad_dark *ds = rad_find_dark(cal, s->integration_s, s->gain_state);
    if (!ds)
        return gonio_err_set(err, GONIO_EBADCONFIG, "sample at (%g, %g) deg: no dark frame at "
                             "integration %g s, gain state %d", s->theta_i, s->theta_r,
                             s->integration_s, s->gain_state);
    int mon = isfinite(s->monitor) && s->monitor > 0;
    for (size_t k = 0; mon && k < cal->n_refs; k++)
        mon = isfinite(cal->refs[k].monitor) && cal->refs[k].monitor > 0;
    for (size_t k = 0; mon && k < cal->n_strays; k++)
        mon = isfinite(cal->strays[k].monitor) && cal->strays[k].monitor > 0;
    struct response ref = {0};
    double stray[3], stray_var[3];
    const struct rad_beam *beam = &cal->beam;
    int rc = beam->on ? beam_at(cal, s, mon, &ref, err) : reference_at(cal, s, mon, &ref, err);
    if (rc < 0 || (rc = stray_at(cal, s, mon, s->theta_i, s->theta_r, stray, stray_var, err)) < 0)
        return rc;
    const struct rad_dark *dr = ref.dark;
    /* The absolute method has no standard: its "f_ref" is 1 everywhere. */
    double f[3] = {1, 1, 1}, fs_sl[2] = {0, 0};
    if (!beam->on) {
        brdf_standard_brdf(&cal->standard, s->theta_i, s->theta_r, f);
        standard_slopes(&cal->standard, ref.ref->theta_i, ref.ref->theta_r, fs_sl);
    }
    double m_s = mon ? s->monitor : s->integration_s;
    for (int c = 0; c < 3; c++) {
        if (s->full_scale > 0 && s->counts[c] >= s->full_scale) {
            v->brdf[c] = v->u[c] = v->snr[c] = NAN;
            for (int t = 0; t < RAD_N_TERMS; t++)
                v->rel[t][c] = NAN;
            continue;
        }
        /* The stray light's photons are counted with the sample's. */
        double x_all = rad_linearise(s->counts[c] - ds->mean[c], s->nonlinearity,
                                     s->full_scale);
        double x_s = x_all - m_s * stray[c];
        /* BRDF per linearised count */
        double A = f[c] / (ref.k[c] * (1.0 + s->drift_rel[c]) * m_s);
        double b = x_s * A;
        double g = su->adu_per_electron[c];
        double var_s = g * fmax(x_all, 0.0) + ds->sd[c] * ds->sd[c];
        double ab = fabs(b) > 0 ? fabs(b) : NAN;
        double r[RAD_N_TERMS] = {0};
        r[RAD_U_COUNTING] = A * sqrt(var_s) / ab;
        double xr = ref.x[c];
        if (ds == dr) {
            double dd = -A + b / xr;
            r[RAD_U_DARK] = fabs(dd) * ds->sd[c] / sqrt(ds->n) / ab;
        } else {
            double vs = A * A * ds->sd[c] * ds->sd[c] / ds->n;
            double vr = (b / xr) * (b / xr) * dr->sd[c] * dr->sd[c] / dr->n;
            r[RAD_U_DARK] = sqrt(vs + vr) / ab;
        }
        r[RAD_U_REFERENCE] = beam->on ? 0.0 : reference_rel_u(cal, c);
        r[RAD_U_SOLID_ANGLE] = beam->on ? beam->omega_rel_u : 0.0;
        r[RAD_U_ATTENUATOR] = beam->on ? beam->attenuation_rel_u : 0.0;
        r[RAD_U_REF_NOISE] = sqrt((g * xr + dr->sd[c] * dr->sd[c]) / ref.ref->n) / xr;
        double mvar = mon ? su->monitor_rel_sd * su->monitor_rel_sd * (1.0 + 1.0 / ref.ref->n)
                          : 0.0;
        r[RAD_U_DRIFT] = sqrt(mvar + su->drift_rel_u * su->drift_rel_u +
                              s->drift_u[c] * s->drift_u[c]);
        r[RAD_U_NONLINEARITY] = s->full_scale > 0 ? su->nonlinearity_rel_u * s->nonlinearity *
                                                        fabs(x_s - xr) / s->full_scale
                                                  : 0.0;
        r[RAD_U_ANGLE] = sqrt(angle_var(fs_sl, su->in_position_deg)); /* sample's: pass 2 */
        r[RAD_U_GEOMETRY] = su->geometry_rel_u;
        /* The sample's and the reference's stray estimates taken as
         * independent (they share readings only at a reference geometry,
         * where their errors partly cancel). */
        r[RAD_U_STRAY] = sqrt(m_s * m_s * stray_var[c] / (x_s * x_s) +
                              ref.stray_var[c] / (xr * xr));
        v->brdf[c] = b;
        v->snr[c] = x_s / sqrt(var_s);
        for (int t = 0; t < RAD_N_TERMS; t++)
            v->rel[t][c] = r[t];
    }
    return 0;
}

/* Neighbours further apart than this resolve no slope: a 12 deg wide lobe
 * read every 25 deg of incidence has no measured slope along theta_i. */
#define SLOPE_MAX_SPAN_DEG 12.0

/* The samples ordered by one angle, so that those sharing a sample's
 * angle are found by bisection: a pass over every sample for each of them
 * cost n^2, hours for an out-of-plane plan of 190,000 samples. */
struct by_angle {
    double angle;
    size_t k;
};

static int by_angle_cmp(const void *pa, const void *pb)
{
    const struct by_angle *a = pa, *b = pb;
    if (a->angle != b->angle)
        return isnan(a->angle) ? 1 : isnan(b->angle) ? -1 : a->angle < b->angle ? -1 : 1;
    return (a->k > b->k) - (a->k < b->k);
}

/* The samples' indices ordered by theta_i (theta_i 1) or theta_r into out[n]. */
static void order_by(const struct rad_raw *raw, size_t n, int theta_i, struct by_angle *out)
{
    for (size_t k = 0; k < n; k++)
        out[k] = (struct by_angle){theta_i ? raw[k].theta_i : raw[k].theta_r, k};
    qsort(out, n, sizeof *out, by_angle_cmp);
}

/* The first entry of by[n] whose angle is not below x. */
static size_t first_from(const struct by_angle *by, size_t n, double x)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (by[mid].angle < x)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

/* ln BRDF's slope along one angle at sample k from its nearest neighbours
 * on either side with the other angle equal (one-sided at an edge; of
 * neighbours at one angle, the first in the samples' order). across: the
 * samples ordered by that other angle. NAN when no neighbour lies within
 * SLOPE_MAX_SPAN_DEG. */
static double neighbour_slope(const struct rad_raw *raw, const struct rad_value *v, size_t n,
                              const struct by_angle *across, size_t k, int c, int along_r)
{
#define ALONG(j) (along_r ? raw[j].theta_r : raw[j].theta_i)
#define ACROSS(j) (along_r ? raw[j].theta_i : raw[j].theta_r)
    double x0 = ALONG(k);
    long lo = -1, hi = -1;
    /* wider than the tolerance: the test below decides, as it always has */
    for (size_t q = first_from(across, n, ACROSS(k) - 2 * GEOM_TOL_DEG);
         q < n && across[q].angle <= ACROSS(k) + 2 * GEOM_TOL_DEG; q++) {
        size_t j = across[q].k;
        if (j == k || fabs(ACROSS(j) - ACROSS(k)) > GEOM_TOL_DEG || !(v[j].brdf[c] > 0))
            continue;
        double x = ALONG(j);
        if (x < x0 - GEOM_TOL_DEG && x >= x0 - SLOPE_MAX_SPAN_DEG &&
            (lo < 0 || x > ALONG(lo) || (x == ALONG(lo) && (long)j < lo)))
            lo = (long)j;
        if (x > x0 + GEOM_TOL_DEG && x <= x0 + SLOPE_MAX_SPAN_DEG &&
            (hi < 0 || x < ALONG(hi) || (x == ALONG(hi) && (long)j < hi)))
            hi = (long)j;
    }
    long a = lo >= 0 ? lo : (long)k, b = hi >= 0 ? hi : (long)k;
    if (a == b || !(v[a].brdf[c] > 0) || !(v[b].brdf[c] > 0))
        return NAN;
    return log(v[b].brdf[c] / v[a].brdf[c]) / (ALONG(b) - ALONG(a));
#undef ALONG
#undef ACROSS
}

/* The sample's slopes along theta_i and theta_r. Where the capture does
 * not resolve the slope along theta_i, it is taken as a mirror lobe's,
 * -d/dtheta_r (a lobe that follows theta_r - theta_i): the larger of the
 * two usual cases, a diffuse material's 0 being the other. by_i, by_r: the
 * samples ordered by theta_i and by theta_r. */
static void sample_slopes(const struct rad_raw *raw, const struct rad_value *v, size_t n,
                          const struct by_angle *by_i, const struct by_angle *by_r, size_t k,
                          int c, double sl[2])
{
    double dr = neighbour_slope(raw, v, n, by_i, k, c, 1);
    double di = neighbour_slope(raw, v, n, by_r, k, c, 0);
    if (isnan(dr))
        dr = 0.0; /* a lone point along theta_r: nothing measured to go by */
    sl[0] = isnan(di) ? -dr : di;
    sl[1] = dr;
}

int rad_reduce(const struct rad_calibration *cal, const struct rad_raw *raw, size_t n,
               struct rad_value *out, struct gonio_err *err)
{
    for (size_t k = 0; k < n; k++) {
        int rc = reduce_one(cal, &raw[k], &out[k], err);
        if (rc < 0)
            return rc;
    }
    struct by_angle *by_i = malloc((n ? n : 1) * sizeof *by_i);
    struct by_angle *by_r = malloc((n ? n : 1) * sizeof *by_r);
    if (!by_i || !by_r) {
        free(by_i);
        free(by_r);
        return gonio_err_set(err, ENOMEM, "reduce: out of memory ordering %zu samples", n);
    }
    order_by(raw, n, 1, by_i);
    order_by(raw, n, 0, by_r);
    for (size_t k = 0; k < n; k++)
        for (int c = 0; c < 3; c++) {
            struct rad_value *v = &out[k];
            if (!isfinite(v->brdf[c]))
                continue;
            double sl[2];
            sample_slopes(raw, out, n, by_i, by_r, k, c, sl);
            double ref_a = v->rel[RAD_U_ANGLE][c];
            v->rel[RAD_U_ANGLE][c] =
                sqrt(ref_a * ref_a + angle_var(sl, cal->setup.in_position_deg));
            double sum = 0;
            for (int t = 0; t < RAD_N_TERMS; t++)
                sum += v->rel[t][c] * v->rel[t][c];
            v->u[c] = fabs(v->brdf[c]) * sqrt(sum);
        }
    free(by_i);
    free(by_r);
    return 0;
}
