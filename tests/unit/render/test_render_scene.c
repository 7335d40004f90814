/* Render scenes: the shipped files load as documented (default.yaml is the
 * built-in default), effects not named are absent, and bad files are
 * refused with path:line:col: key 'x': problem and the value. */
#include <string.h>
#include <unistd.h>

#include "render/scene.h"
#include "tests/gonio_test.h"

static char path[256];

static void write_scene(const char *text)
{
    snprintf(path, sizeof path, "/tmp/gonio-render-scene-%d.yaml", (int)getpid());
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static void expect_error(const char *text, int line, int col, const char *key, const char *what)
{
    write_scene(text);
    struct render_scene sc;
    struct gonio_err err = {0};
    int rc = render_scene_load(path, &sc, &err);
    unlink(path);
    if (rc != -GONIO_EBADCONFIG)
        print_error("rc %d, message '%s'\n", rc, err.msg);
    assert_int_equal(rc, -GONIO_EBADCONFIG);
    char where[400];
    snprintf(where, sizeof where, "%s:%d:%d: key '%s': ", path, line, col, key);
    if (strncmp(err.msg, where, strlen(where)) != 0 || !strstr(err.msg, what)) {
        print_error("message '%s'\nwanted '%s...%s'\n", err.msg, where, what);
        fail();
    }
}

static void test_default_file_is_builtin_default(void **state)
{
    (void)state;
    struct render_scene file, builtin;
    struct gonio_err err = {0};
    if (render_scene_load("default", &file, &err) != 0) {
        print_error("%s\n", err.msg);
        fail();
    }
    render_scene_default(&builtin);
    assert_string_equal(file.name, "default");
    assert_int_equal(file.n_effects, builtin.n_effects);
    for (int i = 0; i < file.n_effects; i++)
        assert_int_equal(file.effects[i], builtin.effects[i]);
    for (int c = 0; c < 3; c++) {
        assert_close(file.direct.direction[c], builtin.direct.direction[c], 1e-15);
        assert_close(file.direct.irradiance[c], builtin.direct.irradiance[c], 1e-15);
        assert_close(file.env.sky[c], builtin.env.sky[c], 0);
        assert_close(file.env.horizon[c], builtin.env.horizon[c], 0);
        assert_close(file.env.ground[c], builtin.env.ground[c], 0);
        assert_close(file.background[c], builtin.background[c], 0);
    }
    assert_int_equal(file.env.samples, builtin.env.samples);
    assert_int_equal(file.env.seed, builtin.env.seed);
    assert_close(file.exposure, builtin.exposure, 0);
    assert_int_equal(file.curve, builtin.curve);
}

static void test_direct_only_and_parameters(void **state)
{
    (void)state;
    struct render_scene sc;
    struct gonio_err err = {0};
    assert_int_equal(render_scene_load("direct", &sc, &err), 0);
    assert_int_equal(sc.n_effects, 1);
    assert_true(render_scene_has(&sc, RENDER_FX_DIRECT));
    assert_false(render_scene_has(&sc, RENDER_FX_ENVIRONMENT));
    /* direction [-1, 1, 1] is normalised */
    assert_close(sc.direct.direction[0], -1 / sqrt(3.0), 1e-15);
    assert_close(sc.direct.direction[1], 1 / sqrt(3.0), 1e-15);

    write_scene("background: [0.1, 0.2, 0.3]\n"
                "tonemap: {exposure: 2, curve: clamp}\n"
                "effects:\n"
                "  - {name: environment, sky: [1, 1, 1], samples: 16, seed: 9}\n"
                "  - direct\n");
    int rc = render_scene_load(path, &sc, &err);
    unlink(path);
    if (rc)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);
    assert_int_equal(sc.n_effects, 2);
    assert_int_equal(sc.effects[0], RENDER_FX_ENVIRONMENT); /* order of the file */
    assert_int_equal(sc.effects[1], RENDER_FX_DIRECT);
    assert_int_equal(sc.env.samples, 16);
    assert_int_equal(sc.env.seed, 9);
    assert_close(sc.env.sky[1], 1, 0);
    assert_close(sc.background[2], 0.3, 0);
    assert_close(sc.exposure, 2, 0);
    assert_int_equal(sc.curve, RENDER_CURVE_CLAMP);

    write_scene("effects: []\n");
    rc = render_scene_load(path, &sc, &err);
    unlink(path);
    assert_int_equal(rc, 0);
    assert_int_equal(sc.n_effects, 0); /* a black sphere, legal */
}

static void test_bad_scenes(void **state)
{
    (void)state;
    expect_error("effects:\n  - {name: ambient}\n", 2, 12, "name", "unknown effect 'ambient'");
    expect_error("effects:\n  - {name: direct, colour: [1, 1, 1]}\n", 2, 20, "colour",
                 "unknown key");
    expect_error("effects:\n  - {name: environment, samples: 0}\n", 2, 34, "samples", "value '0'");
    expect_error("effects:\n  - {name: environment, samples: 5000}\n", 2, 34, "samples", "5000");
    expect_error("effects:\n  - {name: direct, direction: [0, 0, 0]}\n", 2, 31, "direction",
                 "zero vector (value [0, 0, 0]");
    expect_error("effects:\n  - {name: direct, irradiance: [1, -1, 1]}\n", 2, 36, "irradiance",
                 "-1");
    expect_error("effects:\n  - {name: direct, irradiance: [1, 1]}\n", 2, 32, "irradiance",
                 "length");
    expect_error("effects: [direct, direct]\n", 1, 19, "name", "named twice");
    expect_error("name: x\n", 1, 1, "effects", "missing");
    expect_error("effects: []\nlights: 2\n", 2, 1, "lights", "unknown key");
    expect_error("effects: []\ntonemap: {curve: filmic}\n", 2, 18, "curve", "filmic");

    struct render_scene sc;
    struct gonio_err err = {0};
    assert_int_equal(render_scene_load("no-such-render-scene", &sc, &err), -GONIO_ENOTFOUND);
    assert_non_null(strstr(err.msg, "no-such-render-scene"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_default_file_is_builtin_default),
        cmocka_unit_test(test_direct_only_and_parameters),
        cmocka_unit_test(test_bad_scenes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
