/* OpenEXR: round trip through the Core API, refusal of bad arguments, and a
 * failed write that leaves nothing behind. */
#include "brdf/exr.h"
#include "tests/gonio_test.h"

#include <dirent.h>
#include <errno.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static char tmpdir[512];

static int setup(void **state)
{
    (void)state;
    const char *base = getenv("GONIO_TMP");
    if (!base || gonio_mkdir_p(base, NULL) != 0)
        base = "/tmp";
    snprintf(tmpdir, sizeof tmpdir, "%s/test_exr.XXXXXX", base);
    return mkdtemp(tmpdir) ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    char cmd[700];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", tmpdir);
    return system(cmd) == 0 ? 0 : -1;
}

static void fill(float *rgb, int w, int h)
{
    /* Distinct values per pixel and channel, including ones a half-float
     * path would round, a negative, zero and a huge value. */
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++)
                rgb[3 * (y * w + x) + c] = (float)(y * 1000 + x) + 0.1234567f * (float)(c + 1);
    rgb[0] = -2.5f;
    rgb[1] = 0.0f;
    rgb[2] = 3.0e30f;
}

static void roundtrip(int w, int h)
{
    char path[600];
    snprintf(path, sizeof path, "%s/img_%dx%d.exr", tmpdir, w, h);
    float *rgb = malloc(sizeof(float) * 3 * (size_t)w * (size_t)h);
    assert_non_null(rgb);
    fill(rgb, w, h);
    struct gonio_err err = {0};
    int rc = brdf_exr_write_rgb(path, w, h, rgb, &err);
    if (rc != 0)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);

    /* The file starts with the OpenEXR magic number 20000630 (LE). */
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    unsigned char magic[4];
    assert_int_equal(fread(magic, 1, 4, f), 4);
    fclose(f);
    assert_int_equal(magic[0], 0x76);
    assert_int_equal(magic[1], 0x2f);
    assert_int_equal(magic[2], 0x31);
    assert_int_equal(magic[3], 0x01);

    int rw = 0, rh = 0;
    float *back = NULL;
    rc = brdf_exr_read_rgb(path, &rw, &rh, &back, &err);
    if (rc != 0)
        print_error("%s\n", err.msg);
    assert_int_equal(rc, 0);
    assert_int_equal(rw, w);
    assert_int_equal(rh, h);
    assert_memory_equal(back, rgb, sizeof(float) * 3 * (size_t)w * (size_t)h);
    free(back);
    free(rgb);
}

/* Sizes around ZIP's 16-line chunks: one line, a partial last chunk, odd widths. */
static void test_roundtrip(void **state)
{
    (void)state;
    roundtrip(1, 1);
    roundtrip(7, 3);
    roundtrip(33, 17);
    roundtrip(64, 48);
}

/* Writing over an existing image replaces it, and the temporary file the
 * writer goes through is gone afterwards. */
static void test_overwrite_leaves_one_file(void **state)
{
    (void)state;
    char dir[600], path[700];
    snprintf(dir, sizeof dir, "%s/over", tmpdir);
    assert_int_equal(mkdir(dir, 0755), 0);
    snprintf(path, sizeof path, "%s/img.exr", dir);
    float a[6] = {1, 2, 3, 4, 5, 6}, b[6] = {-1, -2, -3, -4, -5, -6};
    assert_int_equal(brdf_exr_write_rgb(path, 2, 1, a, NULL), 0);
    assert_int_equal(brdf_exr_write_rgb(path, 1, 2, b, NULL), 0);
    int w, h;
    float *back = NULL;
    assert_int_equal(brdf_exr_read_rgb(path, &w, &h, &back, NULL), 0);
    assert_int_equal(w, 1);
    assert_int_equal(h, 2);
    assert_memory_equal(back, b, sizeof b);
    free(back);
    DIR *dp = opendir(dir);
    assert_non_null(dp);
    int entries = 0;
    struct dirent *e;
    while ((e = readdir(dp)) != NULL)
        entries += strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0;
    closedir(dp);
    assert_int_equal(entries, 1);
}

static void test_bad_arguments(void **state)
{
    (void)state;
    char path[600];
    snprintf(path, sizeof path, "%s/bad.exr", tmpdir);
    float px[3] = {1, 2, 3};
    struct gonio_err err = {0};
    assert_true(brdf_exr_write_rgb(path, 0, 1, px, &err) < 0);
    assert_non_null(strstr(err.msg, "0x1"));
    assert_non_null(strstr(err.msg, path));
    assert_true(brdf_exr_write_rgb(path, 1, -4, px, &err) < 0);
    assert_true(brdf_exr_write_rgb(path, 1, 1, NULL, &err) < 0);
    assert_true(brdf_exr_write_rgb("", 1, 1, px, &err) < 0);
    struct stat st;
    assert_int_equal(stat(path, &st), -1); /* nothing written */
}

static void test_missing_directory(void **state)
{
    (void)state;
    char path[600];
    snprintf(path, sizeof path, "%s/no/such/dir/img.exr", tmpdir);
    float px[3] = {1, 2, 3};
    struct gonio_err err = {0};
    assert_true(brdf_exr_write_rgb(path, 1, 1, px, &err) < 0);
    assert_non_null(strstr(err.msg, path));
    struct stat st;
    assert_int_equal(stat(path, &st), -1);
    /* The directory of the test holds nothing but what other tests wrote. */
    char dir[600];
    snprintf(dir, sizeof dir, "%s/no", tmpdir);
    assert_int_equal(stat(dir, &st), -1);
}

static void test_read_errors(void **state)
{
    (void)state;
    char path[600];
    struct gonio_err err = {0};
    int w, h;
    float *rgb = (float *)&w; /* must be reset to NULL on failure */
    snprintf(path, sizeof path, "%s/absent.exr", tmpdir);
    assert_true(brdf_exr_read_rgb(path, &w, &h, &rgb, &err) < 0);
    assert_null(rgb);
    assert_non_null(strstr(err.msg, path));
    /* Not an EXR file. */
    snprintf(path, sizeof path, "%s/text.exr", tmpdir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("this is not an image\n", f);
    fclose(f);
    assert_true(brdf_exr_read_rgb(path, &w, &h, &rgb, &err) < 0);
    assert_null(rgb);
}

/* exrheader (Debian package openexr), when installed, reads our file and
 * sees three FLOAT channels, ZIP compression and the data window. */
static void test_exrheader_if_available(void **state)
{
    (void)state;
    if (system("command -v exrheader >/dev/null 2>&1") != 0) {
        gonio_test_skip("exrheader not installed (Debian package openexr): external check");
    }
    char path[600], cmd[2400];
    snprintf(path, sizeof path, "%s/hdr.exr", tmpdir);
    float px[3 * 6] = {0};
    assert_int_equal(brdf_exr_write_rgb(path, 3, 2, px, NULL), 0);
    snprintf(cmd, sizeof cmd,
             "exrheader '%s' | grep -q 'zip, multi-scanline' && "
             "exrheader '%s' | grep -c '32-bit floating-point' | grep -qx 3 && "
             "exrheader '%s' | grep -q '(0 0) - (2 1)'",
             path, path, path);
    assert_int_equal(system(cmd), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_roundtrip),
        cmocka_unit_test(test_overwrite_leaves_one_file),
        cmocka_unit_test(test_bad_arguments),
        cmocka_unit_test(test_missing_directory),
        cmocka_unit_test(test_read_errors),
        cmocka_unit_test(test_exrheader_if_available),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
