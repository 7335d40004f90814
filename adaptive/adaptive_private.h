/* What the adaptive policy's error prediction and costs are made of, for
 * the bench that calibrates it (bench/adaptive_sim.c --calibrate) and the
 * unit tests: not part of the interface the engine uses. */
#ifndef GONIO_ADAPTIVE_ADAPTIVE_PRIVATE_H
#define GONIO_ADAPTIVE_ADAPTIVE_PRIVATE_H

#include "adaptive/adaptive.h"

struct adaptive_evidence {
    size_t samples;   /* in the latest ensemble fit */
    double fit_error; /* the full fit's log error on its samples */
    double cv_error;  /* the jackknife members' log error on their held-out groups */
    double spread;    /* the ensemble's mean sd of log(1 + f cos) over the full-domain subset */
    double mapped;    /* the held-out residuals mapped onto that subset: each node takes the
                         one of the sample nearest it in (theta_h, theta_d) */
};

/* NAN fields before the first ensemble fit. */
void adaptive_evidence(const adaptive *a, struct adaptive_evidence *ev);

/* The rig time the policy expects pool point i to take with the axes at
 * `from`, before any margin: the move, the settle and the integration
 * (adaptive_observe's corrections in). */
double adaptive_point_cost(const adaptive *a, const struct rig_axes *from, size_t i);

/* The status's predicted_next from the prediction and the gain per
 * minute: NAN unless both are positive, the minute's drop at most half
 * the prediction (for the unit test). */
double adaptive_predicted_next(double predicted, double gain_per_min);

#endif
