/* The full-domain error's estimate (capture/oop_estimate.h): the draw of
 * the MERL grid's nodes in proportion to the model's brightness, the
 * weighted mean and its interval. */
#include "capture/oop_estimate.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/domain.h"
#include "capture/oop_check.h"

#define GOLDEN 0.61803398874989484820 /* the golden ratio's fraction: the strata's offsets */
#define N_HD BRDF_DOMAIN_N_HD         /* theta_h's and theta_d's nodes (brdf/domain.h) */
#define N_PD 180                      /* phi_d's */
#define PD_STEP 10                    /* phi_d's nodes the draw takes: every tenth */

/* The node turned about the normal so that its source is in the plane. */
static void source_in_plane(const struct brdf_pair *bp, struct oop_estimate_node *o,
                            struct brdf_pair *placed)
{
    double phi_i = atan2(bp->wi[1], bp->wi[0]) / BRDF_DEG;
    memset(o, 0, sizeof *o);
    o->theta_i = brdf_pair_theta_i_deg(bp);
    o->theta_o = brdf_pair_theta_o_deg(bp);
    o->phi_o = remainder(atan2(bp->wo[1], bp->wo[0]) / BRDF_DEG - phi_i, 360.0);
    brdf_pair_spherical(o->theta_i, 0, o->theta_o, o->phi_o, placed);
}

/* The draw's density at a node where the model predicts rgb: the share of
 * ln(1 + v cos theta_i) a relative error moves, d/dv of the error term
 * times v, for the channels' mean v, plus a floor so that the dark domain
 * is not left out. */
static double density(const double rgb[3], double theta_i)
{
    double vw = fmax((rgb[0] + rgb[1] + rgb[2]) / 3.0, 0.0) * cos(theta_i * BRDF_DEG);
    return vw / (1 + vw) + OOP_ESTIMATE_FLOOR;
}

/* Walk the draw's nodes (every PD_STEP-th phi_d of every kept (theta_h,
 * theta_d)), in the domain's order; with targets, stop at each node where
 * the running density passes the next target and fill out[] in turn.
 * Returns the total density and the node count in *nodes. */
static double walk(oop_estimate_predict_fn predict, void *user, const double *target,
                   size_t n_target, struct oop_estimate_node *out, size_t *nodes)
{
    double total = 0;
    size_t next = 0;
    *nodes = 0;
    for (int i = 0; i < N_HD; i++) {
        double u = i / (double)N_HD, th = u * u * (90 * BRDF_DEG);
        for (int j = 0; j < N_HD; j++)
            for (int k = PD_STEP / 2; k < N_PD; k += PD_STEP) {
                struct brdf_pair bp, placed;
                struct oop_estimate_node o;
                brdf_pair_from_hd(th, j * BRDF_DEG, k / (double)N_PD * (180 * BRDF_DEG), &bp);
                if (!brdf_domain_keeps(&bp))
                    continue;
                source_in_plane(&bp, &o, &placed);
                predict(user, &placed, o.predicted);
                o.density = density(o.predicted, o.theta_i);
                total += o.density;
                ++*nodes;
                while (next < n_target && total > target[next])
                    out[next++] = o;
            }
    }
    return total;
}

size_t oop_estimate_choose(oop_estimate_predict_fn predict, void *user,
                           struct oop_estimate_node *out, double *mean_density)
{
    size_t nodes;
    double total = walk(predict, user, NULL, 0, NULL, &nodes), target[OOP_ESTIMATE_PAIRS];
    if (!(total > 0))
        return 0;
    for (size_t s = 0; s < OOP_ESTIMATE_PAIRS; s++) /* stratum s, the golden sequence's place */
        target[s] = ((double)s + fmod(0.5 + GOLDEN * (double)s, 1.0)) / OOP_ESTIMATE_PAIRS * total;
    walk(predict, user, target, OOP_ESTIMATE_PAIRS, out, &nodes);
    *mean_density = total / (double)nodes;
    return OOP_ESTIMATE_PAIRS;
}

double oop_estimate_error(const double measured[3], const double predicted[3], double theta_i)
{
    double w = cos(theta_i * BRDF_DEG), sum = 0, light = 0;
    for (int c = 0; c < 3; c++) {
        if (!isfinite(measured[c]) || !isfinite(predicted[c]))
            return NAN;
        double m = fmax(measured[c], 0.0);
        light += m;
        sum += fabs(log1p(m * w) - log1p(fmax(predicted[c], 0.0) * w));
    }
    return light > 0 ? sum / 3 : NAN;
}

/* Student's t, two-sided 95%, of df degrees of freedom (1 to the pairs
 * of strata there are). */
static const double student_t95[] = {12.706, 4.303, 3.182, 2.776, 2.571, 2.447};
_Static_assert(OOP_ESTIMATE_PAIRS / 2 <= sizeof student_t95 / sizeof *student_t95,
               "a t quantile for every pair of strata");

void oop_estimate_decide(const struct oop_estimate_node *p, size_t n, const double (*measured)[3],
                         double mean_density, struct oop_estimate *out)
{
    memset(out, 0, sizeof *out);
    out->pairs = n;
    out->error = out->low = out->high = NAN;
    double r[OOP_ESTIMATE_PAIRS]; /* each node's error over its density */
    size_t m = 0;
    for (size_t j = 0; j < n && m < OOP_ESTIMATE_PAIRS; j++) {
        double e = oop_estimate_error(measured[j], p[j].predicted, p[j].theta_i);
        if (!isnan(e) && p[j].density > 0)
            r[m++] = e / p[j].density;
    }
    out->used = m;
    if (m < OOP_ESTIMATE_MIN_USED)
        return;
    double sum = 0, ss = 0;
    for (size_t j = 0; j < m; j++)
        sum += r[j];
    /* collapsed strata: neighbours (2k, 2k+1) differ by the spread within
     * the pair of strata; an odd one out adds nothing to it */
    for (size_t k = 0; k + 1 < m; k += 2)
        ss += (r[k] - r[k + 1]) * (r[k] - r[k + 1]);
    double se = sqrt(ss / (double)(2 * (m / 2)) / (double)m), t = student_t95[m / 2 - 1];
    out->error = mean_density * sum / (double)m;
    out->low = mean_density * fmax(0.0, sum / (double)m - t * se);
    out->high = mean_density * (sum / (double)m + t * se);
}

/* The nodes' travel order: by theta_i in bands of TRAVEL_BAND_DEG (the
 * sample axis), phi_o rising in one band and falling in the next (the
 * azimuth axis snakes). */
#define TRAVEL_BAND_DEG 15.0
static const struct oop_estimate_node *sort_base;
static int by_travel(const void *a, const void *b)
{
    const struct oop_estimate_node *p = &sort_base[*(const size_t *)a];
    const struct oop_estimate_node *q = &sort_base[*(const size_t *)b];
    int bp = (int)(p->theta_i / TRAVEL_BAND_DEG), bq = (int)(q->theta_i / TRAVEL_BAND_DEG);
    if (bp != bq)
        return bp < bq ? -1 : 1;
    double d = (bp % 2 ? -1 : 1) * (p->phi_o - q->phi_o);
    return d < 0 ? -1 : d > 0;
}

int oop_estimate_run(oop_estimate_predict_fn predict, void *puser,
                     int (*measure)(void *user, const struct oop_check_pair *p, int in_plane,
                                    double rgb[3], struct gonio_err *err),
                     void *muser, struct oop_estimate *out, struct gonio_err *err)
{
    struct oop_estimate_node d[OOP_ESTIMATE_PAIRS];
    double m[OOP_ESTIMATE_PAIRS][3], mean_density = 0;
    size_t order[OOP_ESTIMATE_PAIRS];
    size_t n = oop_estimate_choose(predict, puser, d, &mean_density);
    for (size_t j = 0; j < n; j++)
        order[j] = j;
    sort_base = d;
    qsort(order, n, sizeof *order, by_travel);
    for (size_t j = 0; j < n; j++) {
        const struct oop_estimate_node *o = &d[order[j]];
        struct oop_check_pair at = {.theta_i = o->theta_i, .theta_o = o->theta_o,
                                    .phi_o = o->phi_o, .in_theta_i = NAN, .in_theta_r = NAN,
                                    .lobe_deg = NAN, .predicted = NAN, .in_predicted = NAN};
        int rc = measure(muser, &at, 0, m[order[j]], err);
        if (rc < 0)
            return rc;
    }
    oop_estimate_decide(d, n, (const double (*)[3])m, mean_density, out);
    return 0;
}
