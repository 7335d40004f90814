/* Render scenes: what `gonio render` lights its sphere with. A scene file
 * (YAML, configs/render/, keys in docs/render.md) names only the effects it
 * wants, `direct` (a directional light) and `environment` (a sky/ground
 * gradient); render/render.h builds the pipeline from that list, so an effect
 * the scene does not name is never computed.
 *
 * Loading parses and validates everything: a loaded scene always renders. */
#ifndef GONIO_RENDER_SCENE_H
#define GONIO_RENDER_SCENE_H

#include "common/err.h"

enum render_effect_kind { RENDER_FX_DIRECT, RENDER_FX_ENVIRONMENT, RENDER_FX_KINDS };

enum render_curve { RENDER_CURVE_REINHARD, RENDER_CURVE_CLAMP };

#define RENDER_ENV_MAX_SAMPLES 4096

/* Directions are in the camera's frame: +x right, +y up, +z towards the
 * camera (the sphere is seen down -z). */
struct render_direct {
    double direction[3];  /* towards the light, unit length */
    double irradiance[3]; /* linear RGB, on a surface facing the light */
};

/* Radiance of the environment seen along d (unit): ground below the
 * horizon, horizon + (sky - horizon) * d.y above it. */
struct render_environment {
    double sky[3], horizon[3], ground[3];
    int samples;        /* cosine-weighted directions per shading point */
    unsigned long seed; /* places that fixed set of directions */
};

struct render_scene {
    char path[1024];
    char name[64];
    int n_effects; /* in the order of the file */
    enum render_effect_kind effects[RENDER_FX_KINDS];
    struct render_direct direct;     /* valid when named */
    struct render_environment env;   /* valid when named */
    double background[3];            /* linear RGB of pixels off the sphere */
    double exposure;                 /* PNG only: linear scale before the curve */
    enum render_curve curve;         /* PNG only */
};

/* "direct", "environment"; NULL out of range. */
const char *render_effect_name(enum render_effect_kind kind);

/* 1 when the scene names the effect. */
int render_scene_has(const struct render_scene *sc, enum render_effect_kind kind);

/* Load a scene: a path, or a bare name resolved to
 * <gonio_config_dir()>/render/NAME.yaml. Errors: path:line:col: key: problem
 * (-GONIO_EBADCONFIG), -GONIO_ENOTFOUND for a missing file. */
int render_scene_load(const char *path_or_name, struct render_scene *sc, struct gonio_err *err);

/* The built-in scene (the same as configs/render/default.yaml): a light from
 * the upper left front and the environment. */
void render_scene_default(struct render_scene *sc);

#endif
