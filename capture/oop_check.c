/* The in-plane sufficiency check (capture/oop_check.h): pair choice from
 * the fitted model, the measurement sequence and the verdict. */
#include "capture/oop_check.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define MAX_THETA_DEG 80.0  /* the reference domains' horizon (brdf/domain.h) */
#define STEP_DEG 0.25       /* the tilt search's step */
#define MAX_TILT_DEG 30.0   /* the flank searched no further */
#define DIFFUSE_TILT_DEG 20.0 /* a lobe that never falls by OOP_CHECK_DROP: off it here */

/* The model's value, the mean of R, G, B: the verdict's figure. */
static double predict_mean(oop_check_predict_fn predict, void *user, const struct brdf_pair *p)
{
    double rgb[3];
    predict(user, p, rgb);
    return (rgb[0] + rgb[1] + rgb[2]) / 3.0;
}

static const double incidence_deg[OOP_CHECK_INCIDENCES] = {25, 45};
static const double azimuth_deg[OOP_CHECK_AZIMUTHS] = {45, 90, 135};

/* The pair with the source at theta_i in the plane and the half vector
 * tilted tilt from the normal at azimuth psi from the plane; 0, or -1 when
 * it or its in-plane counterpart leaves the domain. */
static int build(double theta_i, double tilt, double psi, struct oop_check_pair *o,
                 struct brdf_pair *bp, struct brdf_pair *in)
{
    double ti = theta_i * BRDF_DEG, th = tilt * BRDF_DEG, ps = psi * BRDF_DEG;
    double wi[3] = {sin(ti), 0, cos(ti)};
    double h[3] = {sin(th) * cos(ps), sin(th) * sin(ps), cos(th)};
    double c = wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2];
    double wo[3] = {2 * c * h[0] - wi[0], 2 * c * h[1] - wi[1], 2 * c * h[2] - wi[2]};
    if (c <= 0 || wo[2] < cos(MAX_THETA_DEG * BRDF_DEG))
        return -1;
    o->theta_i = theta_i;
    o->theta_o = acos(fmin(1.0, wo[2])) / BRDF_DEG;
    o->phi_o = atan2(wo[1], wo[0]) / BRDF_DEG;
    brdf_pair_spherical(o->theta_i, 0, o->theta_o, o->phi_o, bp);
    /* in the plane, theta_i = theta_d + theta_h and theta_r = theta_d - theta_h */
    double hd = bp->theta_h / BRDF_DEG, dd = bp->theta_d / BRDF_DEG;
    o->in_theta_i = dd + hd;
    o->in_theta_r = dd - hd;
    if (o->in_theta_i > MAX_THETA_DEG)
        return -1;
    brdf_pair_inplane(o->in_theta_i, o->in_theta_r, in);
    return 0;
}

/* Where between tilt hi - STEP_DEG and hi the model, at theta_i and
 * azimuth psi, falls by OOP_CHECK_DROP from top (its ln f at the mirror):
 * the lobe's width, finer than the search's step (a spike the data never
 * resolved falls within hundredths of a degree). */
static double crossing(oop_check_predict_fn predict, void *user, double theta_i, double psi,
                       double top, double hi)
{
    double lo = hi - STEP_DEG;
    for (int k = 0; k < 30; k++) {
        double mid = 0.5 * (lo + hi), v = 0;
        struct oop_check_pair c;
        struct brdf_pair bp, in;
        if (build(theta_i, mid, psi, &c, &bp, &in) == 0)
            v = predict_mean(predict, user, &bp);
        if (v > 0 && top - log(v) < OOP_CHECK_DROP)
            lo = mid;
        else
            hi = mid;
    }
    return 0.5 * (lo + hi);
}

/* The pair on the lobe's flank at theta_i, azimuth psi: the first tilt
 * where the model has fallen OOP_CHECK_DROP below the mirror, else the
 * diffuse tilt (or the last one in the domain). 0, or -1: none. */
static int flank(oop_check_predict_fn predict, void *user, double theta_i, double psi,
                 struct oop_check_pair *o)
{
    struct brdf_pair bp, in;
    if (build(theta_i, 0, psi, o, &bp, &in) < 0)
        return -1;
    double top = log(predict_mean(predict, user, &bp));
    int found = 0, steps = 0;
    struct oop_check_pair last = *o, at_diffuse = *o;
    double t = STEP_DEG;
    for (; t <= MAX_TILT_DEG + 1e-9; t += STEP_DEG) {
        struct oop_check_pair c;
        if (build(theta_i, t, psi, &c, &bp, &in) < 0)
            break;
        double v = predict_mean(predict, user, &bp);
        c.predicted = v;
        c.in_predicted = predict_mean(predict, user, &in);
        last = c;
        steps++;
        if (t <= DIFFUSE_TILT_DEG + 1e-9)
            at_diffuse = c;
        if (isfinite(top) && v > 0 && top - log(v) >= OOP_CHECK_DROP) {
            found = 1;
            break;
        }
    }
    *o = found ? last : at_diffuse;
    o->lobe_deg = found ? crossing(predict, user, theta_i, psi, top, t) : NAN;
    return steps > 0 ? 0 : -1;
}

size_t oop_check_choose(oop_check_predict_fn predict, void *user, struct oop_check_pair *out)
{
    size_t m = 0;
    for (int i = 0; i < OOP_CHECK_INCIDENCES; i++)
        for (int k = 0; k < OOP_CHECK_AZIMUTHS; k++)
            if (flank(predict, user, incidence_deg[i], azimuth_deg[k], &out[m]) == 0)
                m++;
    return m;
}

/* The full-domain log error's term for one reading (brdf/metrics.c): the
 * log of 1 + f cos theta_i, which weighs the lobe as the domain error does. */
double oop_check_error(double measured, double predicted, double theta_i)
{
    double w = cos(theta_i * BRDF_DEG);
    return fabs(log1p(measured * w) - log1p(predicted * w));
}

/* The widest lobe of the pairs (NAN when one never fell: a lobe wide
 * enough for any rig). */
static double widest_lobe(const struct oop_check_pair *p, size_t n)
{
    double w = n ? 0 : NAN;
    for (size_t j = 0; j < n; j++) {
        if (isnan(p[j].lobe_deg))
            return NAN;
        w = fmax(w, p[j].lobe_deg);
    }
    return w;
}

/* The verdict from the model alone: a lobe narrower than the rig positions. */
static void decide_unresolved(struct oop_check_result *out)
{
    out->unresolved = 1;
    snprintf(out->verdict, sizeof out->verdict, "insufficient");
    snprintf(out->why, sizeof out->why,
             "the fitted lobe falls by e^-%.1f within %.3f deg of the mirror, inside the rig's "
             "positioning (%.2f deg): no in-plane pair resolved its core",
             OOP_CHECK_DROP, out->lobe_deg, out->resolution_deg);
}

void oop_check_decide(const struct oop_check_pair *p, size_t n, const double *measured,
                      const double *in_measured, double resolution_deg,
                      struct oop_check_result *out)
{
    memset(out, 0, sizeof *out);
    out->pairs = n;
    out->threshold = OOP_CHECK_RATIO;
    out->resolution_deg = resolution_deg;
    out->lobe_deg = widest_lobe(p, n);
    /* NAN compares false: a lobe that never fell is resolved */
    int unresolved = resolution_deg > 0 && out->lobe_deg < resolution_deg;
    double so = 0, si = 0;
    size_t used = 0;
    for (size_t j = 0; j < n; j++) {
        out->measurements += (measured[j] > 0) + (in_measured[j] > 0);
        if (!(measured[j] > 0) || !(in_measured[j] > 0) || !(p[j].predicted > 0) ||
            !(p[j].in_predicted > 0))
            continue;
        double e = oop_check_error(measured[j], p[j].predicted, p[j].theta_i);
        so += e;
        si += oop_check_error(in_measured[j], p[j].in_predicted, p[j].in_theta_i);
        used++;
        if (e >= out->worst_error) {
            out->worst_error = e;
            out->worst = p[j];
        }
    }
    if (used < 3) {
        out->error_oop = out->error_inplane = out->ratio = NAN;
        if (unresolved) {
            decide_unresolved(out);
            return;
        }
        snprintf(out->verdict, sizeof out->verdict, "undetermined");
        snprintf(out->why, sizeof out->why,
                 "too few usable pairs (%zu of %zu with both readings; need 3)", used, n);
        return;
    }
    out->error_oop = so / (double)used;
    out->error_inplane = si / (double)used;
    out->ratio = out->error_oop / fmax(out->error_inplane, OOP_CHECK_FLOOR);
    if (unresolved) {
        decide_unresolved(out);
        return;
    }
    int bad = out->ratio > OOP_CHECK_RATIO;
    snprintf(out->verdict, sizeof out->verdict, bad ? "insufficient" : "sufficient");
    snprintf(out->why, sizeof out->why,
             "out-of-plane error %.3f against %.3f in the plane: %.2fx, %s %.1fx",
             out->error_oop, out->error_inplane, out->ratio, bad ? "beyond" : "within",
             OOP_CHECK_RATIO);
    if (bad) {
        size_t len = strlen(out->why);
        snprintf(out->why + len, sizeof out->why - len, " (worst at %.0f, %.1f/%.0f)",
                 out->worst.theta_i, out->worst.theta_o, out->worst.phi_o);
    }
}

/* A reading's mean of R, G, B: the verdict's figure. */
static int measure_mean(oop_check_measure_fn measure, void *user, const struct oop_check_pair *p,
                        int in_plane, double *value, struct gonio_err *err)
{
    double rgb[3];
    int rc = measure(user, p, in_plane, rgb, err);
    *value = (rgb[0] + rgb[1] + rgb[2]) / 3.0;
    return rc;
}

int oop_check_run(oop_check_predict_fn predict, void *puser, oop_check_measure_fn measure,
                  void *muser, double resolution_deg, struct oop_check_result *out,
                  struct gonio_err *err)
{
    struct oop_check_pair p[OOP_CHECK_MAX_PAIRS];
    double m[OOP_CHECK_MAX_PAIRS], in[OOP_CHECK_MAX_PAIRS];
    size_t n = oop_check_choose(predict, puser, p);
    /* each incidence's out-of-plane pairs, then their counterparts back
     * the way the arm came: the sample axis moves twice per incidence */
    for (size_t a = 0; a < n;) {
        size_t b = a;
        while (b < n && p[b].theta_i == p[a].theta_i)
            b++;
        for (size_t j = a; j < b; j++) {
            int rc = measure_mean(measure, muser, &p[j], 0, &m[j], err);
            if (rc < 0)
                return rc;
        }
        for (size_t j = b; j-- > a;) {
            int rc = measure_mean(measure, muser, &p[j], 1, &in[j], err);
            if (rc < 0)
                return rc;
        }
        a = b;
    }
    oop_check_decide(p, n, m, in, resolution_deg, out);
    return 0;
}
