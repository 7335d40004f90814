/* A written set read back by other readers: the EXR through the OpenEXR
 * Core API (brdf_exr_read_rgb) equals the render; the PNG through libpng has
 * the size, the sRGB tag and, at known pixels, the sRGB code of the
 * tone-mapped EXR value computed here from the IEC 61966-2-1 formula; the
 * grid holds each image in its cell and the background between; render.json
 * names the files. */
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <jansson.h>
#include <png.h>

#include "brdf/exr.h"
#include "brdf/material_private.h"
#include "render/output.h"
#include "render/render.h"
#include "render/tonemap.h"
#include "tests/gonio_test.h"

#define SIZE 24

static char tmpdir[4096];

static int setup_tmp(void **state)
{
    (void)state;
    const char *base = getenv("GONIO_TMP");
    if (!base || !*base)
        base = "/tmp";
    gonio_mkdir_p(base, NULL);
    snprintf(tmpdir, sizeof tmpdir, "%s/test_render_output.XXXXXX", base);
    return mkdtemp(tmpdir) ? 0 : -1;
}

static float *read_exr(const char *name, int *w, int *h)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", tmpdir, name);
    float *rgb = NULL;
    struct gonio_err err = {0};
    if (brdf_exr_read_rgb(path, w, h, &rgb, &err) != 0) {
        print_error("%s\n", err.msg);
        fail();
    }
    return rgb;
}

static uint8_t *read_png(const char *name, int *w, int *h, int *srgb_tagged)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", tmpdir, name);
    png_image img;
    memset(&img, 0, sizeof img);
    img.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&img, path)) {
        print_error("%s: %s\n", path, img.message);
        fail();
    }
    *srgb_tagged = !(img.flags & PNG_IMAGE_FLAG_COLORSPACE_NOT_sRGB);
    assert_int_equal(img.format & PNG_FORMAT_FLAG_COLOR, PNG_FORMAT_FLAG_COLOR);
    assert_int_equal(img.format & PNG_FORMAT_FLAG_ALPHA, 0);
    img.format = PNG_FORMAT_RGB;
    uint8_t *buf = malloc(PNG_IMAGE_SIZE(img));
    assert_non_null(buf);
    assert_true(png_image_finish_read(&img, NULL, buf, 0, NULL));
    *w = (int)img.width;
    *h = (int)img.height;
    return buf;
}

/* The expected 8-bit code, independently of render/tonemap.c. */
static int srgb8_reinhard(double v, double exposure)
{
    v *= exposure;
    v = v > 0 ? v / (1 + v) : 0;
    double e = v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1 / 2.4) - 0.055;
    return (int)floor(255 * e + 0.5);
}

/* A grey diffuser (albedo 0.4), so the cells differ without shared data. */
static void grey_eval(const void *priv, const struct brdf_pair *p, size_t n, double *rgb)
{
    (void)priv;
    (void)p;
    for (size_t i = 0; i < 3 * n; i++)
        rgb[i] = 0.4 / 3.14159265358979323846;
}

static void test_set_with_grid(void **state)
{
    (void)state;
    static const struct brdf_material_ops grey = {"grey", grey_eval, NULL};
    struct gonio_err err = {0};
    brdf_material *a = brdf_material_open("builtin:nylon", &err);
    brdf_material *b = brdf_material_new(&grey, NULL, "grey");
    assert_non_null(a);
    assert_non_null(b);
    struct render_scene sc;
    render_scene_default(&sc);
    sc.env.samples = 8;
    sc.exposure = 1.7;
    sc.background[1] = 0.25;
    struct render_item items[] = {{"builtin:nylon", "truth", a},
                                  {"model:fits/grey.json", NULL, b},
                                  {"model:fits/grey.json", NULL, b}}; /* repeated: -2 */
    struct render_set_options opt = {SIZE, 1, 2, NULL};
    if (render_write_set(tmpdir, &sc, items, 3, &opt, &err) != 0) {
        print_error("%s\n", err.msg);
        fail();
    }

    /* the EXR is the render */
    static float direct[3 * SIZE * SIZE];
    assert_int_equal(render_sphere(&sc, b, SIZE, direct, NULL, &err), 0);
    int w, h;
    float *exr = read_exr("model-fits-grey.json.exr", &w, &h);
    assert_int_equal(w, SIZE);
    assert_int_equal(h, SIZE);
    assert_memory_equal(exr, direct, sizeof direct);
    float *exr2 = read_exr("model-fits-grey.json-2.exr", &w, &h);
    assert_memory_equal(exr2, direct, sizeof direct);
    free(exr2);

    /* the PNG: size, sRGB tag, known pixels */
    int tagged;
    uint8_t *png = read_png("model-fits-grey.json.png", &w, &h, &tagged);
    assert_int_equal(w, SIZE);
    assert_int_equal(h, SIZE);
    assert_true(tagged);
    int pix[][2] = {{12, 12}, {6, 8}, {18, 18}, {0, 0}, {20, 4}};
    int nonblack = 0;
    for (size_t i = 0; i < sizeof pix / sizeof pix[0]; i++)
        for (int c = 0; c < 3; c++) {
            size_t k = 3 * ((size_t)pix[i][1] * SIZE + (size_t)pix[i][0]) + (size_t)c;
            int want = srgb8_reinhard(exr[k], sc.exposure);
            if (png[k] != want) {
                print_error("pixel (%d, %d) channel %d: %d, expected %d from %g\n", pix[i][0],
                            pix[i][1], c, png[k], want, exr[k]);
                fail();
            }
            nonblack += want > 0;
        }
    assert_true(nonblack > 9);
    free(png);

    /* grid: 2 columns, 2 rows, gap of background */
    float *grid = read_exr("grid.exr", &w, &h);
    assert_int_equal(w, 2 * SIZE + RENDER_GRID_GAP);
    assert_int_equal(h, 2 * SIZE + RENDER_GRID_GAP);
    float *truth = read_exr("truth.exr", &w, &h);
    for (int y = 0; y < SIZE; y++)
        for (int x = 0; x < SIZE; x++)
            for (int c = 0; c < 3; c++) {
                int gw = 2 * SIZE + RENDER_GRID_GAP;
                size_t k = 3 * ((size_t)y * SIZE + (size_t)x) + (size_t)c;
                assert_true(grid[3 * (y * gw + x) + c] == truth[k]);                   /* cell 0 */
                assert_true(grid[3 * (y * gw + x + SIZE + RENDER_GRID_GAP) + c] == exr[k]); /* 1 */
                assert_true(grid[3 * ((y + SIZE + RENDER_GRID_GAP) * gw + x) + c] == exr[k]); /* 2 */
                /* cell 3 is empty: background */
                assert_true(grid[3 * ((y + SIZE + RENDER_GRID_GAP) * gw + x + SIZE +
                                      RENDER_GRID_GAP) + c] == (float)sc.background[c]);
            }
    int gw = 2 * SIZE + RENDER_GRID_GAP;
    for (int c = 0; c < 3; c++) /* the gap */
        assert_true(grid[3 * (5 * gw + SIZE + 1) + c] == (float)sc.background[c]);
    uint8_t *gpng = read_png("grid.png", &w, &h, &tagged);
    assert_int_equal(w, gw);
    free(gpng);
    free(grid);
    free(truth);
    free(exr);

    /* render.json names every file, and they exist */
    char path[4200];
    snprintf(path, sizeof path, "%s/render.json", tmpdir);
    json_error_t jerr;
    json_t *root = json_load_file(path, 0, &jerr);
    assert_non_null(root);
    assert_int_equal(json_integer_value(json_object_get(root, "size")), SIZE);
    json_t *images = json_object_get(root, "images");
    assert_int_equal(json_array_size(images), 3);
    const char *want_stems[] = {"truth", "model-fits-grey.json", "model-fits-grey.json-2"};
    for (size_t i = 0; i < 3; i++) {
        json_t *im = json_array_get(images, i);
        const char *exrname = json_string_value(json_object_get(im, "exr"));
        char want[80];
        snprintf(want, sizeof want, "%s.exr", want_stems[i]);
        assert_string_equal(exrname, want);
        struct stat sb;
        snprintf(path, sizeof path, "%s/%s", tmpdir,
                 json_string_value(json_object_get(im, "png")));
        assert_int_equal(stat(path, &sb), 0);
        assert_true(json_integer_value(json_object_get(im, "evaluations")) > 0);
    }
    json_t *g = json_object_get(root, "grid");
    assert_int_equal(json_integer_value(json_object_get(g, "columns")), 2);
    assert_int_equal(json_integer_value(json_object_get(g, "rows")), 2);
    assert_string_equal(json_string_value(json_array_get(json_object_get(g, "cells"), 0)),
                        "truth");
    json_decref(root);
    brdf_material_free(a);
    brdf_material_free(b);
}

static void test_stems(void **state)
{
    (void)state;
    char s[64];
    render_file_stem("model:fits/ds1 abc.json", s, sizeof s);
    assert_string_equal(s, "model-fits-ds1-abc.json");
    render_file_stem("../x", s, sizeof s);
    assert_string_equal(s, "_.-x");
    render_file_stem("", s, sizeof s);
    assert_string_equal(s, "image");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_set_with_grid),
        cmocka_unit_test(test_stems),
    };
    return cmocka_run_group_tests(tests, setup_tmp, NULL);
}
