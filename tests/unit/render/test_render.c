/* The sphere renderer against an independent evaluation: pixels recomputed
 * from the material directly (normal from the pixel, a frame of the test's
 * own, f * E * cos for the light, (pi/K) sum f L for the environment);
 * only the named effects are computed; background exact; no-data and
 * overflowing values render black and finite. */
#include <string.h>
#include <unistd.h>

#include "brdf/material.h"
#include "brdf/material_private.h"
#include "render/render.h"
#include "render/scene.h"
#include "tests/gonio_test.h"

#define SIZE 32
#define PI 3.14159265358979323846

static float img_a[3 * SIZE * SIZE], img_b[3 * SIZE * SIZE], img_c[3 * SIZE * SIZE];

/* The documented geometry: pixel centre to camera-frame normal. */
static int normal_of(int size, int x, int y, double n[3])
{
    double u = (2.0 * (x + 0.5) / size - 1) * 1.05, v = (1 - 2.0 * (y + 0.5) / size) * 1.05;
    if (u * u + v * v >= 1)
        return 0;
    n[0] = u, n[1] = v, n[2] = sqrt(1 - u * u - v * v);
    return 1;
}

static double dot(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* Any orthonormal frame around n (Gram-Schmidt from the axis least aligned
 * with n): the materials here are isotropic, so the result must not depend
 * on the renderer's choice. */
static void any_frame(const double n[3], double t[3], double b[3])
{
    double a[3] = {0, 0, 0};
    int k = fabs(n[0]) < fabs(n[1]) ? (fabs(n[0]) < fabs(n[2]) ? 0 : 2)
                                    : (fabs(n[1]) < fabs(n[2]) ? 1 : 2);
    a[k] = 1;
    double d = dot(a, n);
    for (int c = 0; c < 3; c++)
        t[c] = a[c] - d * n[c];
    double len = sqrt(dot(t, t));
    for (int c = 0; c < 3; c++)
        t[c] /= len;
    b[0] = n[1] * t[2] - n[2] * t[1];
    b[1] = n[2] * t[0] - n[0] * t[2];
    b[2] = n[0] * t[1] - n[1] * t[0];
}

static void local(const double t[3], const double b[3], const double n[3], const double d[3],
                  double out[3])
{
    out[0] = dot(t, d), out[1] = dot(b, d), out[2] = dot(n, d);
}

static void eval1(const brdf_material *m, const double wi[3], const double wo[3], double f[3])
{
    struct brdf_pair p;
    brdf_pair_from_dirs(wi, wo, &p);
    brdf_material_eval(m, &p, 1, f);
}

static brdf_material *open_or_fail(const char *spec)
{
    struct gonio_err err = {0};
    brdf_material *m = brdf_material_open(spec, &err);
    if (!m) {
        print_error("%s\n", err.msg);
        fail();
    }
    return m;
}

static void scene_with(struct render_scene *sc, int direct, int env)
{
    render_scene_default(sc);
    sc->n_effects = 0;
    if (direct)
        sc->effects[sc->n_effects++] = RENDER_FX_DIRECT;
    if (env)
        sc->effects[sc->n_effects++] = RENDER_FX_ENVIRONMENT;
    double bg[3] = {0.1, 0.2, 0.3};
    memcpy(sc->background, bg, sizeof bg);
    sc->env.samples = 16;
    sc->env.seed = 5;
}

static void render_or_fail(const struct render_scene *sc, const brdf_material *m, float *img,
                           struct render_stats *st)
{
    struct gonio_err err = {0};
    if (render_sphere(sc, m, SIZE, img, st, &err) != 0) {
        print_error("%s\n", err.msg);
        fail();
    }
}

static void test_direct_matches_material(void **state)
{
    (void)state;
    brdf_material *m = open_or_fail("builtin:nylon");
    struct render_scene sc;
    scene_with(&sc, 1, 0);
    double E[3] = {2.0, 3.0, 5.0};
    memcpy(sc.direct.irradiance, E, sizeof E);
    struct render_stats st;
    render_or_fail(&sc, m, img_a, &st);

    long lit = 0, sphere = 0, checked = 0, dark = 0;
    for (int y = 0; y < SIZE; y++)
        for (int x = 0; x < SIZE; x++) {
            const float *px = &img_a[3 * (y * SIZE + x)];
            double n[3], t[3], b[3], wi[3], wo[3], f[3];
            static const double cam[3] = {0, 0, 1};
            if (!normal_of(SIZE, x, y, n)) {
                for (int c = 0; c < 3; c++) /* exactly the background */
                    assert_true(px[c] == (float)sc.background[c]);
                continue;
            }
            sphere++;
            any_frame(n, t, b);
            local(t, b, n, sc.direct.direction, wi);
            local(t, b, n, cam, wo);
            if (wi[2] <= 0) { /* light below the horizon: exactly black */
                for (int c = 0; c < 3; c++)
                    assert_true(px[c] == 0.0f);
                dark++;
                continue;
            }
            lit++;
            eval1(m, wi, wo, f);
            for (int c = 0; c < 3; c++)
                assert_close(px[c], f[c] * E[c] * wi[2], 2e-6 * f[c] * E[c] * wi[2] + 1e-9);
            checked++;
        }
    assert_int_equal(st.sphere_pixels, sphere);
    assert_int_equal(st.pixels, SIZE * SIZE);
    assert_int_equal(st.evaluations, lit); /* one per lit pixel: nothing else computed */
    assert_int_equal(st.no_data, 0);
    assert_true(checked > 300 && dark > 50);
    brdf_material_free(m);
}

/* The environment recomputed from the documented frame and direction set. */
static void test_environment_matches_material(void **state)
{
    (void)state;
    brdf_material *m = open_or_fail("builtin:nylon");
    struct render_scene sc;
    scene_with(&sc, 0, 1);
    struct render_stats st;
    render_or_fail(&sc, m, img_a, &st);
    int pix[][2] = {{16, 16}, {3, 16}, {26, 6}, {16, 30}, {9, 22}, {16, 1}, {1, 16}, {4, 7}};
    for (size_t i = 0; i < sizeof pix / sizeof pix[0]; i++) {
        double n[3], t[3], b[3], wo[3], sum[3] = {0, 0, 0};
        assert_true(normal_of(SIZE, pix[i][0], pix[i][1], n));
        double s = 1 / (1 + n[2]);
        t[0] = 1 - n[0] * n[0] * s, t[1] = -n[0] * n[1] * s, t[2] = -n[0];
        b[0] = -n[0] * n[1] * s, b[1] = 1 - n[1] * n[1] * s, b[2] = -n[1];
        wo[0] = t[2], wo[1] = b[2], wo[2] = n[2];
        for (int k = 0; k < sc.env.samples; k++) {
            double d[3], world[3], L[3], f[3];
            render_env_direction(&sc.env, k, d);
            assert_true(d[2] > 0);
            assert_close(dot(d, d), 1, 1e-12);
            for (int c = 0; c < 3; c++)
                world[c] = d[0] * t[c] + d[1] * b[c] + d[2] * n[c];
            /* the environment's radiance by its documented formula */
            for (int c = 0; c < 3; c++)
                L[c] = world[1] < 0 ? sc.env.ground[c]
                                    : sc.env.horizon[c] + (sc.env.sky[c] - sc.env.horizon[c]) *
                                                              world[1];
            eval1(m, d, wo, f);
            for (int c = 0; c < 3; c++)
                sum[c] += f[c] * L[c] * PI / sc.env.samples;
        }
        const float *px = &img_a[3 * (pix[i][1] * SIZE + pix[i][0])];
        for (int c = 0; c < 3; c++)
            assert_close(px[c], sum[c], 2e-6 * sum[c] + 1e-9);
    }
    assert_int_equal(st.evaluations, st.sphere_pixels * sc.env.samples);
    brdf_material_free(m);
}

/* Under a constant sky the estimate converges to the hemispherical integral
 * of f cos, computed here by a fine midpoint rule: the direction set is a
 * fair cosine-weighted one, not merely the one the renderer uses. */
static void test_environment_converges(void **state)
{
    (void)state;
    brdf_material *m = open_or_fail("builtin:nylon");
    struct render_scene sc;
    scene_with(&sc, 0, 1);
    for (int c = 0; c < 3; c++)
        sc.env.sky[c] = sc.env.horizon[c] = sc.env.ground[c] = 1.0;
    sc.env.samples = 1024;
    struct render_stats st;
    struct gonio_err err = {0};
    float small[3 * 8 * 8];
    assert_int_equal(render_sphere(&sc, m, 8, small, &st, &err), 0);
    int x = 2, y = 3; /* an oblique view */
    double n[3], t[3], b[3], wo[3];
    static const double cam[3] = {0, 0, 1};
    assert_true(normal_of(8, x, y, n));
    any_frame(n, t, b);
    local(t, b, n, cam, wo);
    double sum[3] = {0, 0, 0};
    int nt = 300, np = 600;
    for (int i = 0; i < nt; i++)
        for (int j = 0; j < np; j++) {
            double th = (i + 0.5) * (PI / 2) / nt, ph = (j + 0.5) * 2 * PI / np, f[3];
            double wi[3] = {sin(th) * cos(ph), sin(th) * sin(ph), cos(th)};
            eval1(m, wi, wo, f);
            double dw = sin(th) * (PI / 2 / nt) * (2 * PI / np);
            for (int c = 0; c < 3; c++)
                sum[c] += f[c] * cos(th) * dw;
        }
    for (int c = 0; c < 3; c++)
        assert_rel_close(small[3 * (y * 8 + x) + c], sum[c], 2e-3);
    brdf_material_free(m);
}

/* direct + environment = direct alone + environment alone; the
 * environment lights what the light does not reach. */
static void test_effects_add_up(void **state)
{
    (void)state;
    brdf_material *m = open_or_fail("builtin:nylon");
    struct render_scene sc;
    struct render_stats sd, se, sb;
    scene_with(&sc, 1, 0);
    render_or_fail(&sc, m, img_a, &sd);
    scene_with(&sc, 0, 1);
    render_or_fail(&sc, m, img_b, &se);
    scene_with(&sc, 1, 1);
    render_or_fail(&sc, m, img_c, &sb);
    long shadow_lit = 0;
    for (int i = 0; i < SIZE * SIZE; i++) {
        double n[3];
        int on = normal_of(SIZE, i % SIZE, i / SIZE, n);
        for (int c = 0; c < 3; c++) {
            float d = img_a[3 * i + c], e = img_b[3 * i + c], both = img_c[3 * i + c];
            if (!on) {
                assert_true(d == (float)sc.background[c] && e == d && both == d);
                continue;
            }
            assert_close(both, (double)d + e, 1e-6 * (d + e) + 1e-9);
            if (c == 0 && d == 0.0f && e > 0)
                shadow_lit++;
        }
    }
    assert_true(shadow_lit > 50);
    assert_int_equal(sb.evaluations, sd.evaluations + se.evaluations);

    /* no effects: a black sphere, nothing evaluated */
    scene_with(&sc, 0, 0);
    render_or_fail(&sc, m, img_a, &sd);
    assert_int_equal(sd.evaluations, 0);
    for (int i = 0; i < SIZE * SIZE; i++) {
        double n[3];
        if (normal_of(SIZE, i % SIZE, i / SIZE, n))
            assert_true(img_a[3 * i] == 0.0f);
    }
    brdf_material_free(m);
}

/* A material with no data for theta_h > 0.5 rad and an overflow at grazing
 * difference angles, constant elsewhere. */
static void holey_eval(const void *priv, const struct brdf_pair *p, size_t n, double *rgb)
{
    (void)priv;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            rgb[3 * i + c] = p[i].theta_h > 0.5 ? NAN : p[i].theta_d > 1.3 ? INFINITY : 1 / PI;
}

static void test_no_data_renders_black(void **state)
{
    (void)state;
    static const struct brdf_material_ops ops = {"holey", holey_eval, NULL};
    brdf_material *m = brdf_material_new(&ops, NULL, "holey");
    assert_non_null(m);
    struct render_scene sc;
    struct render_stats st;
    scene_with(&sc, 1, 1);
    render_or_fail(&sc, m, img_a, &st);
    assert_true(st.no_data > 0);
    for (int i = 0; i < 3 * SIZE * SIZE; i++)
        assert_true(isfinite(img_a[i]));
    /* direct only: a pixel whose one pair has no data is black */
    scene_with(&sc, 1, 0);
    render_or_fail(&sc, m, img_a, &st);
    long holes = 0, plain = 0;
    for (int y = 0; y < SIZE; y++)
        for (int x = 0; x < SIZE; x++) {
            double n[3], t[3], b[3], wi[3], wo[3];
            static const double cam[3] = {0, 0, 1};
            if (!normal_of(SIZE, x, y, n))
                continue;
            any_frame(n, t, b);
            local(t, b, n, sc.direct.direction, wi);
            local(t, b, n, cam, wo);
            if (wi[2] <= 0)
                continue;
            struct brdf_pair p;
            brdf_pair_from_dirs(wi, wo, &p);
            const float *px = &img_a[3 * (y * SIZE + x)];
            if (p.theta_h > 0.5 || p.theta_d > 1.3) {
                assert_true(px[0] == 0.0f && px[1] == 0.0f && px[2] == 0.0f);
                holes++;
            } else {
                assert_close(px[0], sc.direct.irradiance[0] * wi[2] / PI, 1e-6);
                plain++;
            }
        }
    assert_true(holes > 10 && plain > 10);
    assert_int_equal(st.no_data, holes);
    brdf_material_free(m);
}

/* Real measured data at the rim: grazing views stay finite. */
static void test_rim_finite_nbrdf(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    static const char *specs[] = {"nbrdf:nylon", "nbrdf:gold-metallic-paint", "abc:nylon"};
    for (size_t k = 0; k < sizeof specs / sizeof specs[0]; k++) {
        brdf_material *m = open_or_fail(specs[k]);
        struct render_scene sc;
        struct render_stats st;
        scene_with(&sc, 1, 1);
        /* a light grazing the visible rim from the side */
        double dir[3] = {1, 0, 0.01};
        double len = sqrt(dot(dir, dir));
        for (int c = 0; c < 3; c++)
            sc.direct.direction[c] = dir[c] / len;
        render_or_fail(&sc, m, img_a, &st);
        for (int i = 0; i < 3 * SIZE * SIZE; i++)
            if (!isfinite(img_a[i])) {
                print_error("%s: pixel %d not finite\n", specs[k], i / 3);
                fail();
            }
        brdf_material_free(m);
    }
}

static void test_bad_size(void **state)
{
    (void)state;
    brdf_material *m = open_or_fail("default");
    struct render_scene sc;
    render_scene_default(&sc);
    struct gonio_err err = {0};
    assert_int_equal(render_sphere(&sc, m, 4, img_a, NULL, &err), -GONIO_EUSAGE);
    assert_non_null(strstr(err.msg, "4"));
    brdf_material_free(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_direct_matches_material),
        cmocka_unit_test(test_environment_matches_material),
        cmocka_unit_test(test_environment_converges),
        cmocka_unit_test(test_effects_add_up),
        cmocka_unit_test(test_no_data_renders_black),
        cmocka_unit_test(test_rim_finite_nbrdf),
        cmocka_unit_test(test_bad_size),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
