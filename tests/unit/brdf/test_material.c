/* The material interface: spec parsing and its errors, the embedded
 * default without shared data, embedded figures equal to the shared table,
 * and the no-data count. */
#include <string.h>

#include "brdf/embedded.h"
#include "brdf/material.h"
#include "brdf/material_private.h"
#include "brdf/published.h"
#include "brdf/sgd.h"
#include "tests/gonio_test.h"

static void expect_error(const char *spec, int code, const char *needle)
{
    struct gonio_err err = {0};
    brdf_material *m = brdf_material_open(spec, &err);
    if (m || err.code != code || !strstr(err.msg, spec) || (needle && !strstr(err.msg, needle))) {
        print_error("%s: code %d (want %d), message '%s' should name the spec and '%s'\n", spec,
                    err.code, code, err.msg, needle ? needle : "");
        brdf_material_free(m);
        fail();
    }
    assert_null(strchr(err.msg, '\n'));
}

static void test_bad_specs(void **state)
{
    (void)state;
    expect_error("phong:white", GONIO_EBADCONFIG, "unknown material kind");
    expect_error("nylon", GONIO_EBADCONFIG, "unknown material kind");
    expect_error("nbrdf:", GONIO_EBADCONFIG, "missing name");
    expect_error("builtin:no-such", GONIO_ENOTFOUND, "no-such");
    expect_error("merl:/nonexistent/dir/x.binary", GONIO_ENOTFOUND, "/nonexistent/dir/x.binary");
    expect_error("nbrdf:/nonexistent/dir/x.nbrdf", GONIO_ENOTFOUND, "/nonexistent/dir/x.nbrdf");
    if (gonio_shared_dir()) {
        expect_error("nbrdf:no-such-material", GONIO_ENOTFOUND, "no-such-material.nbrdf");
        expect_error("abc:no-such-material", GONIO_ENOTFOUND, "abc_low2012_merl.csv");
        expect_error("sgd:no-such-material", GONIO_ENOTFOUND, "sgd_bagher2012_merl.csv");
    }
    struct gonio_err err = {0};
    assert_null(brdf_material_open("", &err));
    assert_int_equal(err.code, GONIO_EBADCONFIG);
}

/* `default` needs no shared folder: point GONIO_SHARED at nothing. */
static void test_default_without_shared(void **state)
{
    (void)state;
    char *saved = getenv("GONIO_SHARED") ? strdup(getenv("GONIO_SHARED")) : NULL;
    setenv("GONIO_SHARED", "/nonexistent/gonio-shared", 1);
    assert_null(gonio_shared_dir());

    struct gonio_err err = {0};
    brdf_material *m = brdf_material_open("default", &err);
    assert_non_null(m);
    assert_string_equal(brdf_material_name(m), "default");
    assert_int_equal(strncmp(brdf_material_default_spec(), "builtin:", 8), 0);

    /* It is the SGD model with the embedded parameters of that name. */
    struct brdf_sgd p;
    assert_int_equal(brdf_embedded_sgd(brdf_material_default_spec() + 8, &p), 0);
    struct brdf_pair g[3];
    brdf_pair_inplane(30, 30, &g[0]);
    brdf_pair_inplane(30, -10, &g[1]);
    brdf_pair_inplane(60, 45, &g[2]);
    double rgb[9], want[3];
    assert_int_equal(brdf_material_eval(m, g, 3, rgb), 0);
    for (int i = 0; i < 3; i++) {
        brdf_sgd_eval(&p, &g[i], want);
        for (int c = 0; c < 3; c++) {
            assert_close(rgb[3 * i + c], want[c], 0);
            assert_true(rgb[3 * i + c] > 0);
        }
    }
    /* glossy: the mirror value stands above the off-specular one */
    assert_true(rgb[1] > 1.5 * rgb[4]);
    brdf_material_free(m);

    for (size_t i = 0; i < brdf_embedded_count(); i++) {
        char spec[128];
        snprintf(spec, sizeof spec, "builtin:%s", brdf_embedded_name(i));
        m = brdf_material_open(spec, &err);
        assert_non_null(m);
        assert_string_equal(brdf_material_name(m), spec);
        brdf_material_free(m);
    }
    expect_error("nbrdf:nylon", GONIO_ENOTFOUND, "shared data folder not found");

    if (saved)
        setenv("GONIO_SHARED", saved, 1);
    else
        unsetenv("GONIO_SHARED");
    free(saved);
}

/* The embedded figures are the shared table's, digit for digit. */
static void test_embedded_equals_shared_table(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    assert_true(brdf_embedded_count() >= 3);
    for (size_t i = 0; i < brdf_embedded_count(); i++) {
        const char *name = brdf_embedded_name(i);
        struct brdf_sgd emb, pub;
        struct gonio_err err = {0};
        assert_int_equal(brdf_embedded_sgd(name, &emb), 0);
        if (brdf_published_sgd(name, &pub, &err) != 0) {
            print_error("%s\n", err.msg);
            fail();
        }
        const double *a = &emb.rho_d[0], *b = &pub.rho_d[0];
        for (size_t k = 0; k < sizeof emb / sizeof(double); k++)
            assert_close(a[k], b[k], 0);
    }
    assert_null(brdf_embedded_name(brdf_embedded_count()));
}

/* A backend that reports no data for every other pair. */
static void half_missing(const void *priv, const struct brdf_pair *pairs, size_t n, double *rgb)
{
    (void)priv;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            rgb[3 * i + c] = i % 2 ? NAN : pairs[i].theta_d;
}

static int freed;
static void count_free(void *priv)
{
    (void)priv;
    freed++;
}

static void test_nan_count_and_ownership(void **state)
{
    (void)state;
    static const struct brdf_material_ops ops = {"test", half_missing, count_free};
    freed = 0;
    brdf_material *m = brdf_material_new(&ops, &freed, NULL);
    assert_non_null(m);
    assert_string_equal(brdf_material_name(m), "test");
    struct brdf_pair g[5];
    for (int i = 0; i < 5; i++)
        brdf_pair_inplane(10 * i, 5, &g[i]);
    double rgb[15];
    assert_int_equal(brdf_material_eval(m, g, 5, rgb), 2);
    brdf_material_free(m);
    assert_int_equal(freed, 1);
    brdf_material_free(NULL);
}

static void test_shared_kinds_open(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    const char *specs[] = {"nbrdf:nylon", "abc:nylon", "sgd:nylon"};
    for (size_t s = 0; s < 3; s++) {
        struct gonio_err err = {0};
        brdf_material *m = brdf_material_open(specs[s], &err);
        if (!m) {
            print_error("%s\n", err.msg);
            fail();
        }
        assert_string_equal(brdf_material_name(m), specs[s]);
        struct brdf_pair g;
        brdf_pair_inplane(30, 0, &g);
        double rgb[3];
        assert_int_equal(brdf_material_eval(m, &g, 1, rgb), 0);
        /* nylon is a white-ish diffuse material: about 0.065/sr off-peak */
        for (int c = 0; c < 3; c++)
            assert_true(rgb[c] > 0.04 && rgb[c] < 0.1);
        brdf_material_free(m);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bad_specs),
        cmocka_unit_test(test_default_without_shared),
        cmocka_unit_test(test_embedded_equals_shared_table),
        cmocka_unit_test(test_nan_count_and_ownership),
        cmocka_unit_test(test_shared_kinds_open),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
