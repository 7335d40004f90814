/* MERL tables: refusal of damaged files, lookup at grid nodes, and an
 * export of the NBRDF nylon network read back cell by cell. */
#include <string.h>
#include <unistd.h>
#include <time.h>

#include "brdf/material.h"
#include "brdf/material_private.h"
#include "brdf/merl.h"
#include "brdf/nbrdf.h"
#include "tests/gonio_test.h"

#define PI 3.14159265358979323846

static char tmpdir[4096];

static int setup_tmp(void **state)
{
    (void)state;
    const char *base = getenv("GONIO_TMP");
    if (!base || !*base)
        base = "/tmp";
    gonio_mkdir_p(base, NULL);
    snprintf(tmpdir, sizeof tmpdir, "%s/test_merl.XXXXXX", base);
    return mkdtemp(tmpdir) ? 0 : -1;
}

static int teardown_tmp(void **state)
{
    (void)state;
    rmdir(tmpdir);
    return 0;
}

/* A table file built here byte by byte (little-endian), independent of the
 * writer under test. */
static void write_table(const char *path, int32_t n0, int32_t n1, int32_t n2, size_t nvalues,
                        double fill, size_t bad_index, double bad)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    int32_t hdr[3] = {n0, n1, n2};
    assert_int_equal(fwrite(hdr, 4, 3, f), 3);
    double *buf = malloc(65536 * sizeof *buf);
    assert_non_null(buf);
    for (size_t done = 0; done < nvalues;) {
        size_t k = nvalues - done < 65536 ? nvalues - done : 65536;
        for (size_t t = 0; t < k; t++)
            buf[t] = done + t == bad_index ? bad : fill;
        assert_int_equal(fwrite(buf, 8, k, f), k);
        done += k;
    }
    free(buf);
    fclose(f);
}

/* Overwrite value number index (after the header) of the table at path. */
static void set_value(const char *path, size_t index, double v)
{
    FILE *f = fopen(path, "r+b");
    assert_non_null(f);
    assert_int_equal(fseek(f, 12 + 8 * (long)index, SEEK_SET), 0);
    assert_int_equal(fwrite(&v, 8, 1, f), 1);
    fclose(f);
}

static void expect_refused(const char *path, const char *what)
{
    struct gonio_err err = {0};
    brdf_material *m = brdf_merl_open(path, NULL, &err);
    assert_null(m);
    assert_int_equal(err.code, GONIO_EBADDATA);
    if (!strstr(err.msg, path) || !strstr(err.msg, what)) {
        print_error("message should name %s and say '%s': %s\n", path, what, err.msg);
        fail();
    }
    remove(path); /* 35 MB each: do not leave them behind */
}

static void test_damaged_files_refused(void **state)
{
    (void)state;
    const size_t full = 3 * (size_t)BRDF_MERL_CELLS;
    char path[4200];

    snprintf(path, sizeof path, "%s/header.binary", tmpdir);
    write_table(path, 90, 90, 360, full, 1.0, SIZE_MAX, 0);
    expect_refused(path, "header");

    snprintf(path, sizeof path, "%s/short.binary", tmpdir);
    write_table(path, 90, 90, 180, full - 1000, 1.0, SIZE_MAX, 0);
    expect_refused(path, "truncated");

    snprintf(path, sizeof path, "%s/long.binary", tmpdir);
    write_table(path, 90, 90, 180, full + 1, 1.0, SIZE_MAX, 0);
    expect_refused(path, "bytes");

    snprintf(path, sizeof path, "%s/nan.binary", tmpdir);
    write_table(path, 90, 90, 180, full, 1.0, 2000000, NAN);
    expect_refused(path, "NaN");

    snprintf(path, sizeof path, "%s/inf.binary", tmpdir);
    write_table(path, 90, 90, 180, full, 1.0, 17, INFINITY);
    expect_refused(path, "infinite");

    /* Every cell unmeasured: refused. Then one cell measured in two of its
     * three channels (still refused), then in all three (loaded). */
    snprintf(path, sizeof path, "%s/unmeasured.binary", tmpdir);
    write_table(path, 90, 90, 180, full, -1.0, SIZE_MAX, 0);
    expect_refused(path, "no valid cell");
    write_table(path, 90, 90, 180, full, -1.0, SIZE_MAX, 0);
    const size_t cell = 12345;
    set_value(path, cell, 0.5);
    set_value(path, BRDF_MERL_CELLS + cell, 0.5);
    expect_refused(path, "no valid cell");
    write_table(path, 90, 90, 180, full, -1.0, SIZE_MAX, 0);
    for (int c = 0; c < 3; c++)
        set_value(path, (size_t)c * BRDF_MERL_CELLS + cell, 0.5);
    struct gonio_err err = {0};
    brdf_material *m = brdf_merl_open(path, NULL, &err);
    assert_non_null(m);
    brdf_material_free(m);
    remove(path);

    snprintf(path, sizeof path, "%s/tiny.binary", tmpdir);
    write_table(path, 90, 90, 180, 0, 0, SIZE_MAX, 0);
    expect_refused(path, "truncated");

    snprintf(path, sizeof path, "%s/absent.binary", tmpdir);
    assert_null(brdf_merl_open(path, NULL, &err));
    assert_int_equal(err.code, GONIO_ENOTFOUND);
    assert_non_null(strstr(err.msg, path));
}

/* Cells hold their own (i, j, k) code, so a lookup says where it landed. */
static void test_lookup_at_nodes(void **state)
{
    (void)state;
    char path[4200];
    snprintf(path, sizeof path, "%s/index.binary", tmpdir);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    int32_t hdr[3] = {90, 90, 180};
    fwrite(hdr, 4, 3, f);
    for (int c = 0; c < 3; c++)
        for (int i = 0; i < 90; i++)
            for (int j = 0; j < 90; j++)
                for (int k = 0; k < 180; k++) {
                    /* cell (5, 7, *) is "no data" in the green plane only */
                    double v = i * 1e6 + j * 1e3 + k + c * 0.25;
                    if (i == 5 && j == 7 && c == 1)
                        v = -1.0;
                    fwrite(&v, 8, 1, f);
                }
    fclose(f);
    brdf_material *m = brdf_merl_open(path, "idx", NULL);
    assert_non_null(m);
    const double scale[3] = {1.0 / 1500, 1.15 / 1500, 1.66 / 1500};
    for (int i = 0; i < 90; i += 1)
        for (int j = 0; j < 90; j += 11)
            for (int k = 0; k < 180; k += 7) {
                double u = i / 90.0;
                struct brdf_pair p;
                brdf_pair_from_hd(u * u * PI / 2, j / 90.0 * PI / 2, k / 180.0 * PI, &p);
                double rgb[3];
                size_t missing = brdf_material_eval(m, &p, 1, rgb);
                if (i == 5 && j == 7) {
                    assert_int_equal(missing, 1);
                    for (int c = 0; c < 3; c++)
                        assert_true(isnan(rgb[c]));
                    continue;
                }
                assert_int_equal(missing, 0);
                for (int c = 0; c < 3; c++)
                    assert_close(rgb[c] / scale[c], i * 1e6 + j * 1e3 + k + c * 0.25, 1e-6);
            }
    /* phi_d in (-pi, 0) folds by +pi; half a bin past a node stays in it. */
    struct brdf_pair p;
    double u = 30 / 90.0;
    brdf_pair_from_hd(u * u * PI / 2, 40.5 / 90 * PI / 2, (10.5 / 180.0 - 1) * PI, &p);
    double rgb[3];
    brdf_material_eval(m, &p, 1, rgb);
    assert_close(rgb[0] * 1500, 30e6 + 40e3 + 10, 1e-6);
    brdf_material_free(m);
    remove(path);
}

/* The nylon network, except that it has no data at theta_d = 7/90 pi/2
 * (one MERL theta_d slice): export must write those cells as no data. */
static int is_hole(const struct brdf_pair *p)
{
    return fabs(p->theta_d - 7.0 / 90 * PI / 2) < 1e-12;
}

static void holey_eval(const void *priv, const struct brdf_pair *pairs, size_t n, double *rgb)
{
    brdf_nbrdf_eval(priv, pairs, n, rgb);
    for (size_t i = 0; i < n; i++)
        if (is_hole(&pairs[i]))
            rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = NAN;
}

static void test_export_nylon(void **state)
{
    (void)state;
    const char *shared = gonio_test_shared_or_skip();
    char wpath[4096], path[4200];
    snprintf(wpath, sizeof wpath, "%s/data/merl/nbrdf_f32/nylon.nbrdf", shared);
    snprintf(path, sizeof path, "%s/nylon.binary", tmpdir);
    struct gonio_err err = {0};
    static const struct brdf_material_ops holey_ops = {"holey", holey_eval, free};
    struct brdf_nbrdf *hnet = malloc(sizeof *hnet);
    assert_non_null(hnet);
    assert_int_equal(brdf_nbrdf_load(wpath, hnet, &err), 0);
    brdf_material *src = brdf_material_new(&holey_ops, hnet, "holey nylon");
    assert_non_null(src);
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    assert_int_equal(brdf_merl_export(src, path, &err), 0);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    fprintf(stderr, "MERL export of the nylon network: %.2f s\n",
            (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec));

    /* The file on disk: exact size, header, a raw value equal to f / scale. */
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    assert_int_equal(ftell(f), 34992012L);
    fseek(f, 0, SEEK_SET);
    int32_t hdr[3];
    assert_int_equal(fread(hdr, 4, 3, f), 3);
    assert_int_equal(hdr[0], 90);
    assert_int_equal(hdr[1], 90);
    assert_int_equal(hdr[2], 180);
    fclose(f);

    brdf_material *tab = brdf_merl_open(path, NULL, &err);
    assert_non_null(tab);
    struct brdf_nbrdf net; /* the network, evaluated directly */
    assert_int_equal(brdf_nbrdf_load(wpath, &net, &err), 0);
    size_t checked = 0, nodata = 0, holes = 0;
    for (int i = 0; i < 90; i += 3)
        for (int j = 1; j < 90; j += 2)
            for (int k = 0; k < 180; k += 5) {
                double u = i / 90.0;
                struct brdf_pair p;
                brdf_pair_from_hd(u * u * PI / 2, j / 90.0 * PI / 2, k / 180.0 * PI, &p);
                double got[3], want[3];
                size_t missing = brdf_material_eval(tab, &p, 1, got);
                if (!(p.wi[2] > 0 && p.wo[2] > 0) || j == 7) {
                    assert_int_equal(missing, 1);
                    assert_true(isnan(got[0]) && isnan(got[1]) && isnan(got[2]));
                    nodata++;
                    holes += j == 7;
                    continue;
                }
                assert_int_equal(missing, 0);
                brdf_nbrdf_eval(&net, &p, 1, want);
                for (int c = 0; c < 3; c++)
                    assert_close(got[c], want[c], 1e-12 * fabs(want[c]) + 1e-300);
                checked++;
            }
    assert_true(checked > 10000);
    assert_true(nodata > 100); /* large theta_h + theta_d: one direction below */
    assert_int_equal(holes, 30 * 36);
    brdf_material_free(tab);
    brdf_material_free(src);
    remove(path);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_damaged_files_refused),
        cmocka_unit_test(test_lookup_at_nodes),
        cmocka_unit_test(test_export_nylon),
    };
    return cmocka_run_group_tests(tests, setup_tmp, teardown_tmp);
}
