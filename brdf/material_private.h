/* For material backends only: one const ops table per kind, private state
 * behind a void pointer (as libmodbus's backends). */
#ifndef GONIO_BRDF_MATERIAL_PRIVATE_H
#define GONIO_BRDF_MATERIAL_PRIVATE_H

#include "brdf/material.h"

struct brdf_material_ops {
    const char *kind; /* "nbrdf", "merl", "abc", "sgd" */
    /* Fill rgb[3n]; NAN triples where there is no data. */
    void (*eval)(const void *priv, const struct brdf_pair *pairs, size_t n, double *rgb);
    void (*free_priv)(void *priv);
};

/* Takes ownership of priv (freed with ops->free_priv, even on failure). */
brdf_material *brdf_material_new(const struct brdf_material_ops *ops, void *priv,
                                 const char *name);

/* Mark m anisotropic: its values depend on the pairs' azimuth in the
 * sample frame (brdf_material_isotropic). Materials are isotropic unless
 * their backend says so. */
void brdf_material_set_anisotropic(brdf_material *m);

#endif
