/* NBRDF: the per-material neural BRDF of Sztrajman, Rainer, Ritschel and
 * Weyrich, "Neural BRDF Representation and Importance Sampling", CGF 40(6),
 * 2021, fitted to the MERL materials. One MLP 6 -> 21 -> 21 -> 3 with 675
 * float32 weights (layout and recipe: <shared>/data/merl/README.md):
 *
 *   x  = (sin th, 0, cos th, sin td cos pd, sin td sin pd, cos td)
 *   a1 = relu(x W1 + b1), a2 = relu(a1 W2 + b2), f = max(0, exp(a2 W3 + b3) - 1)
 *
 * in Rusinkiewicz coordinates with phi_h = 0. f is linear RGB in 1/sr with
 * the MERL channel scales already applied. Evaluated in double. */
#ifndef GONIO_BRDF_NBRDF_H
#define GONIO_BRDF_NBRDF_H

#include <stddef.h>

#include "brdf/angles.h"
#include "brdf/material.h"
#include "common/err.h"

#define BRDF_NBRDF_NIN 6
#define BRDF_NBRDF_NHID 21
#define BRDF_NBRDF_NOUT 3
#define BRDF_NBRDF_NWEIGHTS 675
#define BRDF_NBRDF_FILE_BYTES (4 * BRDF_NBRDF_NWEIGHTS)

struct brdf_nbrdf {
    double w1[BRDF_NBRDF_NIN * BRDF_NBRDF_NHID]; /* [in][out], row-major */
    double b1[BRDF_NBRDF_NHID];
    double w2[BRDF_NBRDF_NHID * BRDF_NBRDF_NHID];
    double b2[BRDF_NBRDF_NHID];
    double w3[BRDF_NBRDF_NHID * BRDF_NBRDF_NOUT];
    double b3[BRDF_NBRDF_NOUT];
};

/* Read a .nbrdf file (exactly 2,700 bytes of little-endian float32, all
 * finite). Returns 0 or a negative code with err naming the file. */
int brdf_nbrdf_load(const char *path, struct brdf_nbrdf *net, struct gonio_err *err);

/* Fill the network from 675 floats in file order. */
void brdf_nbrdf_from_floats(const float w[BRDF_NBRDF_NWEIGHTS], struct brdf_nbrdf *net);

/* Evaluate n pairs into rgb[3n] (theta_h, theta_d, phi_d of each pair). */
void brdf_nbrdf_eval(const struct brdf_nbrdf *net, const struct brdf_pair *pairs, size_t n,
                     double *rgb);

/* A material over the network in path; name is what brdf_material_name
 * reports (the path when NULL). */
brdf_material *brdf_nbrdf_open(const char *path, const char *name, struct gonio_err *err);

#endif
