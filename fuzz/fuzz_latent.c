/* The latent decoder file (fit/latent.h, configs/models/latent-decoder.gld): a network
 * and a table of material codes from outside. */
#include <stdlib.h>

#include "fit/latent.h"
#include "fuzz/fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("decoder.gld", data, size);
    struct gonio_err err = {0};
    latent_decoder *d = latent_decoder_load(path, &err);
    if (!d) {
        FUZZ_CHECK(err.msg[0]);
        return 0;
    }
    int nz = latent_decoder_nz(d);
    FUZZ_CHECK(nz > 0);
    for (size_t i = 0; i < latent_decoder_n_materials(d); i++) {
        const char *name = latent_decoder_material(d, i);
        FUZZ_CHECK(name && latent_decoder_latent(d, i));
        FUZZ_CHECK(latent_decoder_find(d, name) >= 0);
    }
    struct brdf_pair pairs[8];
    for (int i = 0; i < 8; i++)
        brdf_pair_inplane(-70.0 + 20.0 * i, 60.0 - 15.0 * i, &pairs[i]);
    double rgb[3 * 8];
    brdf_material *m = latent_material(d, latent_decoder_mean_latent(d), "fuzz");
    if (m) {
        brdf_material_eval(m, pairs, 8, rgb);
        brdf_material_free(m);
    }
    latent_decoder_free(d);
    return 0;
}
