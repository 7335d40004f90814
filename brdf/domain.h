/* Reference domains for errors (design brief section 3): the MERL grid nodes
 * theta_h = (i/90)^2 pi/2, theta_d = j/90 pi/2, phi_d = k/180 pi (i, j in
 * 0..89), as direction pairs with phi_h = 0, kept where both polar angles are
 * at most 80 degrees. Beyond 80 degrees measured data are unreliable and
 * 1/(cos cos) terms explode, so errors there say nothing. */
#ifndef GONIO_BRDF_DOMAIN_H
#define GONIO_BRDF_DOMAIN_H

#include <stddef.h>
#include <stdint.h>

#include "brdf/angles.h"
#include "common/err.h"

#define BRDF_DOMAIN_MAX_THETA_DEG 80.0

/* The `oop200k` plan: 200,000 nodes of the full domain, drawn with this seed
 * unless the plan names another. */
#define BRDF_DOMAIN_OOP200K_N 200000
#define BRDF_DOMAIN_OOP200K_SEED UINT64_C(20030727)

struct brdf_domain {
    struct brdf_pair *pairs;
    size_t n;
};

/* The inclusion rule: both directions above the horizon and both polar
 * angles <= 80 degrees (1e-9 degree tolerance, so nodes that land on 80
 * degrees up to rounding stay in). */
int brdf_domain_keeps(const struct brdf_pair *p);

/* All nodes k = 0..179 (phi_d in [0, pi)), in (i, j, k) order, i slowest. */
int brdf_domain_full(struct brdf_domain *d, struct gonio_err *err);

/* The in-plane nodes: phi_d = 0 and phi_d = pi (both orders of light and
 * detector), in (i, j, phi_d) order. */
int brdf_domain_inplane(struct brdf_domain *d, struct gonio_err *err);

/* n nodes of the full domain drawn without replacement by a partial
 * Fisher-Yates shuffle driven by splitmix64(seed), returned in full-domain
 * order. The same (n, seed) gives the same nodes on every machine. n larger
 * than the full domain is an error. */
int brdf_domain_oop_random(struct brdf_domain *d, size_t n, uint64_t seed,
                           struct gonio_err *err);

/* The full domain for an anisotropic material, whose value depends on where
 * a pair lies on the sample: every node of d turned about the normal by its
 * own sample azimuth (brdf_pair_rotate), node n by n times the golden angle
 * (137.5...) modulo 360, so that the turns spread evenly over the circle
 * whatever d's order, and theta_h, theta_d, phi_d stay the node's. */
void brdf_domain_turn(struct brdf_domain *d);

/* A pair's place in the coordinates the MERL nodes are uniform in,
 * u = sqrt(theta_h / 90 deg) and v = theta_d / 90 deg (node (i, j) at
 * (i / 90, j / 90); a pair and its reciprocal at one place): where coverage
 * of the error's domain is measured. */
void brdf_domain_hd_place(const struct brdf_pair *p, double *u, double *v);

/* How much of the full domain each (theta_h, theta_d) cell of the MERL grid
 * stands for: counts[i * BRDF_DOMAIN_N_HD + j] = the full domain's nodes at
 * (i, j) over all phi_d, 0..180 (the 80-degree rule keeps fewer at large
 * angles). What an error averaged over the full domain weighs a
 * (theta_h, theta_d) by, for samples (in-plane ones) that do not resolve
 * phi_d. */
#define BRDF_DOMAIN_N_HD 90
void brdf_domain_hd_counts(unsigned short counts[BRDF_DOMAIN_N_HD * BRDF_DOMAIN_N_HD]);

/* splitmix64 (Steele, Lea, Flood 2014): advance *state, return the next
 * value. Exposed so tests and plans can reproduce the draw. */
uint64_t brdf_splitmix64(uint64_t *state);

void brdf_domain_free(struct brdf_domain *d);

#endif
