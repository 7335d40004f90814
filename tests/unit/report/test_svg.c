/* The SVG writer, the slices figure and the PNG rasteriser. The SVG files
 * are also parsed as XML by tests/report (Python's xml.etree). */
#include <string.h>

#include <cairo.h>

#include "brdf/material.h"
#include "report/raster.h"
#include "report/slices.h"
#include "report/svg.h"
#include "tests/gonio_test.h"

static size_t count(const char *hay, const char *needle)
{
    size_t n = 0;
    for (const char *p = hay; (p = strstr(p, needle)); p += strlen(needle))
        n++;
    return n;
}

static void text_is_escaped(void **state)
{
    (void)state;
    svg_doc *s = svg_new(100, 50, "9 bad id!");
    svg_text(s, 1, 2, SVG_START, 10, 0, 0, NULL, "a<b & \"c\"\x01>");
    svg_clip_begin(s, 0, 0, 10, 10);
    svg_group_end(s);
    size_t len;
    char *doc = svg_finish(s, &len);
    assert_non_null(doc);
    assert_int_equal(strlen(doc), len);
    assert_non_null(strstr(doc, ">a&lt;b &amp; &quot;c&quot;&gt;</text>"));
    /* ids start with a letter and carry only safe characters */
    assert_non_null(strstr(doc, "id=\"p9badid-clip0\""));
    assert_non_null(strstr(doc, "url(#p9badid-clip0)"));
    free(doc);
}

static void polyline_breaks_at_gaps(void **state)
{
    (void)state;
    svg_doc *s = svg_new(100, 50, "t");
    double x[] = {0, 1, 2, NAN, 4, 5, 6, 7, NAN, 9};
    double y[] = {0, 1, 2, 3, 4, 5, INFINITY, 7, 8, 9};
    svg_polyline(s, x, y, 10, "#000", 1, NULL);
    size_t len;
    char *doc = svg_finish(s, &len);
    /* 0-2 and 4-5 are lines; 7 and 9 stand alone and draw nothing */
    assert_int_equal(count(doc, "<polyline"), 2);
    assert_non_null(strstr(doc, "points=\"0.0,0.0 1.0,1.0 2.0,2.0\""));
    assert_non_null(strstr(doc, "points=\"4.0,4.0 5.0,5.0\""));
    free(doc);
}

static void slices_have_a_panel_per_theta_i(void **state)
{
    (void)state;
    brdf_material *m = brdf_material_open("default", NULL);
    assert_non_null(m);
    const brdf_material *models[] = {m};
    const char *labels[] = {"same as truth"};
    double ti[] = {10, 40, 70};
    struct report_sample sm[] = {{40, 40, {0.5, 0.5, 0.5}}, {40.2, -20, {0.1, 0.1, 0.1}},
                                 {55, 0, {0.1, 0.1, 0.1}}};
    struct report_slices in = {.title = "t",
                               .truth = m,
                               .models = models,
                               .model_labels = labels,
                               .n_models = 1,
                               .samples = sm,
                               .n_samples = 3,
                               .theta_i = ti,
                               .n_theta_i = 3,
                               .channel = REPORT_Y};
    char *svg = NULL;
    size_t len = 0;
    assert_int_equal(report_plot_slices(&in, "s", &svg, &len, NULL), 0);
    assert_int_equal(count(svg, "θi = "), 3);
    assert_non_null(strstr(svg, "θi = 70°"));
    /* truth and model: one curve each per panel (no gaps for this material) */
    assert_int_equal(count(svg, "<polyline"), 6);
    /* the two samples near theta_i = 40 are drawn, the one at 55 is not */
    assert_int_equal(count(svg, "<title>θi 4"), 2);
    assert_int_equal(count(svg, "<title>"), 2);
    assert_non_null(strstr(svg, ">same as truth</text>"));
    free(svg);
    /* a theta_i outside 0..89 is bad input */
    double bad[] = {95};
    in.theta_i = bad;
    in.n_theta_i = 1;
    struct gonio_err err = {0};
    assert_int_equal(report_plot_slices(&in, "s", &svg, &len, &err), -GONIO_EUSAGE);
    assert_non_null(strstr(err.msg, "95"));
    brdf_material_free(m);
}

static void slices_default_panels(void **state)
{
    (void)state;
    /* From the samples: their distinct theta_i, up to six evenly spread. */
    struct report_sample sm[20];
    for (int i = 0; i < 20; i++)
        sm[i] = (struct report_sample){5.0 * (i % 10) + 0.1, 0, {1, 1, 1}};
    struct report_slices in = {.samples = sm, .n_samples = 20};
    double t[REPORT_SLICES_MAX_PANELS];
    assert_int_equal(report_slices_theta_i(&in, t, NULL), 6);
    assert_close(t[0], 0, 0);
    assert_close(t[5], 45, 0);
    /* A six-pair plan at theta_i = 30 and one stray sample at 52: shown
     * among the standard incidences, 30 not twice. */
    for (int i = 0; i < 6; i++)
        sm[i] = (struct report_sample){30.1, -60.0 + 20 * i, {1, 1, 1}};
    sm[6] = (struct report_sample){52, 0, {1, 1, 1}};
    in.n_samples = 7;
    assert_int_equal(report_slices_theta_i(&in, t, NULL), 7);
    const double want[] = {0, 15, 30, 45, 52, 60, 75};
    for (int i = 0; i < 7; i++)
        assert_close(t[i], want[i], 0);
    in.n_samples = 0;
    assert_int_equal(report_slices_theta_i(&in, t, NULL), 6);
    assert_close(t[5], 75, 0);
}

static cairo_status_t read_mem(void *closure, unsigned char *data, unsigned int length)
{
    const unsigned char **p = closure;
    memcpy(data, *p, length);
    *p += length;
    return CAIRO_STATUS_SUCCESS;
}

static void raster_draws_the_svg(void **state)
{
    (void)state;
    /* A 40x20 white document with a black square at (10..20, 5..15). */
    svg_doc *s = svg_new(40, 20, "r");
    svg_rect(s, 10, 5, 10, 10, "#000000", NULL, 0);
    size_t len;
    char *doc = svg_finish(s, &len);
    unsigned char *png = NULL;
    size_t png_len = 0;
    assert_int_equal(report_svg_to_png(doc, len, 2.0, &png, &png_len, NULL), 0);
    unsigned w, h;
    assert_int_equal(report_png_size(png, png_len, &w, &h, NULL), 0);
    assert_int_equal(w, 80);
    assert_int_equal(h, 40);
    const unsigned char *at = png;
    cairo_surface_t *img = cairo_image_surface_create_from_png_stream(read_mem, &at);
    assert_int_equal(cairo_surface_status(img), CAIRO_STATUS_SUCCESS);
    const unsigned char *px = cairo_image_surface_get_data(img);
    int stride = cairo_image_surface_get_stride(img);
    /* ARGB32 in native order: a pixel inside the square is black, one
     * outside white, both opaque. */
    uint32_t inside = *(const uint32_t *)(px + 20 * stride + 30 * 4);
    uint32_t outside = *(const uint32_t *)(px + 4 * stride + 4 * 4);
    assert_int_equal(inside, 0xff000000u);
    assert_int_equal(outside, 0xffffffffu);
    cairo_surface_destroy(img);
    free(png);
    free(doc);
}

static void raster_refuses_bad_documents(void **state)
{
    (void)state;
    unsigned char *png = NULL;
    size_t png_len = 0;
    struct gonio_err err = {0};
    const char *bad = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10\"><rect";
    assert_int_equal(report_svg_to_png(bad, strlen(bad), 1, &png, &png_len, &err),
                     -GONIO_EBADDATA);
    assert_non_null(strstr(err.msg, "SVG"));
    unsigned w, h;
    const unsigned char junk[] = "\x89PNG\r\n\x1a\nnot really";
    assert_int_equal(report_png_size(junk, sizeof junk, &w, &h, &err), -GONIO_EBADDATA);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(text_is_escaped),
        cmocka_unit_test(polyline_breaks_at_gaps),
        cmocka_unit_test(slices_have_a_panel_per_theta_i),
        cmocka_unit_test(slices_default_panels),
        cmocka_unit_test(raster_draws_the_svg),
        cmocka_unit_test(raster_refuses_bad_documents),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
