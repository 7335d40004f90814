/* Model files: the parameters of a fitted model, written so that they load
 * back bit-exact (docs/models.md).
 *
 *   gonio-model KIND VERSION\n          the kind's own format version
 *   KEY VALUE\n                         any number; KEY has no blanks
 *   data N CRC\n                        N float64 values, CRC-32 (hex) of them
 *   <8 N bytes: IEEE-754 binary64, little-endian>
 *
 * The file ends right after the data; anything else (a short or long file,
 * a CRC mismatch, a malformed line) is refused with the file's name. */
#ifndef GONIO_FIT_MODEL_FILE_H
#define GONIO_FIT_MODEL_FILE_H

#include <stddef.h>

#include "brdf/material.h"
#include "common/err.h"

#define FIT_MODEL_KIND_MAX 32
#define FIT_MODEL_KEY_MAX 64
#define FIT_MODEL_VALUE_MAX 256

struct fit_model_kv {
    char key[FIT_MODEL_KEY_MAX];
    char value[FIT_MODEL_VALUE_MAX];
};

struct fit_model_file {
    char kind[FIT_MODEL_KIND_MAX];
    int version;
    struct fit_model_kv *kv;
    size_t n_kv;
    double *data;
    size_t n_data;
};

/* A new, empty model file of this kind and version (NULL: out of memory). */
struct fit_model_file *fit_model_file_new(const char *kind, int version);

/* Set (or replace) a key; the value is printf-formatted and must hold no
 * newline. Returns 0 or a negative code. */
int fit_model_file_set(struct fit_model_file *f, const char *key, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* The value of a key, or NULL. */
const char *fit_model_file_get(const struct fit_model_file *f, const char *key);

/* Parse a key as an integer / double; a missing or malformed key is a
 * GONIO_EBADDATA error naming path (may be NULL), the key and the value. */
int fit_model_file_get_long(const struct fit_model_file *f, const char *key, const char *path,
                            long *out, struct gonio_err *err);
int fit_model_file_get_double(const struct fit_model_file *f, const char *key,
                              const char *path, double *out, struct gonio_err *err);

/* Replace the data block with a copy of x[n]. */
int fit_model_file_set_data(struct fit_model_file *f, const double *x, size_t n);

/* Write atomically (temporary file + rename). */
int fit_model_file_write(const struct fit_model_file *f, const char *path,
                         struct gonio_err *err);

/* Read and check a model file; NULL with err naming the file and problem. */
struct fit_model_file *fit_model_file_read(const char *path, struct gonio_err *err);

void fit_model_file_free(struct fit_model_file *f);

/* A material for a specification: `model:PATH` opens a model file of any
 * registered kind (fit/models.h); anything else goes to brdf_material_open. */
brdf_material *fit_material_open(const char *spec, struct gonio_err *err);

#endif
