/* The ABC fit tests' synthetic material and sampling: a glossy ABC truth
 * and a DS2-like in-plane grid written out from the design brief rather
 * than taken from the planner (theta_i 0..75 step 15, diffuse theta_r step
 * 10 outside a 15 degree window, glossy step 2 inside it, blind zone 5). */
#ifndef GONIO_TEST_FIT_ABC_SYNTH_H
#define GONIO_TEST_FIT_ABC_SYNTH_H

#include <math.h>

#include "brdf/abc.h"
#include "brdf/angles.h"
#include "fit/fit.h"

static const struct brdf_abc truth = {
    .kd = {0.20, 0.15, 0.10}, .A = {20.0, 15.0, 10.0}, .B = 3000, .C = 0.9, .eta = 1.5};

static size_t ds2_grid(struct brdf_pair *out)
{
    size_t n = 0;
    for (double ti = 0; ti <= 80; ti += 15) {
        for (double tr = -80; tr <= 80; tr += 10)
            if (fabs(tr - ti) > 15 && fabs(ti + tr) >= 5)
                brdf_pair_inplane(ti, tr, &out[n++]);
        for (double k = -14; k <= 14; k += 2) {
            double tr = ti + k;
            if (fabs(tr) <= 80 && fabs(ti + tr) >= 5)
                brdf_pair_inplane(ti, tr, &out[n++]);
        }
    }
    return n;
}

/* Noiseless samples of p at the pairs g. */
static void synth(const struct brdf_abc *p, const struct brdf_pair *g, size_t n,
                  struct fit_sample *s)
{
    for (size_t k = 0; k < n; k++) {
        s[k].g = g[k];
        brdf_abc_eval(p, &g[k], s[k].rgb);
    }
}

#endif
