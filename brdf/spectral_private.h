/* For spectral material kinds only (after brdf/material_private.h). */
#ifndef GONIO_BRDF_SPECTRAL_PRIVATE_H
#define GONIO_BRDF_SPECTRAL_PRIVATE_H

#include "brdf/spectral.h"

struct brdf_spectral_ops {
    const char *kind;
    void (*eval)(const void *priv, const struct brdf_pair *p, const double *lambda_nm,
                 size_t n, double *out);
    void (*free_priv)(void *priv);
};

struct brdf_spectral {
    const struct brdf_spectral_ops *ops;
    void *priv;
    double lo_nm, hi_nm;
    char name[640];
};

/* Takes ownership of priv (freed with ops->free_priv, even on failure). */
brdf_spectral *brdf_spectral_new(const struct brdf_spectral_ops *ops, void *priv,
                                 const char *name, double lo_nm, double hi_nm);

#endif
