/* NBRDF network: loading checks and the forward pass against the reference
 * values published with the shared data (computed independently in numpy). */
#include <string.h>
#include <unistd.h>
#include <time.h>

#include "brdf/material.h"
#include "brdf/nbrdf.h"
#include "tests/gonio_test.h"

#define PI 3.14159265358979323846

static double angle_diff(double a, double b)
{
    double d = fmod(a - b, 2 * PI);
    if (d > PI)
        d -= 2 * PI;
    if (d < -PI)
        d += 2 * PI;
    return fabs(d);
}

static void test_reference_values(void **state)
{
    (void)state;
    const char *shared = gonio_test_shared_or_skip();
    char path[4096];
    snprintf(path, sizeof path, "%s/data/merl/nbrdf_reference_values.csv", shared);
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    char line[1024], last[128] = "";
    struct brdf_nbrdf net;
    int rows = 0, materials = 0;
    while (fgets(line, sizeof line, f)) {
        if (line[0] == '#' || strncmp(line, "material,", 9) == 0)
            continue;
        char name[128];
        double ti, pi_, to, po, th, td, pd, ref[3];
        int n = sscanf(line, "%127[^,],%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf", name, &ti, &pi_,
                       &to, &po, &th, &td, &pd, &ref[0], &ref[1], &ref[2]);
        assert_int_equal(n, 11);
        if (strcmp(name, last) != 0) {
            char wpath[4096];
            struct gonio_err err = {0};
            snprintf(wpath, sizeof wpath, "%s/data/merl/nbrdf_f32/%s.nbrdf", shared, name);
            assert_int_equal(brdf_nbrdf_load(wpath, &net, &err), 0);
            snprintf(last, sizeof last, "%s", name);
            materials++;
        }
        struct brdf_pair p;
        brdf_pair_spherical(ti, pi_, to, po, &p);
        /* Our half/difference conversion must agree with the reference's. */
        assert_close(p.theta_h, th, 1e-9);
        assert_close(p.theta_d, td, 1e-9);
        if (sin(p.theta_d) > 1e-9 && p.theta_h > 1e-9)
            assert_close(angle_diff(p.phi_d, pd), 0.0, 1e-9);
        double rgb[3];
        brdf_nbrdf_eval(&net, &p, 1, rgb);
        for (int c = 0; c < 3; c++)
            assert_rel_close(rgb[c], ref[c], 1e-6);
        rows++;
    }
    fclose(f);
    assert_int_equal(materials, 6);
    assert_int_equal(rows, 72);
}

static char tmpdir[4096];

static int setup_tmp(void **state)
{
    (void)state;
    const char *base = getenv("GONIO_TMP");
    if (!base || !*base)
        base = "/tmp";
    gonio_mkdir_p(base, NULL);
    snprintf(tmpdir, sizeof tmpdir, "%s/test_nbrdf.XXXXXX", base);
    return mkdtemp(tmpdir) ? 0 : -1;
}

static void write_file(const char *path, const void *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, len, f), len);
    fclose(f);
}

static void expect_refused(const char *path, int code)
{
    struct brdf_nbrdf net;
    struct gonio_err err = {0};
    int rc = brdf_nbrdf_load(path, &net, &err);
    assert_int_equal(rc, -code);
    assert_int_equal(err.code, code);
    if (!strstr(err.msg, path)) {
        print_error("message does not name the file: %s\n", err.msg);
        fail();
    }
    remove(path);
}

static void test_bad_files_refused(void **state)
{
    (void)state;
    float w[BRDF_NBRDF_NWEIGHTS + 1];
    for (int i = 0; i <= BRDF_NBRDF_NWEIGHTS; i++)
        w[i] = 0.01f * (float)(i % 7);
    char path[4200];

    snprintf(path, sizeof path, "%s/short.nbrdf", tmpdir);
    write_file(path, w, BRDF_NBRDF_FILE_BYTES - 4);
    expect_refused(path, GONIO_EBADDATA);

    snprintf(path, sizeof path, "%s/long.nbrdf", tmpdir);
    write_file(path, w, BRDF_NBRDF_FILE_BYTES + 4);
    expect_refused(path, GONIO_EBADDATA);

    snprintf(path, sizeof path, "%s/nan.nbrdf", tmpdir);
    w[300] = NAN;
    write_file(path, w, BRDF_NBRDF_FILE_BYTES);
    expect_refused(path, GONIO_EBADDATA);

    snprintf(path, sizeof path, "%s/inf.nbrdf", tmpdir);
    w[300] = INFINITY;
    write_file(path, w, BRDF_NBRDF_FILE_BYTES);
    expect_refused(path, GONIO_EBADDATA);

    snprintf(path, sizeof path, "%s/missing.nbrdf", tmpdir);
    expect_refused(path, GONIO_ENOTFOUND);

    /* A well-formed file loads, in file order (first weight of W1, last of b3). */
    w[300] = 0.5f;
    snprintf(path, sizeof path, "%s/good.nbrdf", tmpdir);
    write_file(path, w, BRDF_NBRDF_FILE_BYTES);
    struct brdf_nbrdf net;
    assert_int_equal(brdf_nbrdf_load(path, &net, NULL), 0);
    assert_close(net.w1[1], (double)w[1], 0);
    assert_close(net.w2[300 - 147], 0.5, 0);
    assert_close(net.b3[2], (double)w[674], 0);
    remove(path);
    rmdir(tmpdir);
}

/* Hand-made network with one live path: the recipe's ReLU, exp(x)-1 and
 * clamp, checked against values worked out by hand. */
static void test_recipe_by_hand(void **state)
{
    (void)state;
    float w[BRDF_NBRDF_NWEIGHTS] = {0};
    /* h1[0] = x[2] (cos th) - 0.5; h2[0] = 2 h1[0]; out = h2[0]*(1, -1, 0) + b3 */
    w[2 * 21 + 0] = 1.0f;  /* W1[2][0] */
    w[126 + 0] = -0.5f;    /* b1[0] */
    w[147 + 0] = 2.0f;     /* W2[0][0] */
    w[609 + 0] = 1.0f;     /* W3[0][0] */
    w[609 + 1] = -1.0f;    /* W3[0][1] */
    w[672 + 2] = 0.25f;    /* b3[2] */
    struct brdf_nbrdf net;
    brdf_nbrdf_from_floats(w, &net);
    struct brdf_pair p;
    brdf_pair_from_hd(0.3, 0.2, 1.0, &p);
    double rgb[3];
    brdf_nbrdf_eval(&net, &p, 1, rgb);
    double a = 2 * (cos(0.3) - 0.5);
    assert_rel_close(rgb[0], exp(a) - 1, 1e-14);
    assert_close(rgb[1], 0.0, 0); /* exp(-a) - 1 < 0 clamps to 0 */
    assert_rel_close(rgb[2], exp(0.25) - 1, 1e-14);
    /* theta_h = 90 deg: cos th = 0, first ReLU cuts, output exp(0)-1 = 0 */
    brdf_pair_from_hd(PI / 2, 0.2, 1.0, &p);
    brdf_nbrdf_eval(&net, &p, 1, rgb);
    assert_close(rgb[0], 0.0, 1e-15);
}

/* Throughput on the scale of the full-domain metric; printed, not asserted. */
static void test_throughput(void **state)
{
    (void)state;
    const char *shared = gonio_test_shared_or_skip();
    char spec[64] = "nbrdf:nylon";
    (void)shared;
    struct gonio_err err = {0};
    brdf_material *m = brdf_material_open(spec, &err);
    assert_non_null(m);
    size_t n = 924000;
    struct brdf_pair *pairs = malloc(n * sizeof *pairs);
    double *rgb = malloc(3 * n * sizeof *rgb);
    assert_non_null(pairs);
    assert_non_null(rgb);
    for (size_t i = 0; i < n; i++)
        brdf_pair_from_hd((double)(i % 90) / 90 * PI / 2, (double)(i / 90 % 90) / 90 * PI / 2,
                          (double)(i % 360) / 180 * PI, &pairs[i]);
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    size_t missing = brdf_material_eval(m, pairs, n, rgb);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double s = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    fprintf(stderr, "NBRDF batch: %zu pairs in %.3f s = %.3g pairs/s\n", n, s, (double)n / s);
    assert_int_equal(missing, 0);
    for (size_t i = 0; i < 3 * n; i++)
        assert_true(rgb[i] >= 0 && isfinite(rgb[i]));
    free(pairs);
    free(rgb);
    brdf_material_free(m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reference_values),
        cmocka_unit_test_setup(test_bad_files_refused, setup_tmp),
        cmocka_unit_test(test_recipe_by_hand),
        cmocka_unit_test(test_throughput),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
