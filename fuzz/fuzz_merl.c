/* MERL BRDF tables (brdf/merl.h). A real table is 35 MB, too big for a
 * corpus: the first byte of an input picks the shape of the file. Odd:
 * the rest of the input is the start of a full-size table (the remainder
 * reads as zeros, sparse on disk), so the header, the value checks and
 * the material over the table are reached; even: the rest is the whole
 * file (truncated or odd-sized tables). */
#include <fcntl.h>
#include <math.h>
#include <stdlib.h>
#include <unistd.h>

#include "brdf/merl.h"
#include "fuzz/fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1)
        return 0;
    int full = data[0] & 1;
    size_t n = size - 1;
    if (full && n > BRDF_MERL_FILE_BYTES)
        n = BRDF_MERL_FILE_BYTES;
    const char *path = fuzz_file("table.binary", data + 1, n);
    if (full)
        FUZZ_CHECK(truncate(path, (off_t)BRDF_MERL_FILE_BYTES) == 0);
    struct gonio_err err = {0};
    brdf_material *m = brdf_merl_open(path, "fuzz", &err);
    if (!m) {
        FUZZ_CHECK(err.msg[0]);
        return 0;
    }
    FUZZ_CHECK(full);
    /* Lookups anywhere, including past the grid and at NaN, stay in the
     * table: a grid of pairs over and beyond the hemisphere. */
    struct brdf_pair pairs[64];
    size_t np = 0;
    for (int i = 0; i < 8; i++)
        for (int j = 0; j < 8; j++)
            brdf_pair_from_hd(-0.2 + 0.3 * i, -0.1 + 0.25 * j, -4.0 + 1.2 * j, &pairs[np++]);
    pairs[0].theta_h = NAN;
    pairs[1].phi_d = INFINITY;
    pairs[2].theta_d = -INFINITY;
    double rgb[3 * 64];
    brdf_material_eval(m, pairs, np, rgb);
    for (size_t i = 0; i < 3 * np; i++)
        FUZZ_CHECK(isnan(rgb[i]) || rgb[i] >= 0);
    brdf_material_free(m);
    return 0;
}
