/* Scenes: what a simulated acquisition simulates. A scene file (YAML,
 * configs/scenes/, keys in docs/scenes.md) names the material, the rig
 * profile, the detector kind and the effects to apply; only the named
 * effects are computed, and a scene with none returns the material's exact
 * values. */
#ifndef GONIO_SIM_SCENE_H
#define GONIO_SIM_SCENE_H

#include "common/err.h"

enum sim_detector_kind { SIM_DETECTOR_RGB, SIM_DETECTOR_SPECTRAL };

struct sim_scene {
    char path[1024];
    char name[64];
    char material[512]; /* material spec, e.g. nbrdf:nylon (brdf/material.h) */
    char rig[512];      /* rig profile name or path */
    enum sim_detector_kind detector;
    unsigned long seed; /* seeds every effect's random stream */
    int n_effects;
};

/* Load a scene: a path, or a bare name resolved to
 * <gonio_config_dir()>/scenes/NAME.yaml. Errors: path:line:col: key: problem. */
int sim_scene_load(const char *path_or_name, struct sim_scene *scene, struct gonio_err *err);

#endif
