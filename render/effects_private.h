/* For render/ only: the effects as pipeline stages. render.c builds the
 * list of stages from the scene's effects, so an effect the scene does not
 * name is not in the list and is never computed (the idea of sim/effects.h). */
#ifndef GONIO_RENDER_EFFECTS_PRIVATE_H
#define GONIO_RENDER_EFFECTS_PRIVATE_H

#include <stddef.h>

#include "brdf/material.h"
#include "render/render.h"

/* The shading points: the pixels on the sphere, each with its frame. */
struct render_points {
    size_t n;
    const double *normal, *tangent, *bitangent; /* 3n each, camera frame */
    const size_t *pixel;                        /* index into the image */
};

/* Pairs collected for one call of brdf_material_eval and what each adds:
 * rgb_out[pixel] += weight * f. */
#define RENDER_BATCH 4096
struct render_batch {
    const brdf_material *m;
    double *accum; /* 3 per pixel */
    struct render_stats *stats;
    size_t n;
    struct brdf_pair pairs[RENDER_BATCH];
    double weight[3 * RENDER_BATCH];
    size_t pixel[RENDER_BATCH];
    double f[3 * RENDER_BATCH];
};

/* Queue one pair (local directions wi, wo) for pixel with its weight. */
void render_batch_add(struct render_batch *b, const double wi[3], const double wo[3],
                      size_t pixel, const double weight[3]);
/* Evaluate what is queued and add it to the image. */
void render_batch_flush(struct render_batch *b);

typedef void (*render_stage_fn)(const struct render_scene *sc, const struct render_points *pts,
                                struct render_batch *b);

/* The stage of an effect kind. */
render_stage_fn render_effect_stage(enum render_effect_kind kind);

#endif
