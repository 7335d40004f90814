/* The in-plane sufficiency check (docs/checks.md, `--check out-of-plane`):
 * does the model fitted to the capture's in-plane pairs predict the
 * material out of the plane of incidence as well as it does in it?
 *
 * In-plane pairs hold the half vector in the plane of incidence and the
 * difference angle at phi_d = 90 degrees: a model fitted to them has never
 * seen the lobe's width across the plane (an anisotropic sample) nor its
 * dependence on phi_d (a layered or off-specular one). The check measures
 * a few out-of-plane pairs where that shows most — the glossy lobe's flank
 * with the half vector turned 45, 90 and 135 degrees out of the plane, at
 * the tilt where the fitted model says the lobe has fallen by
 * OOP_CHECK_DROP in ln f — and, for each, its in-plane counterpart (the
 * pair of the same theta_h and theta_d in the plane), which the in-plane
 * data did constrain. The figure: the model's mean error at the
 * out-of-plane pairs over its mean error at the counterparts (no better
 * than OOP_CHECK_FLOOR), in the units of the full-domain log error
 * (brdf/metrics.h). Beyond OOP_CHECK_RATIO: "insufficient".
 *
 * "insufficient" too, whatever the readings, when the fitted lobe is
 * narrower than the rig positions: when in every direction the model
 * falls by OOP_CHECK_DROP within the rig's positioning band of the mirror
 * (mechanics.in_position_deg), no in-plane pair the rig can place
 * determined the lobe's core, and the fit's value there (the peak of a
 * spike the data never resolved) is an extrapolation. Ratios cannot show
 * it: the model is as wrong in the plane as out of it, at tilts the rig
 * cannot resolve.
 *
 * No devices here: the host predicts with its fitted model and measures
 * through callbacks (the capture engine on its rig; the tests with
 * materials). */
#ifndef GONIO_CAPTURE_OOP_CHECK_H
#define GONIO_CAPTURE_OOP_CHECK_H

#include <stddef.h>

#include "brdf/angles.h"
#include "capture/oop_estimate.h"
#include "common/err.h"

#define OOP_CHECK_INCIDENCES 2  /* 25 and 45 degrees */
#define OOP_CHECK_AZIMUTHS 3    /* the half vector 45, 90, 135 degrees out of the plane */
#define OOP_CHECK_MAX_PAIRS (OOP_CHECK_INCIDENCES * OOP_CHECK_AZIMUTHS)
#define OOP_CHECK_DROP 1.5      /* ln f below the mirror's: the lobe's flank */
#define OOP_CHECK_RATIO 1.5     /* out-of-plane error over in-plane, at most */
#define OOP_CHECK_FLOOR 0.02    /* an in-plane error credited, at least */

/* One validation pair (the source in the plane, phi_i = 0) and its
 * in-plane counterpart (theta_r signed, as in-plane pairs are). */
struct oop_check_pair {
    double theta_i, theta_o, phi_o;
    double in_theta_i, in_theta_r;
    double lobe_deg; /* the half vector's tilt where the model has fallen by
                      * OOP_CHECK_DROP (NAN: it never does within the search) */
    double predicted, in_predicted; /* the model's (mean of R, G, B), 1/sr */
};

/* The fitted model's value at a pair, R, G, B in 1/sr (the verdict takes
 * their mean, the full-domain estimate each). */
typedef void (*oop_check_predict_fn)(void *user, const struct brdf_pair *p, double rgb[3]);

/* A host's measurement of the pair (in_plane 0) or of its counterpart
 * (1): the reading, R, G, B (NAN when unusable: saturated, or out of the
 * rig's reach). */
typedef int (*oop_check_measure_fn)(void *user, const struct oop_check_pair *p, int in_plane,
                                    double rgb[3], struct gonio_err *err);

struct oop_check_result {
    char verdict[16]; /* "sufficient", "insufficient", "undetermined" */
    char why[160];    /* one line: what decided it */
    size_t pairs, measurements;
    double error_oop;     /* the model's mean error at the out-of-plane pairs */
    double error_inplane; /* ... at their in-plane counterparts */
    double ratio;         /* error_oop / max(error_inplane, OOP_CHECK_FLOOR) */
    double threshold;     /* OOP_CHECK_RATIO */
    double lobe_deg;      /* the widest of the pairs' lobe_deg (NAN: a lobe that never falls) */
    double resolution_deg; /* the rig's positioning band the lobe was held to */
    int unresolved;       /* 1: lobe_deg within resolution_deg: the verdict's reason */
    struct oop_check_pair worst; /* the out-of-plane pair of the largest error */
    double worst_error;
    struct oop_estimate full; /* the fit's full-domain error (capture/oop_estimate.h) */
    double rig_time_s;    /* filled by the host: what the check cost the rig */
};

/* A reading's term of the full-domain log error (brdf/metrics.c):
 * |ln(1 + m cos theta_i) - ln(1 + p cos theta_i)|. */
double oop_check_error(double measured, double predicted, double theta_i);

/* The validation pairs for the model predict: up to OOP_CHECK_MAX_PAIRS
 * (fewer when a pair or its counterpart would leave theta <= 80 degrees).
 * Returns the count. */
size_t oop_check_choose(oop_check_predict_fn predict, void *user, struct oop_check_pair *out);

/* The verdict from the readings: measured[j] at pair j, in_measured[j] at
 * its counterpart. A pair with either reading NAN or not positive is left
 * out; fewer than 3 left: "undetermined" — unless the lobe is narrower
 * than resolution_deg (the rig's positioning band; 0: no such test), which
 * is "insufficient" from the model alone. */
void oop_check_decide(const struct oop_check_pair *p, size_t n, const double *measured,
                      const double *in_measured, double resolution_deg,
                      struct oop_check_result *out);

/* Choose, measure (each incidence's out-of-plane pairs, then their
 * counterparts) and decide with the rig's positioning band resolution_deg
 * (out->full zero: oop_estimate_run fills it).
 * Returns 0, or the callback's failure. */
int oop_check_run(oop_check_predict_fn predict, void *puser, oop_check_measure_fn measure,
                  void *muser, double resolution_deg, struct oop_check_result *out,
                  struct gonio_err *err);

#endif
