#include "render/png.h"

#include <errno.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <png.h>

#include "common/paths.h"

/* The encoded file grows in memory; libpng calls back for each piece. */
struct membuf {
    uint8_t *data;
    size_t len, cap;
    int oom;
};

static void on_write(png_structp png, png_bytep data, png_size_t len)
{
    struct membuf *mb = png_get_io_ptr(png);
    if (mb->oom)
        return;
    if (mb->len + len > mb->cap) {
        size_t cap = mb->cap ? mb->cap : 4096;
        while (cap < mb->len + len)
            cap *= 2;
        uint8_t *p = realloc(mb->data, cap);
        if (!p) {
            mb->oom = 1;
            return;
        }
        mb->data = p;
        mb->cap = cap;
    }
    memcpy(mb->data + mb->len, data, len);
    mb->len += len;
}

static void on_flush(png_structp png)
{
    (void)png;
}

/* libpng reports through a callback and longjmp; keep its message. */
static void on_error(png_structp png, png_const_charp msg)
{
    char *buf = png_get_error_ptr(png);
    snprintf(buf, 200, "%s", msg);
    png_longjmp(png, 1);
}

static void on_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg;
}

int render_png_encode(int width, int height, const uint8_t *rgb, uint8_t **out, size_t *len,
                      struct gonio_err *err)
{
    if (width < 1 || height < 1)
        return gonio_err_set(err, GONIO_EUSAGE, "png: empty image %dx%d", width, height);
    char msg[200] = "";
    /* On the heap: what the callbacks change survives libpng's longjmp. */
    struct membuf *mb = calloc(1, sizeof *mb);
    png_bytep *rows = malloc((size_t)height * sizeof *rows);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, msg, on_error, on_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!mb || !rows || !png || !info) {
        png_destroy_write_struct(&png, &info);
        free(mb);
        free(rows);
        return gonio_err_set(err, ENOMEM, "png: out of memory");
    }
    for (int y = 0; y < height; y++)
        rows[y] = (png_bytep)(rgb + (size_t)y * (size_t)width * 3);
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        free(rows);
        free(mb->data);
        free(mb);
        return gonio_err_set(err, GONIO_EBADDATA, "png: %s", msg);
    }
    png_set_write_fn(png, mb, on_write, on_flush);
    png_set_IHDR(png, info, (png_uint_32)width, (png_uint_32)height, 8, PNG_COLOR_TYPE_RGB,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_set_rows(png, info, rows);
    png_write_png(png, info, PNG_TRANSFORM_IDENTITY, NULL);
    png_destroy_write_struct(&png, &info);
    free(rows);
    int oom = mb->oom;
    *out = oom ? NULL : mb->data;
    *len = oom ? 0 : mb->len;
    if (oom)
        free(mb->data);
    free(mb);
    return oom ? gonio_err_set(err, ENOMEM, "png: out of memory") : 0;
}

int render_png_write(const char *path, int width, int height, const uint8_t *rgb,
                     struct gonio_err *err)
{
    uint8_t *buf;
    size_t len;
    struct gonio_err e = {0};
    int rc = render_png_encode(width, height, rgb, &buf, &len, &e);
    if (rc < 0)
        return gonio_err_set(err, e.code, "%s: %s", path, e.msg);
    rc = gonio_write_file_atomic(path, buf, len, err);
    free(buf);
    return rc;
}
