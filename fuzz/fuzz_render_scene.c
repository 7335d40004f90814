/* Render scenes (render/scene.h): YAML from the user. */
#include <math.h>

#include "fuzz/fuzz.h"
#include "render/scene.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("render.yaml", data, size);
    struct render_scene sc;
    struct gonio_err err = {0};
    if (render_scene_load(path, &sc, &err) < 0) {
        FUZZ_CHECK(err.msg[0]);
        return 0;
    }
    FUZZ_CHECK(sc.n_effects >= 0 && sc.n_effects <= RENDER_FX_KINDS);
    for (int i = 0; i < sc.n_effects; i++)
        FUZZ_CHECK(render_effect_name(sc.effects[i]) != NULL);
    const double *d = sc.direct.direction;
    FUZZ_CHECK(fabs(d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - 1) < 1e-9);
    FUZZ_CHECK(sc.env.samples >= 1 && sc.env.samples <= RENDER_ENV_MAX_SAMPLES);
    for (int c = 0; c < 3; c++)
        FUZZ_CHECK(sc.direct.irradiance[c] >= 0 && sc.env.sky[c] >= 0 && sc.env.horizon[c] >= 0 &&
                   sc.env.ground[c] >= 0 && sc.background[c] >= 0 && isfinite(sc.background[c]));
    FUZZ_CHECK(sc.exposure > 0 && isfinite(sc.exposure));
    return 0;
}
