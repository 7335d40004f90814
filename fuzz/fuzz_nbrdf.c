/* NBRDF weight files (brdf/nbrdf.h): 675 float32 from outside. */
#include <math.h>

#include "brdf/nbrdf.h"
#include "fuzz/fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("weights.nbrdf", data, size);
    struct gonio_err err = {0};
    brdf_material *m = brdf_nbrdf_open(path, "fuzz", &err);
    if (!m) {
        FUZZ_CHECK(err.msg[0]);
        return 0;
    }
    FUZZ_CHECK(size == BRDF_NBRDF_FILE_BYTES);
    struct brdf_pair pairs[16];
    for (int i = 0; i < 16; i++)
        brdf_pair_inplane(-80.0 + 10.0 * i, 75.0 - 9.0 * i, &pairs[i]);
    double rgb[3 * 16];
    brdf_material_eval(m, pairs, 16, rgb);
    /* f = max(0, exp(.) - 1): never negative, whatever the weights. */
    for (int i = 0; i < 3 * 16; i++)
        FUZZ_CHECK(!(rgb[i] < 0));
    brdf_material_free(m);
    return 0;
}
