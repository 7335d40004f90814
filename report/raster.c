/* SVG to PNG with librsvg and cairo (raster.h). */
#include "report/raster.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <cairo.h>
#include <librsvg/rsvg.h>

struct png_buf {
    unsigned char *data;
    size_t len, cap;
};

static cairo_status_t png_write(void *closure, const unsigned char *data, unsigned int length)
{
    struct png_buf *b = closure;
    if (b->len + length > b->cap) {
        size_t cap = b->cap ? 2 * b->cap : 65536;
        while (cap < b->len + length)
            cap *= 2;
        unsigned char *p = realloc(b->data, cap);
        if (!p)
            return CAIRO_STATUS_NO_MEMORY;
        b->data = p;
        b->cap = cap;
    }
    memcpy(b->data + b->len, data, length);
    b->len += length;
    return CAIRO_STATUS_SUCCESS;
}

int report_svg_to_png(const char *svg, size_t len, double scale, unsigned char **png,
                      size_t *png_len, struct gonio_err *err)
{
    GError *gerr = NULL;
    RsvgHandle *h = rsvg_handle_new_from_data((const guint8 *)svg, len, &gerr);
    if (!h) {
        int rc = gonio_err_set(err, GONIO_EBADDATA, "SVG does not parse: %s",
                               gerr ? gerr->message : "unknown error");
        g_clear_error(&gerr);
        return rc;
    }
    gdouble w = 0, hgt = 0;
    if (!rsvg_handle_get_intrinsic_size_in_pixels(h, &w, &hgt) || !(w > 0) || !(hgt > 0) ||
        !(scale > 0) || w * scale > 20000 || hgt * scale > 20000) {
        g_object_unref(h);
        return gonio_err_set(err, GONIO_EBADDATA,
                             "SVG has no usable size in pixels (%gx%g at scale %g)", w, hgt,
                             scale);
    }
    int pw = (int)ceil(w * scale), ph = (int)ceil(hgt * scale);
    cairo_surface_t *surf = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, pw, ph);
    cairo_t *cr = cairo_create(surf);
    cairo_scale(cr, scale, scale);
    RsvgRectangle viewport = {0, 0, w, hgt};
    int rc = 0;
    if (!rsvg_handle_render_document(h, cr, &viewport, &gerr)) {
        rc = gonio_err_set(err, GONIO_EBADDATA, "SVG does not render: %s",
                           gerr ? gerr->message : "unknown error");
        g_clear_error(&gerr);
    }
    struct png_buf b = {0};
    if (!rc && cairo_status(cr) == CAIRO_STATUS_SUCCESS) {
        cairo_surface_flush(surf);
        if (cairo_surface_write_to_png_stream(surf, png_write, &b) != CAIRO_STATUS_SUCCESS) {
            free(b.data);
            rc = gonio_err_set(err, GONIO_EBADDATA, "PNG encoding failed");
        }
    } else if (!rc) {
        rc = gonio_err_set(err, GONIO_EBADDATA, "cairo: %s",
                           cairo_status_to_string(cairo_status(cr)));
    }
    cairo_destroy(cr);
    cairo_surface_destroy(surf);
    g_object_unref(h);
    if (rc)
        return rc;
    *png = b.data;
    *png_len = b.len;
    return 0;
}

struct png_src {
    const unsigned char *data;
    size_t len, at;
};

static cairo_status_t png_read(void *closure, unsigned char *data, unsigned int length)
{
    struct png_src *src = closure;
    if (length > src->len - src->at)
        return CAIRO_STATUS_READ_ERROR;
    memcpy(data, src->data + src->at, length);
    src->at += length;
    return CAIRO_STATUS_SUCCESS;
}

int report_png_size(const unsigned char *png, size_t len, unsigned *width, unsigned *height,
                    struct gonio_err *err)
{
    struct png_src src = {png, len, 0};
    cairo_surface_t *surf = cairo_image_surface_create_from_png_stream(png_read, &src);
    cairo_status_t st = cairo_surface_status(surf);
    if (st == CAIRO_STATUS_SUCCESS) {
        *width = (unsigned)cairo_image_surface_get_width(surf);
        *height = (unsigned)cairo_image_surface_get_height(surf);
    }
    cairo_surface_destroy(surf);
    if (st != CAIRO_STATUS_SUCCESS)
        return gonio_err_set(err, GONIO_EBADDATA, "not a readable PNG image (%s)",
                             cairo_status_to_string(st));
    return 0;
}
