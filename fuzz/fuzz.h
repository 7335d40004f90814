/* What every fuzz target shares: the libFuzzer entry point, and a scratch
 * file for the parsers that take a path. Built with clang's libFuzzer
 * (`make fuzz`) or with replay_main.c under GCC (`make check` replays the
 * committed corpus). docs/fuzzing.md. */
#ifndef GONIO_FUZZ_FUZZ_H
#define GONIO_FUZZ_FUZZ_H

#include <stddef.h>
#include <stdint.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Write data[size] to <scratch dir>/name (the dir is made once per process
 * and removed at exit) and return the path; aborts when the disk refuses,
 * which is no finding of the target. */
const char *fuzz_file(const char *name, const uint8_t *data, size_t size);

/* The scratch directory itself. */
const char *fuzz_dir(void);

/* Abort with a message: a broken invariant is a finding. */
#define FUZZ_CHECK(cond)                                                                     \
    do {                                                                                     \
        if (!(cond))                                                                         \
            fuzz_fail(__FILE__, __LINE__, #cond);                                            \
    } while (0)
void fuzz_fail(const char *file, int line, const char *what) __attribute__((noreturn));

#endif
