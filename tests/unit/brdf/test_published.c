/* Published ABC and SGD tables: CSV reading, errors, and the ABC
 * convention (A_ours = A_published / pi) checked two ways: against the
 * formula as dj_brdf evaluates the published numbers (written out here
 * from the data README), and against the mirror values in the README. */
#include <string.h>

#include "brdf/abc.h"
#include "brdf/material.h"
#include "brdf/published.h"
#include "tests/gonio_test.h"

#define PI 3.14159265358979323846

static char fits[4096];

static int setup_paths(void **state)
{
    (void)state;
    const char *shared = gonio_shared_dir();
    if (shared)
        snprintf(fits, sizeof fits, "%s/data/merl/fits", shared);
    return 0;
}

static void test_reads_rows(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    char path[4200];
    snprintf(path, sizeof path, "%s/abc_low2012_merl.csv", fits);
    struct brdf_abc_published a;
    assert_int_equal(brdf_published_abc_read(path, "nylon", &a, NULL), 0);
    /* nylon,0.232688,0.232487,0.207358,19.215639,18.194090,16.938326,
     *       3334.451904,0.886752,1.382529 */
    assert_close(a.kd[0], 0.232688, 0);
    assert_close(a.A[2], 16.938326, 0);
    assert_close(a.B, 3334.451904, 0);
    assert_close(a.C, 0.886752, 0);
    assert_close(a.ior, 1.382529, 0);

    snprintf(path, sizeof path, "%s/sgd_bagher2012_merl.csv", fits);
    struct brdf_sgd s, s2;
    assert_int_equal(brdf_published_sgd_read(path, "specular-black-phenolic", &s, NULL), 0);
    assert_close(s.rho_d[0], 0.00212164, 0);
    assert_close(s.alpha[2], 0.000186605, 0);
    /* other_name column: the same row */
    assert_int_equal(brdf_published_sgd_read(path, "black-bball", &s2, NULL), 0);
    assert_memory_equal(&s, &s2, sizeof s);
}

static void test_errors_name_file_and_problem(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    char path[4200];
    struct gonio_err err = {0};
    struct brdf_abc_published a;
    snprintf(path, sizeof path, "%s/abc_low2012_merl.csv", fits);
    assert_int_equal(brdf_published_abc_read(path, "no-such-material", &a, &err),
                     -GONIO_ENOTFOUND);
    assert_non_null(strstr(err.msg, path));
    assert_non_null(strstr(err.msg, "no-such-material"));

    snprintf(path, sizeof path, "%s/absent.csv", fits);
    assert_int_equal(brdf_published_abc_read(path, "nylon", &a, &err), -GONIO_ENOTFOUND);
    assert_non_null(strstr(err.msg, "absent.csv"));

    /* a damaged row */
    const char *base = getenv("GONIO_TMP");
    char tmp[4200];
    snprintf(tmp, sizeof tmp, "%s/test_published_bad.csv", base && *base ? base : "/tmp");
    gonio_mkdir_p(base && *base ? base : "/tmp", NULL);
    FILE *f = fopen(tmp, "w");
    assert_non_null(f);
    fputs("name,kd_r,kd_g,kd_b,A_r,A_g,A_b,B,C,ior\nfoo,0.1,0.1,0.1,1,1,1,x,1,1.5\n", f);
    fclose(f);
    assert_int_equal(brdf_published_abc_read(tmp, "foo", &a, &err), -GONIO_EBADDATA);
    assert_non_null(strstr(err.msg, tmp));
    assert_non_null(strstr(err.msg, "B"));
    remove(tmp);
}

/* dj_brdf's evaluation of a published row (data README):
 * f = kd/pi + F(h.wi; ior) D G / (pi cos_i cos_o), D = A / (1 + B (1 - cos th))^C */
static void dj_abc(const struct brdf_abc_published *p, const struct brdf_pair *g, double rgb[3])
{
    const double *i = g->wi, *o = g->wo;
    double h[3] = {i[0] + o[0], i[1] + o[1], i[2] + o[2]};
    double n = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
    for (int k = 0; k < 3; k++)
        h[k] /= n;
    double hi = h[0] * i[0] + h[1] * i[1] + h[2] * i[2];
    double ho = h[0] * o[0] + h[1] * o[1] + h[2] * o[2];
    double G = fmin(1.0, fmin(2 * h[2] * i[2] / hi, 2 * h[2] * o[2] / ho));
    double c = hi, gg = sqrt(p->ior * p->ior + c * c - 1);
    double F = 0.5 * (gg - c) * (gg - c) / ((gg + c) * (gg + c)) *
               (1 + pow(c * (gg + c) - 1, 2) / pow(c * (gg - c) + 1, 2));
    for (int k = 0; k < 3; k++) {
        double D = p->A[k] / pow(1 + p->B * (1 - h[2]), p->C);
        rgb[k] = p->kd[k] / PI + F * D * G / (PI * i[2] * o[2]);
    }
}

static void test_abc_convention(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    char path[4200];
    snprintf(path, sizeof path, "%s/abc_low2012_merl.csv", fits);
    static const char *const names[] = {"nylon", "brass", "white-paint", "gold-metallic-paint",
                                        "blue-acrylic"};
    for (size_t n = 0; n < sizeof names / sizeof names[0]; n++) {
        struct brdf_abc_published pub;
        struct brdf_abc ours;
        assert_int_equal(brdf_published_abc_read(path, names[n], &pub, NULL), 0);
        brdf_published_abc_convert(&pub, &ours);
        assert_rel_close(ours.A[1] * PI, pub.A[1], 1e-15);
        for (double ti = 0; ti <= 80; ti += 20)
            for (double to = 0; to <= 85; to += 17)
                for (double dphi = 0; dphi <= 180; dphi += 60) {
                    struct brdf_pair g;
                    brdf_pair_spherical(ti, 0, to, 180 - dphi, &g);
                    double a[3], b[3];
                    brdf_abc_eval(&ours, &g, a);
                    dj_abc(&pub, &g, b);
                    for (int c = 0; c < 3; c++)
                        assert_rel_close(a[c], b[c], 1e-9);
                }
    }
}

/* README: f_g at the mirror direction of 30 degree incidence, ABC column. */
static void test_abc_readme_peaks(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    static const struct {
        const char *spec;
        double f_g;
    } ref[] = {{"abc:blue-acrylic", 17.9},
               {"abc:brass", 174},
               {"abc:specular-black-phenolic", 34},
               {"abc:white-diffuse-bball", 0.147}};
    for (size_t r = 0; r < sizeof ref / sizeof ref[0]; r++) {
        struct gonio_err err = {0};
        brdf_material *m = brdf_material_open(ref[r].spec, &err);
        if (!m) {
            print_error("%s\n", err.msg);
            fail();
        }
        struct brdf_pair g;
        brdf_pair_inplane(30, 30, &g);
        double rgb[3];
        brdf_material_eval(m, &g, 1, rgb);
        assert_rel_close(rgb[1], ref[r].f_g, 0.03);
        brdf_material_free(m);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reads_rows),
        cmocka_unit_test(test_errors_name_file_and_problem),
        cmocka_unit_test(test_abc_convention),
        cmocka_unit_test(test_abc_readme_peaks),
    };
    return cmocka_run_group_tests(tests, setup_paths, NULL);
}
