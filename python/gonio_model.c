/* The C side of the Python client's gonio.Model (python/gonio/model.py): a
 * fitted model file evaluated through the project's own model registry
 * (fit_material_open, brdf_material_eval), so that Python gets the values
 * gonio itself computes and no second implementation of any model exists.
 * Built as libgonio_model.so from the static libraries (compiled PIC for
 * it); only the functions below are exported. */
#include <stdio.h>
#include <stdlib.h>

#include "brdf/angles.h"
#include "brdf/material.h"
#include "common/err.h"
#include "fit/model_file.h"

#define EXPORT __attribute__((visibility("default")))

/* Open the model file at path (any registered kind: docs/models.md). NULL
 * with msg (size bytes) naming the file and the problem. */
EXPORT brdf_material *gonio_model_open(const char *path, char *msg, size_t size)
{
    struct gonio_err err = {0};
    char spec[4200];
    if (snprintf(spec, sizeof spec, "model:%s", path) >= (int)sizeof spec) {
        snprintf(msg, size, "%.200s...: path too long", path);
        return NULL;
    }
    brdf_material *m = fit_material_open(spec, &err);
    if (!m)
        snprintf(msg, size, "%s", err.msg[0] ? err.msg : "cannot open model file");
    return m;
}

/* The n pairs' RGB BRDF (1/sr) into rgb[3n], each pair given by spherical
 * angles in degrees (in-plane: phi_i 0, phi_o 0 or 180). Returns the number
 * of pairs the model has no value for (their rgb NaN), or -1 when out of
 * memory. */
EXPORT long gonio_model_eval(const brdf_material *m, const double *theta_i, const double *phi_i,
                             const double *theta_o, const double *phi_o, size_t n, double *rgb)
{
    struct brdf_pair *pairs = malloc((n ? n : 1) * sizeof *pairs);
    if (!pairs)
        return -1;
    for (size_t k = 0; k < n; k++)
        brdf_pair_spherical(theta_i[k], phi_i[k], theta_o[k], phi_o[k], &pairs[k]);
    size_t missing = brdf_material_eval(m, pairs, n, rgb);
    free(pairs);
    return (long)missing;
}

/* The same for in-plane pairs: theta_i and the signed theta_r of
 * samples.csv (degrees, brdf_pair_inplane's convention). */
EXPORT long gonio_model_eval_inplane(const brdf_material *m, const double *theta_i,
                                     const double *theta_r, size_t n, double *rgb)
{
    struct brdf_pair *pairs = malloc((n ? n : 1) * sizeof *pairs);
    if (!pairs)
        return -1;
    for (size_t k = 0; k < n; k++)
        brdf_pair_inplane(theta_i[k], theta_r[k], &pairs[k]);
    size_t missing = brdf_material_eval(m, pairs, n, rgb);
    free(pairs);
    return (long)missing;
}

/* The model's name, as gonio prints it. */
EXPORT const char *gonio_model_name(const brdf_material *m)
{
    return brdf_material_name(m);
}

EXPORT void gonio_model_close(brdf_material *m)
{
    brdf_material_free(m);
}
