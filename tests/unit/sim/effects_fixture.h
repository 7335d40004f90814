/* What the effects tests share: the default rig profile and material, set
 * up and torn down per group, and a scene effect added with every axis in
 * its reach. Static: each test includes it once. */
#ifndef GONIO_TESTS_SIM_EFFECTS_FIXTURE_H
#define GONIO_TESTS_SIM_EFFECTS_FIXTURE_H

#include <string.h>

#include "brdf/material.h"
#include "rig/rig.h"
#include "sim/scene.h"
#include "tests/gonio_test.h"

static struct rig_profile rig_profile;
static brdf_material *material;

static int setup(void **state)
{
    (void)state;
    rig_profile_default(&rig_profile);
    material = brdf_material_open("default", NULL);
    return material ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    brdf_material_free(material);
    return 0;
}

static struct sim_effect_spec *add(struct sim_scene *sc, enum sim_effect_kind kind)
{
    struct sim_effect_spec *fx = &sc->effects[sc->n_effects];
    memset(fx, 0, sizeof *fx);
    fx->kind = kind;
    fx->index = sc->n_effects++;
    fx->axes = SIM_AXES_ALL;
    return fx;
}

#endif
