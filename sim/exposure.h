/* Exposure: the integration time the simulated detector uses for a point.
 *
 * With detector noise in the scene the detector auto-exposes: it picks the
 * time that brings its brightest channel to target_e electrons, within the
 * rig profile's auto_min_s..auto_max_s; weak signals therefore integrate
 * longer (up to auto_max_s) and rig time grows where the material is dark.
 * The meter is ideal (it sees the noise-free signal, as a pre-exposure would
 * up to its own noise) and costs no rig time. Without noise the rig's fixed
 * integration is used, so ideal scenes keep the planner's time estimate. */
#ifndef GONIO_SIM_EXPOSURE_H
#define GONIO_SIM_EXPOSURE_H

#include "rig/rig.h"
#include "sim/scene.h"

struct sim_exposure {
    int automatic;       /* 0: fixed_s always */
    double fixed_s;      /* the rig's fixed integration */
    double min_s, max_s; /* auto-exposure bounds */
    double target_e;     /* electrons wanted in the brightest channel */
    double responsivity; /* e-/s per 1/sr at normal incidence */
};

void sim_exposure_init(struct sim_exposure *x, const struct rig_profile *rig,
                       const struct sim_scene *scene, int noisy);

/* The integration time for a signal v[n] (1/sr) lit at cos_i. */
double sim_exposure_choose(const struct sim_exposure *x, const double *v, int n, double cos_i);

#endif
