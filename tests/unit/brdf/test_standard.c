/* Reflectance standards (brdf/standard.h): the shipped Spectralon file read
 * with its certificate and non-Lambertian shape, the `standard:` material
 * equal to rho/pi times that shape, a bare rho and a shapeless file taken
 * as Lambertian with a warning, and bad files refused naming the field. */
#include "brdf/angles.h"
#include "brdf/material.h"
#include "brdf/standard.h"
#include "tests/gonio_test.h"

#define PI 3.14159265358979323846

static char dir[64];

static int setup(void **state)
{
    (void)state;
    return gonio_test_dir_make(dir, sizeof dir, "standard");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

static void test_shipped_spectralon(void **state)
{
    (void)state;
    struct brdf_standard s;
    struct gonio_err err = {0};
    assert_int_equal(brdf_standard_load("spectralon-99", &s, &err), 0);
    assert_string_equal(s.name, "spectralon-99");
    assert_string_equal(s.warning, "");
    for (int c = 0; c < 3; c++) {
        assert_close(s.rho[c], 0.99, 0.004);
        assert_close(s.u_rho[c], 0.005, 0.0005);
    }
    /* -10 % at 60 deg view for normal incidence, more at grazing. */
    double r60 = brdf_standard_shape(&s, 0, 60) / brdf_standard_shape(&s, 0, 0);
    assert_close(r60, 0.90, 0.005);
    assert_true(brdf_standard_shape(&s, 0, 80) < brdf_standard_shape(&s, 0, 60));
    /* Oblique incidence lifts the mirror side above the back side. */
    assert_true(brdf_standard_shape(&s, 60, 70) > brdf_standard_shape(&s, 60, -70) + 0.05);
    /* Between grid nodes the shape is bilinear. */
    double mid = brdf_standard_shape(&s, 7.5, 52.5);
    /* view_deg 45 and 60 are columns 9 and 10, incidence 0 and 15 rows 0 and 1. */
    double corners = (s.shape[0][9] + s.shape[0][10] + s.shape[1][9] + s.shape[1][10]) / 4;
    assert_close(mid, corners, 1e-12);
    /* On a node, the file's value: incidence 45, view 60 reads 0.943. */
    assert_close(brdf_standard_shape(&s, 45, 60), 0.943, 1e-12);
    assert_close(brdf_standard_shape(&s, -45, 60), 0.943, 1e-12);
}

static void test_material_follows_the_file(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    brdf_material *m = brdf_material_open("standard:spectralon-99", &err);
    assert_non_null(m);
    struct brdf_standard s;
    assert_int_equal(brdf_standard_load("spectralon-99", &s, &err), 0);
    const double geo[][2] = {{0, 0}, {0, 60}, {45, 30}, {45, -70}, {60, 75}};
    for (size_t k = 0; k < sizeof geo / sizeof geo[0]; k++) {
        struct brdf_pair p;
        brdf_pair_inplane(geo[k][0], geo[k][1], &p);
        double rgb[3];
        assert_int_equal(brdf_material_eval(m, &p, 1, rgb), 0);
        double shape = brdf_standard_shape(&s, geo[k][0], geo[k][1]);
        for (int c = 0; c < 3; c++)
            assert_rel_close(rgb[c], s.rho[c] / PI * shape, 1e-9);
    }
    brdf_material_free(m);
}

static void write_std(const char *name, const char *body, char *path, size_t size)
{
    snprintf(path, size, "%s/%s.yaml", dir, name);
    gonio_test_write_text(path, body);
}

static void test_lambertian_with_warning(void **state)
{
    (void)state;
    char path[256];
    struct brdf_standard s;
    struct gonio_err err = {0};
    write_std("bare", "name: bare\ncertificate: none\nreflectance: 0.98\n", path, sizeof path);
    assert_int_equal(brdf_standard_load(path, &s, &err), 0);
    assert_close(s.rho[1], 0.98, 1e-12);
    assert_non_null(strstr(s.warning, "rho/pi"));
    assert_close(brdf_standard_shape(&s, 0, 60), 1.0, 0);
    write_std("flat", "name: flat\ncertificate: c\nreflectance:\n  rgb: [0.5, 0.5, 0.5]\n"
              "  u: [0.01, 0.01, 0.01]\n", path, sizeof path);
    assert_int_equal(brdf_standard_load(path, &s, &err), 0);
    assert_non_null(strstr(s.warning, "Lambertian"));
    assert_close(s.u_rho[2], 0.01, 1e-12);
    /* A spectrally flat certificate is grey in RGB. */
    write_std("spec", "name: spec\ncertificate: c\nreflectance:\n"
              "  wavelength_nm: [400, 550, 700]\n  value: [0.5, 0.5, 0.5]\n"
              "  u: [0.01, 0.01, 0.01]\n", path, sizeof path);
    assert_int_equal(brdf_standard_load(path, &s, &err), 0);
    for (int c = 0; c < 3; c++) {
        assert_close(s.rho[c], 0.5, 0.002);
        assert_close(s.u_rho[c], 0.01, 0.0005);
    }
    /* Dropping the shipped standard's shape is what "as rho/pi" means. */
    assert_int_equal(brdf_standard_load("spectralon-99", &s, &err), 0);
    brdf_standard_as_lambertian(&s);
    assert_close(brdf_standard_shape(&s, 0, 60), 1.0, 0);
}

static void expect_refusal(const char *body, const char *needle)
{
    char path[256];
    struct brdf_standard s;
    struct gonio_err err = {0};
    write_std("bad", body, path, sizeof path);
    assert_int_equal(brdf_standard_load(path, &s, &err), -GONIO_EBADCONFIG);
    if (!strstr(err.msg, needle) || !strstr(err.msg, "bad.yaml")) {
        print_error("message '%s' lacks '%s' or the file\n", err.msg, needle);
        fail();
    }
}

static void test_bad_files_refused(void **state)
{
    (void)state;
    const char *head = "name: b\ncertificate: c\nreflectance:\n  rgb: [0.9, 0.9, 0.9]\n"
                       "  u: [0.01, 0.01, 0.01]\n";
    char body[1024];
    snprintf(body, sizeof body, "%sangular:\n  incidence_deg: [0, 30]\n  view_deg: [0, 30]\n"
             "  factor:\n    - [1, 1]\n    - [1]\n  u: 0.01\n", head);
    expect_refusal(body, "row 2");
    snprintf(body, sizeof body, "%sangular:\n  incidence_deg: [0, 30]\n  view_deg: [30, 0]\n"
             "  factor:\n    - [1, 1]\n    - [1, 1]\n  u: 0.01\n", head);
    expect_refusal(body, "view_deg");
    snprintf(body, sizeof body, "%sangular:\n  incidence_deg: [0]\n  view_deg: [0]\n"
             "  factor:\n    - [1]\n", head);
    expect_refusal(body, "'u'");
    expect_refusal("name: b\ncertificate: c\nreflectance:\n  rgb: [0.9, 0.9]\n"
                   "  u: [0.01, 0.01, 0.01]\n", "rgb");
    expect_refusal("name: b\ncertificate: c\nreflectance: 0.9\ncolour: white\n", "colour");
    expect_refusal("name: b\nreflectance: 0.9\n", "certificate");
    struct brdf_standard s;
    struct gonio_err err = {0};
    assert_int_equal(brdf_standard_load("no-such-standard", &s, &err), -GONIO_ENOTFOUND);
    assert_non_null(strstr(err.msg, "no-such-standard"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_shipped_spectralon),
        cmocka_unit_test(test_material_follows_the_file),
        cmocka_unit_test(test_lambertian_with_warning),
        cmocka_unit_test(test_bad_files_refused),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
