#include "fuzz/fuzz.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char dir[PATH_MAX];
static char files[8][64];
static int n_files;

static void cleanup(void)
{
    for (int i = 0; i < n_files; i++) {
        char path[sizeof dir + sizeof files[0]];
        snprintf(path, sizeof path, "%s/%.63s", dir, files[i]);
        unlink(path);
    }
    rmdir(dir);
}

const char *fuzz_dir(void)
{
    if (!dir[0]) {
        const char *tmp = getenv("TMPDIR");
        snprintf(dir, sizeof dir, "%s/gonio-fuzz-XXXXXX", tmp && *tmp ? tmp : "/tmp");
        if (!mkdtemp(dir)) {
            perror("fuzz: mkdtemp");
            abort();
        }
        atexit(cleanup);
    }
    return dir;
}

const char *fuzz_file(const char *name, const uint8_t *data, size_t size)
{
    static char path[sizeof dir + sizeof files[0]];
    snprintf(path, sizeof path, "%s/%.63s", fuzz_dir(), name);
    int known = 0;
    for (int i = 0; i < n_files; i++)
        known |= !strcmp(files[i], name);
    if (!known && n_files < 8)
        snprintf(files[n_files++], sizeof files[0], "%s", name);
    FILE *f = fopen(path, "wb");
    if (!f || (size && fwrite(data, 1, size, f) != size) || fclose(f)) {
        perror(path);
        abort();
    }
    return path;
}

void fuzz_fail(const char *file, int line, const char *what)
{
    fprintf(stderr, "%s:%d: fuzz invariant broken: %s\n", file, line, what);
    abort();
}
