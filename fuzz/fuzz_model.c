/* Fitted model files (fit/model_file.h): the generic container, then the
 * kind's own loader through fit_material_open("model:PATH"), then an
 * evaluation of the material it gives. */
#include <limits.h>
#include <stdio.h>

#include "fit/model_file.h"
#include "fuzz/fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("fit.gm", data, size);
    struct gonio_err err = {0};
    struct fit_model_file *f = fit_model_file_read(path, &err);
    if (!f) {
        FUZZ_CHECK(err.msg[0]);
        return 0;
    }
    FUZZ_CHECK(f->n_data == 0 || f->data);
    fit_model_file_free(f);
    char spec[PATH_MAX + 16];
    snprintf(spec, sizeof spec, "model:%s", path);
    brdf_material *m = fit_material_open(spec, &err);
    if (!m) {
        FUZZ_CHECK(err.msg[0]);
        return 0;
    }
    struct brdf_pair pairs[8];
    for (int i = 0; i < 8; i++)
        brdf_pair_inplane(-70.0 + 20.0 * i, 60.0 - 15.0 * i, &pairs[i]);
    double rgb[3 * 8];
    brdf_material_eval(m, pairs, 8, rgb);
    brdf_material_free(m);
    return 0;
}
