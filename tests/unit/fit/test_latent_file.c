/* Latent decoder weight file and tiny training runs:
 *  - a tiny decoder trained twice (1 and 2 threads) gives byte-identical files,
 *    and another seed a different one;
 *  - save/load round trip is bit-exact;
 *  - the forward pass equals an independent evaluation written here from
 *    the format in docs/latent.md, reading the file's bytes directly;
 *  - damaged files are refused with a message naming the file;
 *  - held-out materials are refused for training. */
#define _GNU_SOURCE /* mkdtemp, memmem */
#include <string.h>
#include <unistd.h>

#include "brdf/angles.h"
#include "fit/latent.h"
#include "tests/gonio_test.h"

static char tmpdir[4096];

static int setup_tmp(void **state)
{
    (void)state;
    const char *base = getenv("GONIO_TMP");
    if (!base || !*base)
        base = "/tmp";
    gonio_mkdir_p(base, NULL);
    snprintf(tmpdir, sizeof tmpdir, "%s/test_latent_file.XXXXXX", base);
    return mkdtemp(tmpdir) ? 0 : -1;
}

static unsigned char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc((size_t)n + 1);
    assert_int_equal(fread(b, 1, (size_t)n, f), (size_t)n);
    fclose(f);
    *len = (size_t)n;
    return b;
}

static void spit(const char *path, const void *b, size_t len)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(b, 1, len, f), len);
    fclose(f);
}

static const char *tiny_set[] = {"white-paint", "chrome", "red-fabric"};

static latent_decoder *train_tiny(uint64_t seed, int threads)
{
    struct latent_train_options o = latent_train_default_options();
    o.nz = 4;
    o.layers = 2;
    o.width = 16;
    o.steps = 30;
    o.samples_per_step = 16;
    o.seed = seed;
    o.threads = threads;
    latent_decoder *d = NULL;
    struct gonio_err err = {0};
    int rc = latent_train(tiny_set, 3, &o, &d, &err);
    if (rc < 0)
        fail_msg("%s", err.msg);
    return d;
}

static void save(const latent_decoder *d, const char *name, char *path, size_t size)
{
    snprintf(path, size, "%s/%s", tmpdir, name);
    struct gonio_err err = {0};
    if (latent_decoder_save(d, path, &err) < 0)
        fail_msg("%s", err.msg);
}

static void test_tiny_training_deterministic(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    latent_decoder *a = train_tiny(7, 1), *b = train_tiny(7, 2), *c = train_tiny(8, 2);
    char pa[4200], pb[4200], pc[4200];
    save(a, "a.gld", pa, sizeof pa);
    save(b, "b.gld", pb, sizeof pb);
    save(c, "c.gld", pc, sizeof pc);
    size_t la, lb, lc;
    unsigned char *ba = slurp(pa, &la), *bb = slurp(pb, &lb), *bc = slurp(pc, &lc);
    assert_int_equal(la, lb);
    assert_memory_equal(ba, bb, la);
    /* another seed: the header differs in its seed line, and so do the weights */
    assert_true(la != lc || memcmp(ba, bc, la) != 0);
    assert_true(latent_decoder_crc(a) != latent_decoder_crc(c));
    assert_int_equal(latent_decoder_n_materials(a), 3);
    assert_string_equal(latent_decoder_material(a, 1), "chrome");
    free(ba);
    free(bb);
    free(bc);
    latent_decoder_free(a);
    latent_decoder_free(b);
    latent_decoder_free(c);
}

/* docs/latent.md's layout: layer l has W [in][out] then b [out]; layer 0's
 * input is the 6-value encoding then z; ReLU hidden layers; f = max(0,
 * exp(o) - 1). Shape and data offset are parsed here from the header text. */
static void independent_eval(const unsigned char *file, size_t len, const double *z,
                             const struct brdf_pair *p, double f[3])
{
    int nz = 0, layers = 0, width = 0;
    const char *s = (const char *)file;
    const char *k;
    assert_non_null(k = memmem(s, len, "\nnz ", 4));
    nz = atoi(k + 4);
    assert_non_null(k = memmem(s, len, "\nlayers ", 8));
    layers = atoi(k + 8);
    assert_non_null(k = memmem(s, len, "\nwidth ", 7));
    width = atoi(k + 7);
    assert_non_null(k = memmem(s, len, "\ndata ", 6));
    const char *nl = memchr(k + 1, '\n', len - (size_t)(k + 1 - s));
    assert_non_null(nl);
    const unsigned char *w = (const unsigned char *)nl + 1;
    size_t off = 0;
    double in[300], out[300];
    int nin = 6 + nz;
    double st = sin(p->theta_h), ct = cos(p->theta_h), sd = sin(p->theta_d), cd = cos(p->theta_d);
    double x[6] = {st, 0, ct, sd * cos(p->phi_d), sd * sin(p->phi_d), cd};
    for (int i = 0; i < 6; i++)
        in[i] = x[i];
    for (int i = 0; i < nz; i++)
        in[6 + i] = z[i];
    for (int l = 0; l <= layers; l++) {
        int no = l == layers ? 3 : width;
        for (int j = 0; j < no; j++) {
            double acc = 0;
            for (int i = 0; i < nin; i++) {
                double wij;
                memcpy(&wij, w + 8 * (off + (size_t)i * (size_t)no + (size_t)j), 8);
                acc += in[i] * wij;
            }
            double bj;
            memcpy(&bj, w + 8 * (off + (size_t)nin * (size_t)no + (size_t)j), 8);
            out[j] = acc + bj;
        }
        off += (size_t)nin * (size_t)no + (size_t)no;
        for (int j = 0; j < no; j++)
            in[j] = l == layers ? out[j] : (out[j] > 0 ? out[j] : 0);
        nin = no;
    }
    for (int c = 0; c < 3; c++) {
        double v = expm1(in[c]);
        f[c] = v > 0 ? v : 0;
    }
}

static void test_round_trip_and_independent_eval(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    latent_decoder *a = train_tiny(3, 2);
    char pa[4200], pb[4200];
    save(a, "rt.gld", pa, sizeof pa);
    struct gonio_err err = {0};
    latent_decoder *b = latent_decoder_load(pa, &err);
    if (!b)
        fail_msg("%s", err.msg);
    assert_int_equal(latent_decoder_crc(a), latent_decoder_crc(b));
    assert_int_equal(latent_decoder_seed(b), 3);
    assert_int_equal(latent_decoder_nz(b), 4);
    for (size_t m = 0; m < 3; m++) {
        assert_string_equal(latent_decoder_material(a, m), latent_decoder_material(b, m));
        assert_memory_equal(latent_decoder_latent(a, m), latent_decoder_latent(b, m),
                            4 * sizeof(double));
    }
    save(b, "rt2.gld", pb, sizeof pb);
    size_t la, lb;
    unsigned char *ba = slurp(pa, &la), *bb = slurp(pb, &lb);
    assert_int_equal(la, lb);
    assert_memory_equal(ba, bb, la);

    /* forward pass against the independent evaluation, at several pairs */
    const double *z = latent_decoder_latent(b, 0);
    struct brdf_pair pairs[4];
    brdf_pair_inplane(30, 30, &pairs[0]);
    brdf_pair_inplane(10, -60, &pairs[1]);
    brdf_pair_spherical(45, 0, 50, 120, &pairs[2]);
    brdf_pair_from_hd(0.3, 1.1, -2.0, &pairs[3]);
    double rgb[12];
    latent_decoder_eval(b, z, pairs, 4, rgb);
    for (int k = 0; k < 4; k++) {
        double f[3];
        independent_eval(ba, la, z, &pairs[k], f);
        for (int c = 0; c < 3; c++)
            assert_close(rgb[3 * k + c], f[c], 1e-12 * (1 + fabs(f[c])));
    }
    free(ba);
    free(bb);
    latent_decoder_free(a);
    latent_decoder_free(b);
}

static void expect_refused(const char *path, const char *what)
{
    struct gonio_err err = {0};
    latent_decoder *d = latent_decoder_load(path, &err);
    if (d)
        fail_msg("%s: damaged file (%s) was accepted", path, what);
    assert_true(err.code == GONIO_EBADDATA || err.code == GONIO_ENOTFOUND);
    if (!strstr(err.msg, path))
        fail_msg("message does not name the file (%s): %s", what, err.msg);
}

static void test_damaged_files_refused(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    latent_decoder *a = train_tiny(5, 1);
    char p[4200], q[4300];
    save(a, "good.gld", p, sizeof p);
    latent_decoder_free(a);
    size_t len;
    unsigned char *b = slurp(p, &len);
    unsigned char *c = malloc(len + 16);

    snprintf(q, sizeof q, "%s/truncated.gld", tmpdir);
    spit(q, b, len - 5);
    expect_refused(q, "truncated");

    snprintf(q, sizeof q, "%s/extended.gld", tmpdir);
    memcpy(c, b, len);
    c[len] = 0;
    spit(q, c, len + 1);
    expect_refused(q, "extra byte");

    snprintf(q, sizeof q, "%s/flipped.gld", tmpdir);
    memcpy(c, b, len);
    c[len - 100] ^= 0x10;
    spit(q, c, len);
    expect_refused(q, "flipped data bit");

    snprintf(q, sizeof q, "%s/version.gld", tmpdir);
    memcpy(c, b, len);
    char *v = memmem(c, len, "decoder 1\n", 10);
    assert_non_null(v);
    v[8] = '9';
    spit(q, c, len);
    expect_refused(q, "future version");

    snprintf(q, sizeof q, "%s/magic.gld", tmpdir);
    memcpy(c, b, len);
    c[0] = 'G';
    spit(q, c, len);
    expect_refused(q, "bad magic");

    snprintf(q, sizeof q, "%s/shape.gld", tmpdir);
    memcpy(c, b, len);
    v = memmem(c, len, "\nwidth 16\n", 10);
    assert_non_null(v);
    v[8] = '7'; /* width 17: the data no longer fits the shape */
    spit(q, c, len);
    expect_refused(q, "wrong shape");

    snprintf(q, sizeof q, "%s/absent.gld", tmpdir);
    expect_refused(q, "missing file");
    free(b);
    free(c);
}

static void test_heldout_refused(void **state)
{
    (void)state;
    const char *bad[] = {"white-paint", "brass"};
    latent_decoder *d = NULL;
    struct gonio_err err = {0};
    int rc = latent_train(bad, 2, NULL, &d, &err);
    assert_int_equal(rc, -GONIO_EUSAGE);
    assert_null(d);
    assert_non_null(strstr(err.msg, "brass"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tiny_training_deterministic),
        cmocka_unit_test(test_round_trip_and_independent_eval),
        cmocka_unit_test(test_damaged_files_refused),
        cmocka_unit_test(test_heldout_refused),
    };
    return cmocka_run_group_tests(tests, setup_tmp, NULL);
}
