/* Spectral samples CSV (fit/mlp.h): the input of `gonio fit --model
 * mlp-spectral`. */
#include <math.h>
#include <stdlib.h>

#include "fit/mlp.h"
#include "fuzz/fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const char *path = fuzz_file("spectral.csv", data, size);
    struct gonio_err err = {0};
    struct fit_spectral_sample *s = NULL;
    size_t n = 0;
    if (fit_spectral_samples_read(path, &s, &n, &err) < 0) {
        FUZZ_CHECK(err.msg[0] && !s);
        return 0;
    }
    FUZZ_CHECK(n == 0 || s);
    free(s);
    return 0;
}
