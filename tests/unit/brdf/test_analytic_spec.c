/* Parametric analytic materials (brdf/analytic_spec.h, analytic_aniso.h):
 * a spec's parameters reach the material (defaults and R:G:B included);
 * every bad parameter is refused naming it and its value; the anisotropic
 * lobe has its closed form at the normal mirror, swaps its roughnesses
 * with a quarter turn of its tangent, turns with the sample
 * (brdf_pair_rotate), is reciprocal and finite to the horizon, and is
 * refused by the MERL export; two-lobe is the layered form's two lobes. */
#include <string.h>
#include <unistd.h>

#include "brdf/analytic_spec.h"
#include "brdf/domain.h"
#include "brdf/material.h"
#include "brdf/merl.h"
#include "tests/gonio_test.h"

#define PI 3.14159265358979323846

static const char *const aniso_spec = "analytic:aniso-ggx?ax=0.08&ay=0.3&phi=20";

static void test_parameters_reach_the_material(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    struct brdf_aniso_ggx a;
    assert_int_equal(brdf_analytic_spec_aniso(aniso_spec, aniso_spec + 9, &a, &err), 0);
    assert_close(a.ax, 0.08, 0);
    assert_close(a.ay, 0.3, 0);
    assert_close(a.phi_deg, 20, 0);
    assert_close(a.rho[1], 0.05, 0); /* defaults */
    assert_close(a.f0[2], 0.9, 0);
    const char *rgb = "analytic:aniso-ggx?f0=0.5&ay=0.2&rho_d=0.1:0.2:0.3&ax=0.1";
    assert_int_equal(brdf_analytic_spec_aniso(rgb, rgb + 9, &a, &err), 0);
    assert_close(a.rho[0], 0.1, 0);
    assert_close(a.rho[2], 0.3, 0);
    assert_close(a.f0[0], 0.5, 0);
    assert_close(a.f0[2], 0.5, 0);
    assert_close(a.phi_deg, 0, 0);
    struct brdf_analytic t;
    const char *two = "analytic:two-lobe?a1=0.05&w1=0.6&a2=0.3&w2=0.4&eta=1.7";
    assert_int_equal(brdf_analytic_spec_two_lobe(two, two + 9, &t, &err), 0);
    assert_int_equal(t.lobes, 2);
    assert_close(t.alpha[0], 0.05, 0);
    assert_close(t.weight[0], 0.6, 0);
    assert_close(t.alpha[1], 0.3, 0);
    assert_close(t.weight[1], 0.4, 0);
    assert_close(t.eta, 1.7, 0);
    assert_close(t.rho[0], 0.1, 0);
}

static void refused(const char *spec, const char *w1, const char *w2)
{
    struct gonio_err err = {0};
    brdf_material *m = brdf_material_open(spec, &err);
    if (m)
        fail_msg("%s: opened", spec);
    assert_int_equal(err.code, GONIO_EBADCONFIG);
    if (!strstr(err.msg, w1) || (w2 && !strstr(err.msg, w2)))
        fail_msg("%s: message '%s' does not name '%s' and '%s'", spec, err.msg, w1,
                 w2 ? w2 : "");
}

static void test_bad_parameters_named(void **state)
{
    (void)state;
    refused("analytic:aniso-ggx?ax=0.08&ay=foo", "'ay'", "'foo'");
    refused("analytic:aniso-ggx?ax=0.08&ay=0.3x", "'ay'", "'0.3x'");
    refused("analytic:aniso-ggx?ax=0&ay=0.3", "'ax'", "0.001..1");
    refused("analytic:aniso-ggx?ax=0.08&ay=1.5", "'ay'", "'1.5'");
    refused("analytic:aniso-ggx?ax=0.08", "'ay'", "missing");
    refused("analytic:aniso-ggx?ax=0.08&ay=0.3&bx=1", "'bx'", "unknown");
    refused("analytic:aniso-ggx?ax=0.08&ay=0.3&ax=0.1", "'ax'", "twice");
    refused("analytic:aniso-ggx?ax&ay=0.3", "'ax'", "no value");
    refused("analytic:aniso-ggx?ax=0.08&ay=0.3&rho_d=0.1:0.2", "'rho_d'", "'0.1:0.2'");
    refused("analytic:aniso-ggx?ax=0.08&ay=0.3&rho_d=0.1:0.2:0.3:0.4", "'rho_d'", NULL);
    refused("analytic:aniso-ggx?ax=0.08&ay=0.3&phi=0.1:0.2:0.3", "'phi'", NULL);
    refused("analytic:aniso-ggx?ax=0.08&ay=0.3&phi=nan", "'phi'", "'nan'");
    refused("analytic:two-lobe?a1=0.05&w1=1&a2=0.3", "'w2'", "missing");
    refused("analytic:two-lobe?a1=0.05&w1=1&a2=0.3&w2=1&eta=1", "'eta'", "'1'");
}

static void eval(const char *spec, const struct brdf_pair *p, double rgb[3])
{
    struct gonio_err err = {0};
    brdf_material *m = brdf_material_open(spec, &err);
    if (!m)
        fail_msg("%s: %s", spec, err.msg);
    brdf_material_eval(m, p, 1, rgb);
    brdf_material_free(m);
}

static void test_normal_mirror_closed_form(void **state)
{
    (void)state;
    /* l = v = n: h = n, D = 1 / (pi ax ay), L = 1, F = f0 */
    struct brdf_pair p;
    double rgb[3];
    brdf_pair_inplane(0, 0, &p);
    eval("analytic:aniso-ggx?ax=0.08&ay=0.3&phi=33&rho_d=0.2:0.1:0&f0=0.9:0.5:0.2", &p, rgb);
    const double rho[3] = {0.2, 0.1, 0}, f0[3] = {0.9, 0.5, 0.2};
    for (int c = 0; c < 3; c++)
        assert_rel_close(rgb[c], rho[c] / PI + f0[c] / (4 * PI * 0.08 * 0.3), 1e-12);
}

static void test_quarter_turn_swaps_roughness_and_rotation_turns_tangent(void **state)
{
    (void)state;
    uint64_t s = 11;
    for (int k = 0; k < 500; k++) {
        double u[4];
        for (int i = 0; i < 4; i++)
            u[i] = (double)(brdf_splitmix64(&s) >> 11) * 0x1p-53;
        struct brdf_pair p, q;
        brdf_pair_spherical(85 * u[0], 360 * u[1], 85 * u[2], 360 * u[3], &p);
        double a[3], b[3], c[3];
        eval("analytic:aniso-ggx?ax=0.1&ay=0.35&phi=0", &p, a);
        eval("analytic:aniso-ggx?ax=0.35&ay=0.1&phi=90", &p, b);
        for (int ch = 0; ch < 3; ch++)
            assert_rel_close(b[ch], a[ch], 1e-9);
        /* the sample turned 30 deg: its tangent at 10 deg lies at 40 deg in the lab */
        q = p;
        brdf_pair_rotate(&q, 30);
        eval("analytic:aniso-ggx?ax=0.1&ay=0.35&phi=10", &q, b);
        eval("analytic:aniso-ggx?ax=0.1&ay=0.35&phi=40", &p, c);
        for (int ch = 0; ch < 3; ch++)
            assert_rel_close(b[ch], c[ch], 1e-9);
        assert_close(q.theta_h, p.theta_h, 0);
        assert_close(q.phi_d, p.phi_d, 0);
    }
    /* and it matters: the in-plane flank of the lobe along ax differs from along ay */
    struct brdf_pair f;
    double x[3], y[3], iso[3], iso_turned[3];
    brdf_pair_inplane(30, 50, &f);
    eval("analytic:aniso-ggx?ax=0.08&ay=0.3&phi=0", &f, x);
    eval("analytic:aniso-ggx?ax=0.08&ay=0.3&phi=90", &f, y);
    assert_true(y[1] > 3 * x[1]);
    eval("analytic:aniso-ggx?ax=0.2&ay=0.2&phi=0", &f, iso);
    brdf_pair_rotate(&f, 77);
    eval("analytic:aniso-ggx?ax=0.2&ay=0.2&phi=0", &f, iso_turned);
    assert_rel_close(iso_turned[1], iso[1], 1e-12);
}

static void test_aniso_reciprocal_and_finite(void **state)
{
    (void)state;
    uint64_t s = 5;
    for (int k = 0; k < 2000; k++) {
        double u[4];
        for (int i = 0; i < 4; i++)
            u[i] = (double)(brdf_splitmix64(&s) >> 11) * 0x1p-53;
        struct brdf_pair g, r;
        double f[3], b[3];
        brdf_pair_spherical(89.999 * u[0], 360 * u[1], 89.999 * u[2], 360 * u[3], &g);
        brdf_pair_spherical(89.999 * u[2], 360 * u[3], 89.999 * u[0], 360 * u[1], &r);
        eval(aniso_spec, &g, f);
        eval(aniso_spec, &r, b);
        for (int c = 0; c < 3; c++) {
            assert_true(isfinite(f[c]) && f[c] >= 0);
            assert_rel_close(b[c], f[c], 1e-12);
        }
    }
    struct brdf_pair g;
    double rgb[3];
    double wi[3] = {1, 0, 1e-12}, wo[3] = {-1, 0, 1e-12};
    brdf_pair_from_dirs(wi, wo, &g);
    eval(aniso_spec, &g, rgb);
    assert_true(isfinite(rgb[0]) && rgb[0] >= 0);
    brdf_pair_spherical(30, 0, 95, 180, &g);
    eval(aniso_spec, &g, rgb);
    assert_close(rgb[0], 0, 0);
}

static void test_two_lobe_is_the_layered_form(void **state)
{
    (void)state;
    const struct brdf_analytic ref = {.name = "ref", .rho = {0.1, 0.1, 0.1}, .eta = 1.5,
                                      .lobes = 2, .alpha = {0.05, 0.3}, .weight = {0.6, 0.4}};
    for (double tr = -80; tr <= 80; tr += 7) {
        struct brdf_pair p;
        double a[3], b[3];
        brdf_pair_inplane(35, tr, &p);
        brdf_analytic_eval(&ref, &p, a);
        eval("analytic:two-lobe?a1=0.05&w1=0.6&a2=0.3&w2=0.4", &p, b);
        for (int c = 0; c < 3; c++)
            assert_rel_close(b[c], a[c], 1e-15);
    }
}

static void test_isotropy_flag_and_merl_refusal(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    brdf_material *a = brdf_material_open(aniso_spec, &err);
    brdf_material *t = brdf_material_open("analytic:two-lobe?a1=0.05&w1=1&a2=0.3&w2=1", &err);
    brdf_material *g = brdf_material_open("analytic:ggx-gold", &err);
    assert_non_null(a);
    assert_non_null(t);
    assert_non_null(g);
    assert_false(brdf_material_isotropic(a));
    assert_true(brdf_material_isotropic(t));
    assert_true(brdf_material_isotropic(g));
    assert_string_equal(brdf_material_name(a), aniso_spec);
    char dir[64], path[128];
    assert_int_equal(gonio_test_dir_make(dir, sizeof dir, "aspec"), 0);
    snprintf(path, sizeof path, "%s/a.binary", dir);
    assert_true(brdf_merl_export(a, path, &err) < 0);
    assert_int_equal(err.code, GONIO_EUSAGE);
    assert_non_null(strstr(err.msg, "anisotropic"));
    assert_int_equal(access(path, F_OK), -1); /* nothing written */
    gonio_test_dir_remove(dir);
    brdf_material_free(a);
    brdf_material_free(t);
    brdf_material_free(g);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_parameters_reach_the_material),
        cmocka_unit_test(test_bad_parameters_named),
        cmocka_unit_test(test_normal_mirror_closed_form),
        cmocka_unit_test(test_quarter_turn_swaps_roughness_and_rotation_turns_tangent),
        cmocka_unit_test(test_aniso_reciprocal_and_finite),
        cmocka_unit_test(test_two_lobe_is_the_layered_form),
        cmocka_unit_test(test_isotropy_flag_and_merl_refusal),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
