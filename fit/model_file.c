/* Model files (fit/model_file.h, docs/models.md): a text header a person
 * can read with `head`, then the raw binary64 data. Text for the numbers
 * would round-trip too (%.17g), but raw data keeps large weight sets small
 * and makes "bit-exact" a matter of copying bytes. The data's CRC-32 and
 * the exact file length catch truncation and damage. */
#include "fit/model_file.h"

#include <errno.h>
#include <limits.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <zlib.h>

#include "brdf/material_private.h"
#include "common/paths.h"
#include "fit/models.h"

#define MAGIC "gonio-model"
/* Header lines are short; a longer one means this is not a model file. */
#define LINE_MAX_LEN (FIT_MODEL_KEY_MAX + FIT_MODEL_VALUE_MAX + 4)
/* No model of ours comes near this; a larger count is damage. */
#define DATA_MAX ((size_t)1 << 28)

struct fit_model_file *fit_model_file_new(const char *kind, int version)
{
    if (!kind || strlen(kind) >= FIT_MODEL_KIND_MAX || !*kind)
        return NULL;
    struct fit_model_file *f = calloc(1, sizeof *f);
    if (!f)
        return NULL;
    strcpy(f->kind, kind);
    f->version = version;
    return f;
}

void fit_model_file_free(struct fit_model_file *f)
{
    if (!f)
        return;
    free(f->kv);
    free(f->data);
    free(f);
}

static int valid_key(const char *key)
{
    size_t n = strlen(key);
    if (n == 0 || n >= FIT_MODEL_KEY_MAX || !strcmp(key, "data"))
        return 0;
    for (size_t i = 0; i < n; i++)
        if (key[i] <= ' ' || key[i] == 127)
            return 0;
    return 1;
}

static int put_kv(struct fit_model_file *f, const char *key, const char *value)
{
    if (!valid_key(key) || strlen(value) >= FIT_MODEL_VALUE_MAX || strchr(value, '\n'))
        return -EINVAL;
    for (size_t i = 0; i < f->n_kv; i++)
        if (!strcmp(f->kv[i].key, key)) {
            strcpy(f->kv[i].value, value);
            return 0;
        }
    struct fit_model_kv *kv = realloc(f->kv, (f->n_kv + 1) * sizeof *kv);
    if (!kv)
        return -ENOMEM;
    f->kv = kv;
    strcpy(kv[f->n_kv].key, key);
    strcpy(kv[f->n_kv].value, value);
    f->n_kv++;
    return 0;
}

int fit_model_file_set(struct fit_model_file *f, const char *key, const char *fmt, ...)
{
    char value[FIT_MODEL_VALUE_MAX + 1];
    va_list ap;
    va_start(ap, fmt);
    int len = vsnprintf(value, sizeof value, fmt, ap);
    va_end(ap);
    if (len < 0 || (size_t)len >= FIT_MODEL_VALUE_MAX)
        return -EINVAL;
    return put_kv(f, key, value);
}

const char *fit_model_file_get(const struct fit_model_file *f, const char *key)
{
    for (size_t i = 0; i < f->n_kv; i++)
        if (!strcmp(f->kv[i].key, key))
            return f->kv[i].value;
    return NULL;
}

int fit_model_file_get_long(const struct fit_model_file *f, const char *key, const char *path,
                            long *out, struct gonio_err *err)
{
    const char *v = fit_model_file_get(f, key);
    if (!v)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: %s model: key '%s' missing",
                             path ? path : "(model)", f->kind, key);
    char *end;
    errno = 0;
    long x = strtol(v, &end, 10);
    if (end == v || *end || errno)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: key '%s': '%s' is not an integer",
                             path ? path : "(model)", key, v);
    *out = x;
    return 0;
}

int fit_model_file_get_double(const struct fit_model_file *f, const char *key,
                              const char *path, double *out, struct gonio_err *err)
{
    const char *v = fit_model_file_get(f, key);
    if (!v)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: %s model: key '%s' missing",
                             path ? path : "(model)", f->kind, key);
    char *end;
    errno = 0;
    double x = strtod(v, &end);
    if (end == v || *end || errno == ERANGE)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: key '%s': '%s' is not a number",
                             path ? path : "(model)", key, v);
    *out = x;
    return 0;
}

int fit_model_file_set_data(struct fit_model_file *f, const double *x, size_t n)
{
    double *d = NULL;
    if (n) {
        d = malloc(n * sizeof *d);
        if (!d)
            return -ENOMEM;
        memcpy(d, x, n * sizeof *d);
    }
    free(f->data);
    f->data = d;
    f->n_data = n;
    return 0;
}

/* binary64 to and from little-endian bytes, whatever the host order. */
static void put_le(unsigned char *b, double x)
{
    uint64_t u;
    memcpy(&u, &x, 8);
    for (int k = 0; k < 8; k++)
        b[k] = (unsigned char)(u >> (8 * k));
}

static double get_le(const unsigned char *b)
{
    uint64_t u = 0;
    for (int k = 0; k < 8; k++)
        u |= (uint64_t)b[k] << (8 * k);
    double x;
    memcpy(&x, &u, 8);
    return x;
}

/* CRC-32 in chunks, since zlib's length argument is a uInt. */
static unsigned long crc_bytes(const unsigned char *b, size_t len)
{
    unsigned long c = crc32(0L, Z_NULL, 0);
    while (len) {
        uInt chunk = len > (1u << 30) ? (1u << 30) : (uInt)len;
        c = crc32(c, b, chunk);
        b += chunk;
        len -= chunk;
    }
    return c;
}

int fit_model_file_write(const struct fit_model_file *f, const char *path,
                         struct gonio_err *err)
{
    size_t head_cap = 64 + f->n_kv * LINE_MAX_LEN + 64;
    size_t cap = head_cap + 8 * f->n_data;
    unsigned char *buf = malloc(cap);
    if (!buf)
        return gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    unsigned char *bin = malloc(8 * f->n_data + 1);
    if (!bin) {
        free(buf);
        return gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    }
    for (size_t i = 0; i < f->n_data; i++)
        put_le(bin + 8 * i, f->data[i]);
    size_t len = 0;
    len += (size_t)snprintf((char *)buf + len, cap - len, MAGIC " %s %d\n", f->kind, f->version);
    for (size_t i = 0; i < f->n_kv; i++)
        len += (size_t)snprintf((char *)buf + len, cap - len, "%s %s\n", f->kv[i].key,
                                f->kv[i].value);
    len += (size_t)snprintf((char *)buf + len, cap - len, "data %zu %08lx\n", f->n_data,
                            crc_bytes(bin, 8 * f->n_data));
    memcpy(buf + len, bin, 8 * f->n_data);
    len += 8 * f->n_data;
    free(bin);
    int rc = gonio_write_file_atomic(path, buf, len, err);
    free(buf);
    return rc;
}

/* The next header line of buf[*pos..len) into line (without the newline);
 * -1 when there is none or it is too long. */
static int next_line(const unsigned char *buf, size_t len, size_t *pos, char *line)
{
    size_t i = *pos, k = 0;
    while (i < len && buf[i] != '\n') {
        if (k + 1 >= LINE_MAX_LEN || buf[i] == 0)
            return -1;
        line[k++] = (char)buf[i++];
    }
    if (i >= len)
        return -1;
    line[k] = 0;
    *pos = i + 1;
    return 0;
}

static unsigned char *slurp(const char *path, size_t *len, struct gonio_err *err)
{
    FILE *fp = fopen(path, "rb");
    if (!fp) {
        int e = errno;
        gonio_err_set(err, e == ENOENT ? GONIO_ENOTFOUND : e, "%s: cannot open model file: %s",
                      path, strerror(e));
        return NULL;
    }
    size_t cap = 1 << 16, n = 0;
    unsigned char *buf = malloc(cap);
    while (buf) {
        n += fread(buf + n, 1, cap - n, fp);
        if (n < cap)
            break;
        unsigned char *b = cap > SIZE_MAX / 2 ? NULL : realloc(buf, cap * 2);
        if (!b) {
            free(buf);
            buf = NULL;
            break;
        }
        buf = b;
        cap *= 2;
    }
    int bad = ferror(fp);
    fclose(fp);
    if (!buf || bad) {
        free(buf);
        gonio_err_set(err, bad ? EIO : ENOMEM, "%s: cannot read model file", path);
        return NULL;
    }
    *len = n;
    return buf;
}

struct fit_model_file *fit_model_file_read(const char *path, struct gonio_err *err)
{
    size_t len, pos = 0;
    unsigned char *buf = slurp(path, &len, err);
    if (!buf)
        return NULL;
    struct fit_model_file *f = NULL;
    char line[LINE_MAX_LEN], kind[FIT_MODEL_KIND_MAX], tail;
    int version, lineno = 1;
    if (next_line(buf, len, &pos, line) ||
        sscanf(line, MAGIC " %31s %d %c", kind, &version, &tail) != 2 ||
        strncmp(line, MAGIC " ", sizeof MAGIC)) {
        gonio_err_set(err, GONIO_EBADDATA, "%s: not a gonio model file (first line must be "
                      "'" MAGIC " KIND VERSION')", path);
        goto fail;
    }
    f = fit_model_file_new(kind, version);
    if (!f) {
        gonio_err_set(err, ENOMEM, "%s: out of memory", path);
        goto fail;
    }
    for (;;) {
        lineno++;
        if (next_line(buf, len, &pos, line)) {
            gonio_err_set(err, GONIO_EBADDATA, "%s:%d: header line missing, too long or "
                          "unterminated (truncated file?)", path, lineno);
            goto fail;
        }
        if (!strncmp(line, "data ", 5)) {
            size_t n;
            unsigned long crc;
            int used = 0;
            if (sscanf(line + 5, "%zu %8lx%n", &n, &crc, &used) != 2 || line[5 + used] ||
                n > DATA_MAX) {
                gonio_err_set(err, GONIO_EBADDATA, "%s:%d: bad data line '%s'", path, lineno,
                              line);
                goto fail;
            }
            if (len - pos != 8 * n) {
                gonio_err_set(err, GONIO_EBADDATA, "%s: data block is %zu bytes, the header "
                              "says %zu values (%zu bytes): truncated or damaged", path,
                              len - pos, n, 8 * n);
                goto fail;
            }
            if (crc_bytes(buf + pos, 8 * n) != crc) {
                gonio_err_set(err, GONIO_EBADDATA, "%s: data CRC-32 mismatch: damaged file",
                              path);
                goto fail;
            }
            f->data = malloc((n ? n : 1) * sizeof *f->data);
            if (!f->data) {
                gonio_err_set(err, ENOMEM, "%s: out of memory", path);
                goto fail;
            }
            for (size_t i = 0; i < n; i++)
                f->data[i] = get_le(buf + pos + 8 * i);
            f->n_data = n;
            break;
        }
        char *sp = strchr(line, ' ');
        if (!sp) {
            gonio_err_set(err, GONIO_EBADDATA, "%s:%d: expected 'KEY VALUE', got '%s'", path,
                          lineno, line);
            goto fail;
        }
        *sp = 0;
        if (!valid_key(line) || fit_model_file_get(f, line) || put_kv(f, line, sp + 1)) {
            gonio_err_set(err, GONIO_EBADDATA, "%s:%d: bad or repeated key '%s'", path,
                          lineno, line);
            goto fail;
        }
    }
    free(buf);
    return f;
fail:
    free(buf);
    fit_model_file_free(f);
    return NULL;
}

brdf_material *fit_material_open(const char *spec, struct gonio_err *err)
{
    if (strncmp(spec, "model:", 6))
        return brdf_material_open(spec, err);
    const char *path = spec + 6;
    struct fit_model_file *f = fit_model_file_read(path, err);
    if (!f)
        return NULL;
    const struct fit_model_kind *k = fit_model_for_kind(f->kind);
    brdf_material *m = NULL;
    if (!k)
        gonio_err_set(err, GONIO_EBADDATA, "%s: unknown model kind '%s'", path, f->kind);
    else
        m = k->open(f, spec, err);
    fit_model_file_free(f);
    return m;
}
