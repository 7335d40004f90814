/* A study's results.json as `gonio render --study` reads it (render/study.h). */
#include <string.h>

#include "fuzz/fuzz.h"
#include "render/study.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_file("results.json", data, size);
    struct render_study_material *m;
    int n;
    struct gonio_err err = {0};
    if (render_study_read(fuzz_dir(), NULL, &m, &n, &err) < 0) {
        FUZZ_CHECK(err.msg[0]);
        return 0;
    }
    FUZZ_CHECK(n >= 1);
    size_t dirlen = strlen(fuzz_dir());
    for (int i = 0; i < n; i++) {
        FUZZ_CHECK(m[i].name[0] && m[i].name[0] != '.' && !strchr(m[i].name, '/'));
        FUZZ_CHECK(m[i].n >= 1);
        for (int c = 0; c < m[i].n; c++) {
            const char *spec = m[i].cells[c].spec;
            /* a model file stays inside the study */
            FUZZ_CHECK(!strncmp(spec, "model:", 6) && !strncmp(spec + 6, fuzz_dir(), dirlen) &&
                       !strstr(spec + 6 + dirlen, ".."));
        }
    }
    render_study_free(m, n);
    return 0;
}
