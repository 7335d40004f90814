/* The budget table a calibrated capture reports in results.json
 * (capture/calibration.h). */
#include "capture/calibration.h"

#include "capture/calibration_bands.h"

#include <math.h>
#include <stdlib.h>

#include <jansson.h>

static int by_value(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Median of the finite values of column (term t, channel c); t = -1: the
 * combined relative u. NAN when there is none. */
static double median(const struct rad_value *v, size_t n, int t, int c, double *buf)
{
    size_t m = 0;
    for (size_t k = 0; k < n; k++) {
        double x = t < 0 ? v[k].u[c] / fabs(v[k].brdf[c]) : v[k].rel[t][c];
        if (isfinite(x))
            buf[m++] = x;
    }
    if (!m)
        return NAN;
    qsort(buf, m, sizeof *buf, by_value);
    return m % 2 ? buf[m / 2] : 0.5 * (buf[m / 2 - 1] + buf[m / 2]);
}

static json_t *row(const struct rad_value *v, size_t n, int t, double *buf)
{
    json_t *r = json_array();
    for (int c = 0; c < 3; c++) {
        double x = median(v, n, t, c, buf);
        json_array_append_new(r, isfinite(x) ? json_real(x) : json_null());
    }
    return r;
}

/* Each band's drift ratio: {"nm": [...], "ratio": [...], "ratio_relative_u": [...]}. */
static json_t *band_drift(const struct cal_bands *b)
{
    json_t *nm = json_array(), *q = json_array(), *u = json_array();
    for (int k = 0; k < b->n_bands; k++) {
        const struct cal_drift *d = &b->group[k / 3].drift;
        json_array_append_new(nm, json_real(b->nm[k]));
        json_array_append_new(q, json_real(d->q[k % 3]));
        json_array_append_new(u, json_real(d->u_q[k % 3]));
    }
    return json_pack("{s:o, s:o, s:o}", "nm", nm, "ratio", q, "ratio_relative_u", u);
}

struct json_t *cal_budget_json(const struct cal_loaded *cl, const struct rad_value *v, size_t n)
{
    double *buf = malloc((n ? n : 1) * sizeof *buf);
    json_t *terms = json_array(), *j = json_object();
    if (!buf || !terms || !j) {
        free(buf);
        json_decref(terms);
        json_decref(j);
        return NULL;
    }
    for (int t = 0; t < RAD_N_TERMS; t++)
        json_array_append_new(terms, json_pack("{s:s, s:s, s:o}", "term",
                                               rad_term_name((enum rad_term)t), "kind",
                                               rad_term_systematic((enum rad_term)t)
                                                   ? "systematic" : "per sample",
                                               "median_relative_u", row(v, n, t, buf)));
    json_object_set_new(j, "id", json_string(cl->meta.id));
    json_object_set_new(j, "dark", json_string(cl->meta.dark));
    json_object_set_new(j, "standard", json_string(cl->cal.standard.name));
    if (cl->cal.standard.warning[0])
        json_object_set_new(j, "warning", json_string(cl->cal.standard.warning));
    json_object_set_new(j, "budget", terms);
    const struct cal_drift *d = &cl->drift;
    if (d->on) /* the drift the standard read again after the capture showed */
        json_object_set_new(j, "reference_after",
                            json_pack("{s:[f,f,f], s:[f,f,f], s:f, s:I, s:I}", "ratio", d->q[0],
                                      d->q[1], d->q[2], "ratio_relative_u", d->u_q[0],
                                      d->u_q[1], d->u_q[2], "rig_time_s", d->t_end_s,
                                      "geometries", (json_int_t)d->geometries, "readings",
                                      (json_int_t)d->frames));
    if (d->on && cl->bands && cl->bands->group[0].drift.on)
        json_object_set_new(json_object_get(j, "reference_after"), "bands", band_drift(cl->bands));
    json_object_set_new(j, "combined_median_relative_u", row(v, n, -1, buf));
    free(buf);
    return j;
}
