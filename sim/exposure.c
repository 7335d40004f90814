#include "sim/exposure.h"

#include <math.h>

void sim_exposure_init(struct sim_exposure *x, const struct rig_profile *rig,
                       const struct sim_scene *scene, int noisy)
{
    x->automatic = noisy;
    x->fixed_s = rig->integration_s;
    x->min_s = rig->auto_min_s;
    x->max_s = rig->auto_max_s;
    x->target_e = scene->target_e;
    x->responsivity = scene->responsivity;
}

double sim_exposure_choose(const struct sim_exposure *x, const double *v, int n, double cos_i)
{
    if (!x->automatic)
        return x->fixed_s;
    double peak = 0;
    for (int k = 0; k < n; k++)
        if (v[k] > peak) /* NAN channels do not count */
            peak = v[k];
    double rate = peak * x->responsivity * cos_i; /* electrons per second */
    if (!(rate > 0))
        return x->max_s;
    double t = x->target_e / rate;
    return t < x->min_s ? x->min_s : t > x->max_s ? x->max_s : t;
}
