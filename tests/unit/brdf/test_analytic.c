/* Analytic materials (brdf/analytic.h): finite and non-negative up to the
 * horizon and at v.h -> 0, 0 below it, reciprocal, energy-plausible
 * (directional albedo <= 1), the conductor's lobe four decades above its
 * far off-specular value, an unknown name refused with the list, and a
 * MERL table of one read back at its nodes as the material itself. */
#include "brdf/analytic.h"
#include "brdf/domain.h"
#include "brdf/material.h"
#include "brdf/merl.h"
#include "tests/gonio_test.h"

#define PI 3.14159265358979323846

static char dir[64];

static int setup(void **state)
{
    (void)state;
    return gonio_test_dir_make(dir, sizeof dir, "analytic");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

static double uniform(uint64_t *s)
{
    return (double)(brdf_splitmix64(s) >> 11) * 0x1p-53;
}

static void eval(const struct brdf_analytic *a, const struct brdf_pair *p, double rgb[3])
{
    brdf_analytic_eval(a, p, rgb);
}

static void test_finite_nonnegative_to_grazing(void **state)
{
    (void)state;
    /* polar angles up to 89.9999 deg and past the horizon, every azimuth
     * difference, and the pairs of v.h -> 0: l and v both grazing and
     * opposite (theta_d -> pi/2). */
    static const double th[] = {0, 10, 45, 80, 89, 89.9, 89.99, 89.9999, 90, 95, 180};
    static const double dphi[] = {0, 1e-7, 30, 90, 179, 179.9999, 180};
    size_t checked = 0;
    for (size_t m = 0; brdf_analytic_at(m); m++) {
        const struct brdf_analytic *a = brdf_analytic_at(m);
        for (size_t i = 0; i < sizeof th / sizeof *th; i++)
            for (size_t o = 0; o < sizeof th / sizeof *th; o++)
                for (size_t p = 0; p < sizeof dphi / sizeof *dphi; p++) {
                    struct brdf_pair g;
                    double rgb[3];
                    brdf_pair_spherical(th[i], 0, th[o], dphi[p], &g);
                    eval(a, &g, rgb);
                    int below = th[i] > 90 || th[o] > 90; /* cos 90 deg rounds to 6e-17 > 0 */
                    for (int c = 0; c < 3; c++) {
                        if (!isfinite(rgb[c]) || rgb[c] < 0 || (below && rgb[c] != 0))
                            fail_msg("%s at (%g, %g, dphi %g): channel %d = %g", a->name,
                                     th[i], th[o], dphi[p], c, rgb[c]);
                    }
                    checked++;
                }
        for (double e = 1e-3; e >= 1e-15; e /= 10) {
            struct brdf_pair g;
            double rgb[3];
            brdf_pair_from_hd(0.3, PI / 2 - e, 0.5, &g);
            eval(a, &g, rgb);
            for (int c = 0; c < 3; c++)
                if (!isfinite(rgb[c]) || rgb[c] < 0)
                    fail_msg("%s at theta_d = pi/2 - %g: channel %d = %g", a->name, e, c,
                             rgb[c]);
            /* l and v nearly opposite, both just above the horizon */
            double wi[3] = {1, 0, e}, wo[3] = {-1, 1e-9, e};
            brdf_pair_from_dirs(wi, wo, &g);
            eval(a, &g, rgb);
            for (int c = 0; c < 3; c++)
                if (!isfinite(rgb[c]) || rgb[c] < 0)
                    fail_msg("%s at l = -v, n.l = %g: channel %d = %g", a->name, e, c, rgb[c]);
        }
    }
    assert_true(checked >= 4 * 11 * 11 * 7);
}

static void test_reciprocal(void **state)
{
    (void)state;
    uint64_t s = 7;
    for (size_t m = 0; brdf_analytic_at(m); m++) {
        const struct brdf_analytic *a = brdf_analytic_at(m);
        for (int k = 0; k < 2000; k++) {
            double ti = 89.0 * uniform(&s), to = 89.0 * uniform(&s);
            double pi_ = 360.0 * uniform(&s), po = 360.0 * uniform(&s);
            struct brdf_pair g, r;
            double f[3], b[3];
            brdf_pair_spherical(ti, pi_, to, po, &g);
            brdf_pair_spherical(to, po, ti, pi_, &r);
            eval(a, &g, f);
            eval(a, &r, b);
            for (int c = 0; c < 3; c++)
                assert_rel_close(b[c], f[c], 1e-12);
        }
    }
}

/* Directional albedo: the integral of f cos theta_o over the hemisphere,
 * midpoint rule (0.125 x 0.5 deg; the sharpest lobe, alpha 0.04, spans
 * some 4 deg). */
static double albedo(const struct brdf_analytic *a, double theta_i, int c)
{
    int nt = gonio_test_small() ? 180 : 720, np = gonio_test_small() ? 180 : 720;
    double dt = 90.0 / nt, dp = 360.0 / np, sum = 0;
    for (int i = 0; i < nt; i++) {
        double t = (i + 0.5) * dt;
        double w = sin(t * BRDF_DEG) * cos(t * BRDF_DEG) * (dt * BRDF_DEG) * (dp * BRDF_DEG);
        for (int j = 0; j < np; j++) {
            struct brdf_pair g;
            double rgb[3];
            brdf_pair_spherical(theta_i, 0, t, (j + 0.5) * dp, &g);
            eval(a, &g, rgb);
            sum += rgb[c] * w;
        }
    }
    return sum;
}

static void test_energy_plausible(void **state)
{
    (void)state;
    static const double ti[] = {0, 40, 75};
    for (size_t m = 0; brdf_analytic_at(m); m++) {
        const struct brdf_analytic *a = brdf_analytic_at(m);
        for (size_t i = 0; i < sizeof ti / sizeof *ti; i++)
            for (int c = 0; c < 3; c++) {
                double r = albedo(a, ti[i], c);
                if (!(r > 0.02 && r <= 1.0))
                    fail_msg("%s: albedo at theta_i %g, channel %d = %g (want (0.02, 1])",
                             a->name, ti[i], c, r);
            }
    }
}

static void test_conductor_lobe_four_decades(void **state)
{
    (void)state;
    const struct brdf_analytic *a = brdf_analytic_find("ggx-gold");
    assert_non_null(a);
    struct brdf_pair peak, off;
    brdf_pair_inplane(30, 30, &peak);  /* the mirror direction */
    brdf_pair_inplane(30, -60, &off);  /* back-scatter, theta_h 45 deg */
    double fp[3], fo[3];
    eval(a, &peak, fp);
    eval(a, &off, fo);
    for (int c = 0; c < 3; c++) {
        if (!(fp[c] >= 1e4 * fo[c]) || !(fo[c] > 0))
            fail_msg("channel %d: peak %g, off-specular %g: ratio %g < 1e4", c, fp[c], fo[c],
                     fp[c] / fo[c]);
    }
    /* coloured: gold reflects red more than blue at normal incidence */
    assert_true(fp[0] > 1.5 * fp[2]);
}

static void test_unknown_name_lists_names(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    assert_null(brdf_material_open("analytic:unobtainium", &err));
    assert_int_equal(err.code, GONIO_ENOTFOUND);
    assert_non_null(strstr(err.msg, "analytic:unobtainium"));
    for (size_t m = 0; brdf_analytic_at(m); m++)
        if (!strstr(err.msg, brdf_analytic_at(m)->name))
            fail_msg("message '%s' does not list %s", err.msg, brdf_analytic_at(m)->name);
    memset(&err, 0, sizeof err);
    assert_null(brdf_material_open("analytic:", &err));
    assert_non_null(strstr(err.msg, "missing name"));
}

static void test_merl_table_round_trip(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    char path[128], spec[160];
    snprintf(path, sizeof path, "%s/gold.binary", dir);
    snprintf(spec, sizeof spec, "merl:%s", path);
    brdf_material *m = brdf_material_open("analytic:ggx-gold", &err);
    assert_non_null(m);
    assert_int_equal(brdf_merl_export(m, path, &err), 0);
    brdf_material *t = brdf_material_open(spec, &err);
    assert_non_null(t);
    /* at the table's nodes the table is the material (float64 cells) */
    uint64_t s = 3;
    size_t compared = 0;
    for (int k = 0; k < 3000; k++) {
        int i = (int)(uniform(&s) * BRDF_MERL_NTH), j = (int)(uniform(&s) * BRDF_MERL_NTD),
            q = (int)(uniform(&s) * BRDF_MERL_NPD);
        if (k < 90) /* the whole lobe: theta_h nodes along one theta_d */
            i = k, j = 20, q = 0;
        double th, td, pd, a[3], b[3];
        struct brdf_pair g;
        brdf_merl_node(i, j, q, &th, &td, &pd);
        brdf_pair_from_hd(th, td, pd, &g);
        brdf_material_eval(m, &g, 1, a);
        if (brdf_material_eval(t, &g, 1, b))
            continue; /* a direction below the horizon: no data */
        for (int c = 0; c < 3; c++)
            assert_rel_close(b[c], a[c], 1e-12);
        compared++;
    }
    assert_true(compared > 1000);
    brdf_material_free(t);
    brdf_material_free(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_finite_nonnegative_to_grazing),
        cmocka_unit_test(test_reciprocal),
        cmocka_unit_test(test_energy_plausible),
        cmocka_unit_test(test_conductor_lobe_four_decades),
        cmocka_unit_test(test_unknown_name_lists_names),
        cmocka_unit_test(test_merl_table_round_trip),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
