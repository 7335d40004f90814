/* The in-plane fit's full-domain error, estimated from readings
 * (docs/checks.md, "The full-domain error"): what the in-plane sufficiency
 * check (capture/oop_check.h) reports as its predicted out-of-plane error.
 *
 * The check's validation pairs sit on the fitted lobe's flank, where the
 * model is most likely wrong: their mean error says whether in-plane was
 * enough, not how large the error is over the domain. The full-domain log
 * error (brdf/metrics.h) is a mean over the MERL grid's nodes (brdf/domain.h)
 * with every node weighing the same; so this estimate measures a few nodes
 * drawn from that same measure, one per stratum of equal node count in the
 * grid's order (theta_h slowest: most of the error's variation is across
 * theta_h), the node within each stratum placed by the golden-ratio
 * sequence so that theta_d and phi_d vary from one stratum to the next. The
 * mean of the nodes' errors is an unbiased estimate of the domain's; its
 * standard error comes from the differences of neighbouring strata
 * (collapsed strata), which stratification leaves as the variance's only
 * trace; from so few differences it is itself uncertain, so the interval
 * is Student's t of as many degrees of freedom as pairs of strata. A node's error is the domain error's own term, per channel (R, G,
 * B) and averaged, not the term of the channels' mean: a fit whose colour
 * is wrong (a conductor's Fresnel tint) errs in each channel while the
 * mean of the three can be right.
 *
 * A node is placed on the rig with its source in the plane (phi_i = 0): a
 * turn about the normal an isotropic material does not notice. */
#ifndef GONIO_CAPTURE_OOP_ESTIMATE_H
#define GONIO_CAPTURE_OOP_ESTIMATE_H

#include <stddef.h>

#include "brdf/angles.h"
#include "common/err.h"

#define OOP_ESTIMATE_PAIRS 12  /* domain nodes measured */
#define OOP_ESTIMATE_FLOOR 0.08 /* the draw's density where the model is dark */
#define OOP_ESTIMATE_MIN_USED 4 /* readings below which no estimate is given */

struct oop_check_pair;

/* The fitted model's value at a pair, per channel (R, G, B, 1/sr). */
typedef void (*oop_estimate_predict_fn)(void *user, const struct brdf_pair *p, double rgb[3]);

/* A node of the draw: where it is read (theta_i, theta_o, phi_o with the
 * source in the plane; the pair's other fields unused), the model's value
 * there and the draw's density. */
struct oop_estimate_node {
    double theta_i, theta_o, phi_o;
    double predicted[3]; /* the model's, R, G, B, 1/sr */
    double density;
};

/* The estimate: NAN figures when fewer than OOP_ESTIMATE_MIN_USED nodes
 * were read. */
struct oop_estimate {
    size_t pairs, used;
    double error;     /* the mean of the nodes' log errors */
    double low, high; /* its 95% interval, error -/+ t standard errors (low >= 0) */
};

/* A node's term of the full-domain log error (brdf/metrics.c), the mean
 * over R, G, B of |ln(1 + m cos theta_i) - ln(1 + p cos theta_i)|; NAN
 * when the reading is unusable (a channel NAN, or no light in any). A
 * channel read below 0 (the noise about a dark one) counts as 0. */
double oop_estimate_error(const double measured[3], const double predicted[3], double theta_i);

/* The OOP_ESTIMATE_PAIRS nodes of the full domain's stratified draw, in
 * the strata's order. Returns the count. */
size_t oop_estimate_choose(oop_estimate_predict_fn predict, void *user,
                           struct oop_estimate_node *out, double *mean_density);

/* The estimate from the readings measured[j] (R, G, B) at the nodes p[j],
 * in the strata's order (oop_estimate_choose's); an unusable reading
 * (oop_estimate_error NAN) is left out. */
void oop_estimate_decide(const struct oop_estimate_node *p, size_t n, const double (*measured)[3],
                         double mean_density, struct oop_estimate *out);

/* Choose, measure in travel order (theta_i rising, phi_o snaking) through
 * the check's measure callback (in_plane 0: the pair out of the plane;
 * capture/oop_check.h) and estimate. Returns 0, or the callback's failure. */
int oop_estimate_run(oop_estimate_predict_fn predict, void *puser,
                     int (*measure)(void *user, const struct oop_check_pair *p, int in_plane,
                                    double rgb[3], struct gonio_err *err),
                     void *muser, struct oop_estimate *out, struct gonio_err *err);

#endif
