/* The standard the simulator mounts (sim/standard_draw.h): exactly its
 * certificate unless the scene names standard_draw; with it, a plaque
 * drawn per scene seed, the same for the same seed, whose reflectance
 * scatters over seeds as the certificate's u and shape u say, and which
 * the material `standard:NAME` of that scene is. */
#include <math.h>
#include <string.h>

#include "sim/scene.h"
#include "sim/standard_draw.h"
#include "tests/gonio_test.h"

static char dir[64];

static int setup(void **state)
{
    (void)state;
    return gonio_test_dir_make(dir, sizeof dir, "stddraw");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

static void scene_with(unsigned long seed, int draw, struct sim_scene *sc)
{
    char path[128], text[512];
    snprintf(path, sizeof path, "%s/scene.yaml", dir);
    snprintf(text, sizeof text,
             "name: draw\nmaterial: standard:spectralon-99\nseed: %lu\neffects:\n"
             "  - {name: read_noise, sigma_e: 1}\n%s",
             seed, draw ? "  - standard_draw\n" : "");
    gonio_test_write_text(path, text);
    struct gonio_err err = {0};
    if (sim_scene_load(path, sc, &err) < 0) {
        print_error("%s\n", err.msg);
        fail();
    }
}

static void truth(const struct sim_scene *sc, struct brdf_standard *s)
{
    struct gonio_err err = {0};
    if (sim_standard_truth(sc, "spectralon-99", s, &err) < 0) {
        print_error("%s\n", err.msg);
        fail();
    }
}

static void test_certificate_without_the_effect(void **state)
{
    (void)state;
    struct sim_scene sc;
    scene_with(7, 0, &sc);
    struct brdf_standard cert, got;
    assert_int_equal(brdf_standard_load("spectralon-99", &cert, NULL), 0);
    truth(&sc, &got);
    assert_memory_equal(&cert, &got, sizeof cert);
}

static void test_drawn_per_seed(void **state)
{
    (void)state;
    struct brdf_standard cert, a, b;
    assert_int_equal(brdf_standard_load("spectralon-99", &cert, NULL), 0);
    struct sim_scene sc;
    scene_with(7, 1, &sc);
    truth(&sc, &a);
    truth(&sc, &b);
    assert_memory_equal(&a, &b, sizeof a); /* the same seed, the same plaque */
    assert_true(a.rho[1] != cert.rho[1]);
    /* the shape and the certificate's own u are the certificate's */
    assert_memory_equal(a.shape, cert.shape, sizeof a.shape);
    assert_memory_equal(a.u_rho, cert.u_rho, sizeof a.u_rho);
    /* the material of that scene is the drawn plaque, under the spec's name */
    struct gonio_err err = {0};
    brdf_material *m = sim_material_open(&sc, "standard:spectralon-99", &err);
    assert_non_null(m);
    assert_string_equal(brdf_material_name(m), "standard:spectralon-99");
    struct brdf_pair p;
    brdf_pair_inplane(30, 40, &p);
    double v[3], want[3];
    brdf_material_eval(m, &p, 1, v);
    brdf_standard_brdf(&a, 30, 40, want);
    for (int c = 0; c < 3; c++)
        assert_float_equal(v[c], want[c], 1e-12 * want[c]);
    brdf_material_free(m);
    /* over seeds: the relative error scatters as the budget's reference
     * term, sqrt((u_rho / rho)^2 + u_shape^2), about the certificate; the
     * channels and the wavelengths move together */
    const int draws = gonio_test_small() ? 300 : 2000;
    double s = 0, s2 = 0, want_sd = hypot(cert.u_rho[1] / cert.rho[1], cert.u_shape);
    for (int seed = 1; seed <= draws; seed++) {
        sc.seed = (unsigned long)seed;
        truth(&sc, &a);
        double e = a.rho[1] / cert.rho[1] - 1;
        s += e, s2 += e * e;
        double e0 = a.rho[0] / cert.rho[0] - 1, e_nm = a.rho_nm[3] / cert.rho_nm[3] - 1;
        assert_true(fabs(e0 - e) < 0.1 * fabs(e) + 1e-4);
        assert_true(fabs(e_nm - e) < 0.1 * fabs(e) + 1e-4);
    }
    double mean = s / draws, sd = sqrt(s2 / draws - mean * mean);
    fprintf(stderr, "%d draws: relative error mean %.5f, sd %.5f (stated %.5f)\n", draws, mean,
            sd, want_sd);
    /* within 4 standard errors of the mean and of the sd */
    assert_true(fabs(mean) < 4 * want_sd / sqrt(draws));
    assert_true(fabs(sd / want_sd - 1) < 4 / sqrt(2.0 * draws));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_certificate_without_the_effect),
        cmocka_unit_test(test_drawn_per_seed),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
