/* Sample weights that make a fit's loss an estimate of the full-domain
 * error (DESIGN.md section 6), for samples not spread like the domain.
 *
 * An adaptive capture measures where its model is unsure, which is seldom
 * where the domain's mass is: fitted unweighted, a model that cannot
 * follow the material everywhere bends towards the crowded samples
 * (docs/notes/adaptive.md "Why ABC stalls near 1.1x"). Weighting each sample by
 * the share of the domain it stands for corrects that bias (importance
 * weighting for a covariate shift). */
#ifndef GONIO_FIT_DOMAIN_WEIGHTS_H
#define GONIO_FIT_DOMAIN_WEIGHTS_H

#include <stddef.h>

#include "fit/fit.h"

/* w[k] for samples s[idx[k]], k < n (idx NULL: s[0..n)): every
 * (theta_h, theta_d) cell of the MERL grid, counted by its full-domain
 * nodes (brdf_domain_hd_counts), goes to the sample nearest it in
 * (sqrt(theta_h / 90 deg), theta_d / 90 deg), the coordinates the nodes
 * are uniform in; samples at the same point split it. More samples than a
 * quarter of the cells: each cell's nodes are spread over points round it,
 * four a sample, so that a dense capture's samples each get their share.
 * Scaled to mean 1; a sample nothing is nearest to (where the domain has
 * no nodes) weighs 0. Content-only: a permutation of the
 * samples permutes the weights. Returns 0, or -1 when out of memory. */
int fit_domain_weights(const struct fit_sample *s, const size_t *idx, size_t n, double *w);

/* What a weighted fit's model file says under its `weights` key (and
 * gonio fit on its `weights` line). */
#define FIT_DOMAIN_WEIGHTS_NOTE "each sample's share of the full domain"

/* The fewest samples a fit weighs (fit_options.domain_weights,
 * latent_fit_options.domain_weights): DS4's six pairs, the adaptive
 * policy's seeds, are a fixed design, each standing for a sixth of the
 * domain, and a fit of them is better unweighted (the latent fit at DS4's
 * rig time: 2.5 % worse weighted, at most DS4's error on 4 of 10 held-out
 * materials); from the policy's first picks on the weights gain (9
 * samples: 0.0449 weighted against 0.0531; docs/adaptive.md). */
#define FIT_DOMAIN_WEIGHTS_MIN_SAMPLES 7

#endif
