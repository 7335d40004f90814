/* Simulator scenes (sim/scene.h): YAML from the user. */
#include "fuzz/fuzz.h"
#include "sim/scene.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("scene.yaml", data, size);
    struct sim_scene scene;
    struct gonio_err err = {0};
    if (sim_scene_load(path, &scene, &err) < 0) {
        FUZZ_CHECK(err.msg[0]);
        return 0;
    }
    FUZZ_CHECK(scene.n_effects >= 0 && scene.n_effects <= SIM_SCENE_MAX_EFFECTS);
    FUZZ_CHECK(scene.n_bands >= 0 && scene.n_bands <= SIM_SCENE_MAX_BANDS);
    for (int i = 0; i < scene.n_effects; i++)
        FUZZ_CHECK(scene.effects[i].n_at_moves >= 0 &&
                   scene.effects[i].n_at_moves <= SIM_EFFECT_MAX_MOVES);
    for (int i = 1; i < scene.n_bands; i++)
        FUZZ_CHECK(scene.bands_nm[i] > scene.bands_nm[i - 1]);
    return 0;
}
