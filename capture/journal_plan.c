#include "capture/journal_plan.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <jansson.h>

/* Rounding in the angles' arithmetic: far below any band (0.001 deg at least). */
#define ANGLE_EPS 1e-9

static const struct plan_point *point_at(const struct journal_plan *p, size_t i)
{
    return p->plan ? plan_point(p->plan, i) : &p->points[i];
}

/* The azimuth a record's phi_o says the axis was at (capture.c's mapping:
 * phi_o = az + 180 on the mirror side, az on the source side). */
static double recorded_azimuth(const struct journal_sample *s)
{
    return s->phi_o - (s->theta_r >= 0 ? 180.0 : 0.0);
}

/* Degrees between two azimuths, the short way round. */
static double azimuth_apart(double a, double b)
{
    double d = fmod(fabs(a - b), 360.0);
    return d > 180.0 ? 360.0 - d : d;
}

/* Why record s cannot be a measurement of pt, or NULL. */
static const char *mismatch(const struct journal_sample *s, const struct plan_point *pt,
                            double band, char *why, size_t size)
{
    double ti, tr;
    brdf_axes_to_inplane(s->s, s->a, &ti, &tr);
    if (fabs(s->s - pt->ax.s) > band + ANGLE_EPS || fabs(s->a - pt->ax.a) > band + ANGLE_EPS)
        snprintf(why, size,
                 "point %d measured at axes s %g, a %g; the plan puts it at s %g, a %g "
                 "(theta_i %g, theta_r %g), in-position band %g deg",
                 s->point, s->s, s->a, pt->ax.s, pt->ax.a, pt->theta_i, pt->theta_r, band);
    else if (fabs(s->theta_i - ti) > ANGLE_EPS || fabs(s->theta_r - tr) > ANGLE_EPS ||
             fabs(s->theta_o - fabs(tr)) > ANGLE_EPS || s->phi_i != 0.0)
        snprintf(why, size,
                 "angles theta_i %g, theta_r %g, theta_o %g, phi_i %g are not the ones its "
                 "axes give (s %g, a %g: theta_i %g, theta_r %g, theta_o %g, phi_i 0)",
                 s->theta_i, s->theta_r, s->theta_o, s->phi_i, s->s, s->a, ti, tr, fabs(tr));
    else if (azimuth_apart(recorded_azimuth(s), pt->ax.az) > band + ANGLE_EPS)
        snprintf(why, size,
                 "point %d measured at azimuth %g (phi_o %g); the plan puts it at %g, "
                 "in-position band %g deg",
                 s->point, recorded_azimuth(s), s->phi_o, pt->ax.az, band);
    else
        return NULL;
    return why;
}

int journal_plan_check(const char *path, const struct journal_sample *s, size_t n,
                       const struct journal_plan *plan, double band_deg, struct gonio_err *err)
{
    /* first[k]: the line that journalled point k, 0 while none has. */
    uint32_t *first = plan->count ? calloc(plan->count, sizeof *first) : NULL;
    if (plan->count && !first)
        return gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    int rc = 0;
    char why[400];
    for (size_t i = 0; i < n && rc == 0; i++) {
        size_t line = i + 2; /* the header is line 1 */
        size_t k = (size_t)s[i].point; /* journal_read refused negative points */
        if (s[i].point < 0 || k >= plan->count)
            rc = gonio_err_set(err, GONIO_EBADDATA,
                               "%s:%zu: point %d is not in the plan (it has %zu points)", path,
                               line, s[i].point, plan->count);
        else if (first[k])
            rc = gonio_err_set(err, GONIO_EBADDATA,
                               "%s:%zu: point %d journalled again (first at line %u)", path,
                               line, s[i].point, first[k]);
        else if (mismatch(&s[i], point_at(plan, k), band_deg, why, sizeof why))
            rc = gonio_err_set(err, GONIO_EBADDATA, "%s:%zu: %s", path, line, why);
        else if (!(s[i].flags & JOURNAL_FLAG_DARK)) /* a dark frame names its sample's point */
            first[k] = (uint32_t)line;
    }
    free(first);
    return rc;
}

/* One pair of plan.json: the in-plane form {theta_i, theta_r, s, a} or the
 * general one {theta_i, phi_i, theta_o, phi_o, s, a, az}. */
static int read_pair(const char *file, size_t i, json_t *pair, struct plan_point *pt,
                     struct gonio_err *err)
{
    static const char *const inplane[] = {"theta_i", "theta_r", "s", "a"};
    static const char *const general[] = {"theta_i", "phi_i", "theta_o", "phi_o",
                                          "s",       "a",     "az"};
    int oop = json_object_get(pair, "az") != NULL;
    const char *const *keys = oop ? general : inplane;
    size_t nkeys = oop ? 7 : 4;
    double v[7];
    for (size_t k = 0; k < nkeys; k++) {
        json_t *x = json_object_get(pair, keys[k]);
        if (!json_is_number(x) || !isfinite(json_number_value(x)))
            return gonio_err_set(err, GONIO_EBADDATA, "%s: pairs[%zu]: '%s' %s", file, i,
                                 keys[k], x ? "is not a finite number" : "is missing");
        v[k] = json_number_value(x);
    }
    memset(pt, 0, sizeof *pt);
    pt->theta_i = v[0];
    pt->out_of_plane = oop;
    if (oop) {
        pt->phi_i = v[1];
        pt->theta_o = v[2];
        pt->phi_o = v[3];
        pt->ax = (struct rig_axes){v[4], v[5], v[6]};
    } else {
        pt->theta_r = v[1];
        pt->theta_o = fabs(v[1]);
        pt->phi_o = v[1] >= 0 ? 180.0 : 0.0;
        pt->ax = (struct rig_axes){v[2], v[3], 0.0};
    }
    return 0;
}

int journal_plan_read(const char *plan_json, struct plan_point **points, size_t *count,
                      struct gonio_err *err)
{
    *points = NULL;
    *count = 0;
    if (access(plan_json, R_OK) != 0)
        return gonio_err_set(err, errno == ENOENT ? GONIO_ENOTFOUND : errno, "%s: %s", plan_json,
                             strerror(errno));
    json_error_t je;
    json_t *root = json_load_file(plan_json, 0, &je);
    if (!root)
        return gonio_err_set(err, GONIO_EBADDATA, "%s:%d:%d: %s", plan_json, je.line, je.column,
                             je.text);
    json_t *pairs = json_object_get(root, "pairs");
    size_t n = json_array_size(pairs);
    int rc = 0;
    if (!json_is_array(pairs) || n == 0)
        rc = gonio_err_set(err, GONIO_EBADDATA, "%s: 'pairs' is not a list of pairs", plan_json);
    else if (!(*points = calloc(n, sizeof **points)))
        rc = gonio_err_set(err, ENOMEM, "%s: out of memory", plan_json);
    for (size_t i = 0; rc == 0 && i < n; i++)
        rc = read_pair(plan_json, i, json_array_get(pairs, i), &(*points)[i], err);
    json_decref(root);
    if (rc < 0) {
        free(*points);
        *points = NULL;
        return rc;
    }
    *count = n;
    return 0;
}
