/* The pseudo-data route (`abc-pseudo`): a sparse in-plane capture is
 * densified with the RGB MLP's predictions on the DS1 grid, and ABC is
 * fitted to the measured samples together with those predictions. The
 * network interpolates between sparse samples where ABC's start search
 * and least squares would otherwise see only a few glossy points. */
#ifndef GONIO_FIT_PSEUDO_H
#define GONIO_FIT_PSEUDO_H

#include "fit/models.h"

/* The DS1 rule of configs/plans/ds1.yaml (theta_i 0..80 step 5; theta_r
 * -80..80 step 5 away from the mirror, step 1 within 15 degrees of it;
 * |theta_i + theta_r| < 5 left out), as in-plane pairs. Returns the count
 * (912) or -ENOMEM; *pairs is malloc'd. */
int fit_pseudo_grid(struct brdf_pair **pairs);

/* Writes an abc model file (keys say it came from pseudo-data). */
int fit_abc_pseudo_fit(const struct fit_data *data, const struct fit_model_options *opt,
                       struct fit_model_file **out, struct fit_model_report *rep,
                       struct gonio_err *err);

#endif
