/* Model files (fit/model_file.h): bit-exact round trips, damaged files
 * refused with a message naming the file, and fit_material_open for ABC,
 * MLP and pass-through specifications. */
#include "tests/gonio_test.h"

#include <string.h>
#include <unistd.h>

#include "brdf/abc.h"
#include "brdf/domain.h"
#include "fit/abc_model.h"
#include "fit/mlp.h"
#include "fit/model_file.h"

static char dir[] = "/tmp/gonio-modelfileXXXXXX";

static int setup(void **state)
{
    (void)state;
    return mkdtemp(dir) ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    return system(cmd) == 0 ? 0 : -1;
}

static void path_of(char *buf, size_t len, const char *name)
{
    snprintf(buf, len, "%s/%s", dir, name);
}

static unsigned char *slurp(const char *path, size_t *len)
{
    FILE *fp = fopen(path, "rb");
    assert_non_null(fp);
    fseek(fp, 0, SEEK_END);
    long n = ftell(fp);
    rewind(fp);
    unsigned char *b = malloc((size_t)n + 1);
    assert_int_equal(fread(b, 1, (size_t)n, fp), (size_t)n);
    fclose(fp);
    *len = (size_t)n;
    return b;
}

static void spill(const char *path, const unsigned char *b, size_t len)
{
    FILE *fp = fopen(path, "wb");
    assert_non_null(fp);
    assert_int_equal(fwrite(b, 1, len, fp), len);
    fclose(fp);
}

/* Awkward doubles (negative zero, subnormal, extremes, a NaN payload)
 * come back with the same bits, and so do the keys. */
static void test_round_trip_bits(void **state)
{
    (void)state;
    double x[7] = {-0.0, 4.9406564584124654e-324, 1.7976931348623157e308, -1.0 / 3.0,
                   0.1, 0, 0};
    uint64_t nan_bits = UINT64_C(0x7ff8000000012345);
    memcpy(&x[5], &nan_bits, 8);
    x[6] = -INFINITY;
    struct fit_model_file *f = fit_model_file_new("test-kind", 3);
    assert_non_null(f);
    assert_int_equal(fit_model_file_set(f, "alpha", "%d", 42), 0);
    assert_int_equal(fit_model_file_set(f, "note", "two words"), 0);
    assert_int_equal(fit_model_file_set(f, "alpha", "%d", 43), 0); /* replaced */
    assert_true(fit_model_file_set(f, "bad key", "x") < 0);
    assert_true(fit_model_file_set(f, "data", "x") < 0);
    assert_true(fit_model_file_set(f, "k", "line\nbreak") < 0);
    assert_int_equal(fit_model_file_set_data(f, x, 7), 0);
    char path[256];
    path_of(path, sizeof path, "bits.model");
    struct gonio_err err = {0};
    assert_int_equal(fit_model_file_write(f, path, &err), 0);
    struct fit_model_file *g = fit_model_file_read(path, &err);
    if (!g)
        print_error("%s\n", err.msg);
    assert_non_null(g);
    assert_string_equal(g->kind, "test-kind");
    assert_int_equal(g->version, 3);
    assert_int_equal(g->n_kv, 2);
    assert_string_equal(fit_model_file_get(g, "alpha"), "43");
    assert_string_equal(fit_model_file_get(g, "note"), "two words");
    assert_null(fit_model_file_get(g, "missing"));
    long v;
    assert_int_equal(fit_model_file_get_long(g, "alpha", path, &v, &err), 0);
    assert_int_equal(v, 43);
    assert_true(fit_model_file_get_long(g, "note", path, &v, &err) < 0);
    assert_non_null(strstr(err.msg, path));
    assert_int_equal(g->n_data, 7);
    assert_memory_equal(g->data, x, sizeof x);
    /* The header is text a person can read; the data are little-endian
     * binary64: check the first value's bytes independently. */
    size_t len;
    unsigned char *b = slurp(path, &len);
    assert_memory_equal(b, "gonio-model test-kind 3\nalpha 43\nnote two words\ndata 7 ", 54);
    unsigned char *data = b + len - 56;
    static const unsigned char neg_zero_le[8] = {0, 0, 0, 0, 0, 0, 0, 0x80};
    assert_memory_equal(data, neg_zero_le, 8);
    free(b);
    fit_model_file_free(f);
    fit_model_file_free(g);
}

/* Every kind of damage is refused, and the message names the file. */
static void test_damaged_files(void **state)
{
    (void)state;
    double x[4] = {1, 2, 3, 4};
    struct fit_model_file *f = fit_model_file_new("abc", 1);
    fit_model_file_set(f, "k", "v");
    fit_model_file_set_data(f, x, 4);
    char good[256], bad[256];
    path_of(good, sizeof good, "good.model");
    path_of(bad, sizeof bad, "bad.model");
    assert_int_equal(fit_model_file_write(f, good, NULL), 0);
    fit_model_file_free(f);
    size_t len;
    unsigned char *b = slurp(good, &len);
    unsigned char *c = malloc(len + 16);
    struct {
        const char *what;
        int kind; /* 0 truncate by one, 1 extra byte, 2 flip a data bit, 3 bad magic,
                     4 cut in the header, 5 corrupt the count, 6 empty */
    } cases[] = {{"truncated", 0}, {"trailing byte", 1}, {"flipped bit", 2}, {"magic", 3},
                 {"header cut", 4}, {"count", 5},        {"empty", 6}};
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        memcpy(c, b, len);
        size_t n = len;
        switch (cases[k].kind) {
        case 0: n--; break;
        case 1: c[n++] = 0; break;
        case 2: c[len - 3] ^= 0x10; break;
        case 3: c[0] = 'G'; break;
        case 4: n = 20; break;
        case 5: {
            unsigned char *d = (unsigned char *)strstr((char *)c, "data 4");
            d[5] = '3';
            break;
        }
        case 6: n = 0; break;
        }
        spill(bad, c, n);
        struct gonio_err err = {0};
        struct fit_model_file *g = fit_model_file_read(bad, &err);
        if (g)
            print_error("case %s was accepted\n", cases[k].what);
        assert_null(g);
        assert_int_equal(err.code, GONIO_EBADDATA);
        assert_non_null(strstr(err.msg, bad));
        /* The same through fit_material_open. */
        char spec[300];
        snprintf(spec, sizeof spec, "model:%s", bad);
        assert_null(fit_material_open(spec, &err));
        assert_non_null(strstr(err.msg, bad));
    }
    struct gonio_err err = {0};
    char missing[256];
    path_of(missing, sizeof missing, "missing.model");
    assert_null(fit_model_file_read(missing, &err));
    assert_int_equal(err.code, GONIO_ENOTFOUND);
    assert_non_null(strstr(err.msg, missing));
    free(b);
    free(c);
}

/* An ABC model file opens as a material equal to brdf_abc_eval with the
 * same parameters; an unknown kind or bad parameters are refused. */
static void test_abc_material(void **state)
{
    (void)state;
    struct brdf_abc p = {{0.11, 0.07, 0.05}, {2.5, 2.0, 1.5}, 350.0, 0.6, 1.45};
    struct fit_model_file *f = fit_abc_model_file(&p);
    char path[256], spec[300];
    path_of(path, sizeof path, "abc.model");
    snprintf(spec, sizeof spec, "model:%s", path);
    assert_int_equal(fit_model_file_write(f, path, NULL), 0);
    struct gonio_err err = {0};
    brdf_material *m = fit_material_open(spec, &err);
    if (!m)
        print_error("%s\n", err.msg);
    assert_non_null(m);
    assert_string_equal(brdf_material_name(m), spec);
    for (int ti = 0; ti <= 80; ti += 20)
        for (int tr = -80; tr <= 80; tr += 10) {
            struct brdf_pair g;
            brdf_pair_inplane(ti, tr, &g);
            double a[3], e[3];
            brdf_material_eval(m, &g, 1, a);
            brdf_abc_eval(&p, &g, e);
            assert_memory_equal(a, e, sizeof a);
        }
    brdf_material_free(m);
    /* eta < 1 is not an ABC model. */
    f->data[8] = 0.5;
    assert_int_equal(fit_model_file_write(f, path, NULL), 0);
    assert_null(fit_material_open(spec, &err));
    assert_non_null(strstr(err.msg, path));
    assert_non_null(strstr(err.msg, "eta"));
    fit_model_file_free(f);
    /* A kind nobody registered. */
    f = fit_model_file_new("no-such-kind", 1);
    assert_int_equal(fit_model_file_write(f, path, NULL), 0);
    fit_model_file_free(f);
    assert_null(fit_material_open(spec, &err));
    assert_non_null(strstr(err.msg, "no-such-kind"));
    /* Anything but model: goes to brdf_material_open. */
    m = fit_material_open("default", &err);
    brdf_material *ref = brdf_material_open("default", &err);
    assert_non_null(m);
    assert_string_equal(brdf_material_name(m), brdf_material_name(ref));
    brdf_material_free(m);
    brdf_material_free(ref);
    assert_null(fit_material_open("nosuch:thing", &err));
}

/* An MLP written and read back has the same shape, normalisation and
 * bit-identical weights, and evaluates identically. */
static void test_mlp_round_trip(void **state)
{
    (void)state;
    int w[] = {2, 5, 4, 3};
    struct fit_mlp net;
    assert_int_equal(fit_mlp_init(&net, 3, w, NULL), 0);
    uint64_t s = 99;
    for (size_t k = 0; k < net.n_params; k++)
        net.params[k] = ((double)(brdf_splitmix64(&s) >> 11) * 0x1.0p-53 - 0.5) / 3.0;
    net.offset[0] = 40.0 / 3.0;
    net.offset[1] = -0.1;
    net.scale[0] = 1.0 / 45.0;
    net.scale[1] = 1.0 / 90.0;
    struct fit_model_file *f = fit_model_file_new("mlp", 1);
    fit_model_file_set(f, "inputs", "theta_i_deg,theta_r_deg");
    assert_int_equal(fit_mlp_to_file(&net, f), 0);
    char path[256], spec[300];
    path_of(path, sizeof path, "mlp.model");
    assert_int_equal(fit_model_file_write(f, path, NULL), 0);
    fit_model_file_free(f);
    struct gonio_err err = {0};
    struct fit_model_file *g = fit_model_file_read(path, &err);
    assert_non_null(g);
    struct fit_mlp back;
    assert_int_equal(fit_mlp_from_file(g, path, &back, &err), 0);
    assert_int_equal(back.n_layers, 3);
    assert_memory_equal(back.width, net.width, 4 * sizeof(int));
    assert_memory_equal(back.offset, net.offset, 2 * sizeof(double));
    assert_memory_equal(back.scale, net.scale, 2 * sizeof(double));
    assert_int_equal(back.n_params, net.n_params);
    assert_memory_equal(back.params, net.params, net.n_params * sizeof(double));
    /* Opened as a material, an in-plane pair evaluates to expm1 of the
     * original network's outputs. */
    snprintf(spec, sizeof spec, "model:%s", path);
    brdf_material *m = fit_material_open(spec, &err);
    if (!m)
        print_error("%s\n", err.msg);
    assert_non_null(m);
    struct brdf_pair pr;
    brdf_pair_inplane(30, 10, &pr);
    double u[2] = {30, 10}, z[3], rgb[3];
    fit_mlp_forward(&net, u, 1, z);
    brdf_material_eval(m, &pr, 1, rgb);
    for (int k = 0; k < 3; k++)
        assert_close(rgb[k], z[k] > 0 ? expm1(z[k]) : 0.0, 1e-15 * (1 + fabs(rgb[k])));
    brdf_material_free(m);
    /* Weights that do not match the widths are refused. */
    fit_mlp_free(&back);
    g->n_data--;
    assert_true(fit_mlp_from_file(g, path, &back, &err) < 0);
    assert_non_null(strstr(err.msg, path));
    assert_non_null(strstr(err.msg, "weights"));
    fit_model_file_free(g);
    fit_mlp_free(&net);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip_bits),
        cmocka_unit_test(test_damaged_files),
        cmocka_unit_test(test_abc_material),
        cmocka_unit_test(test_mlp_round_trip),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
