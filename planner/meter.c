#include "planner/meter.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

#include "brdf/angles.h"

struct plan_meter {
    const struct rig_profile *rig;
    size_t n;
    double (*dir)[6];  /* point i's wi and wo */
    double *expected;  /* the host's expectation at i (the fixed integration: none) */
    int has_expected;
    double *observed;  /* the integration measured at i, NAN where not measured */
    long *nearest;     /* the observed point nearest i, -1: none yet */
    double *near_d;    /* its chordal distance */
};

static void point_dir(const struct plan_point *pt, double d[6])
{
    struct brdf_pair p;
    if (pt->out_of_plane)
        brdf_pair_spherical(pt->theta_i, pt->phi_i, pt->theta_o, pt->phi_o, &p);
    else
        brdf_pair_inplane(pt->theta_i, pt->theta_r, &p);
    for (int k = 0; k < 3; k++) {
        d[k] = p.wi[k];
        d[3 + k] = p.wo[k];
    }
}

plan_meter *plan_meter_new(const struct plan *plan, const struct rig_profile *rig,
                           const double *expected_s, struct gonio_err *err)
{
    size_t n = plan_count(plan);
    plan_meter *m = calloc(1, sizeof *m);
    size_t k = n ? n : 1;
    if (m) {
        m->dir = malloc(k * sizeof *m->dir);
        m->expected = malloc(k * sizeof *m->expected);
        m->observed = malloc(k * sizeof *m->observed);
        m->nearest = malloc(k * sizeof *m->nearest);
        m->near_d = malloc(k * sizeof *m->near_d);
    }
    if (!m || !m->dir || !m->expected || !m->observed || !m->nearest || !m->near_d) {
        plan_meter_free(m);
        gonio_err_set(err, ENOMEM, "integration meter: out of memory");
        return NULL;
    }
    m->rig = rig;
    m->n = n;
    m->has_expected = expected_s != NULL;
    for (size_t i = 0; i < n; i++) {
        point_dir(plan_point(plan, i), m->dir[i]);
        m->expected[i] = expected_s ? expected_s[i] : rig->integration_s;
        m->observed[i] = NAN;
        m->nearest[i] = -1;
        m->near_d[i] = INFINITY;
    }
    return m;
}

void plan_meter_free(plan_meter *m)
{
    if (!m)
        return;
    free(m->dir);
    free(m->expected);
    free(m->observed);
    free(m->nearest);
    free(m->near_d);
    free(m);
}

/* Chordal distance of two pairs: cheap, and as good as the angle for
 * nearest neighbours. */
static double chord(const double a[6], const double b[6])
{
    double s = 0;
    for (int k = 0; k < 3; k++) /* wi and wo together: the adaptive policy's sums, bit for bit */
        s += (a[k] - b[k]) * (a[k] - b[k]) + (a[3 + k] - b[3 + k]) * (a[3 + k] - b[3 + k]);
    return sqrt(s);
}

void plan_meter_observe(plan_meter *m, size_t point, double integration_s)
{
    if (point >= m->n)
        return;
    m->observed[point] = integration_s;
    for (size_t i = 0; i < m->n; i++) {
        double d = chord(m->dir[i], m->dir[point]);
        if (d < m->near_d[i]) {
            m->near_d[i] = d;
            m->nearest[i] = (long)point;
        }
    }
}

double plan_meter_integration(const plan_meter *m, size_t i)
{
    if (i >= m->n)
        return m->rig->integration_s;
    long j = m->nearest[i];
    if (j < 0)
        return m->expected[i];
    if (m->has_expected && m->expected[j] > 0)
        return m->expected[i] * m->observed[j] / m->expected[j];
    return fmax(m->rig->integration_s, m->observed[j]);
}

long plan_meter_nearest(const plan_meter *m, size_t i)
{
    return i < m->n ? m->nearest[i] : -1;
}
