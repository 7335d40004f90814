/* The latent row of the model registry: fit through fit_model_find("latent"),
 * write the model file, open it with fit_material_open("model:PATH") and get
 * the same values as latent_material with the fitted z; a model file whose
 * decoder CRC does not match the decoder is refused, naming the file. */
#define _GNU_SOURCE /* mkdtemp */
#include <string.h>
#include <unistd.h>

#include "brdf/angles.h"
#include "fit/latent.h"
#include "fit/model_file.h"
#include "fit/models.h"
#include "tests/gonio_test.h"

static char tmpdir[4096];

static int setup_tmp(void **state)
{
    (void)state;
    const char *base = getenv("GONIO_TMP");
    if (!base || !*base)
        base = "/tmp";
    gonio_mkdir_p(base, NULL);
    snprintf(tmpdir, sizeof tmpdir, "%s/test_latent_model.XXXXXX", base);
    return mkdtemp(tmpdir) ? 0 : -1;
}

static void test_registry_round_trip(void **state)
{
    (void)state;
    char dpath[4096];
    assert_int_equal(latent_decoder_default_path(dpath, sizeof dpath), 0);
    struct gonio_err err = {0};
    latent_decoder *dec = latent_decoder_load(dpath, &err);
    if (!dec)
        fail_msg("%s", err.msg);
    /* samples: the decoder at a training latent, on a coarse in-plane grid */
    long m = latent_decoder_find(dec, "red-fabric");
    assert_true(m >= 0);
    struct fit_sample s[200] = {0};
    size_t n = 0;
    for (int ti = 0; ti <= 70; ti += 10)
        for (int tr = -70; tr <= 70; tr += 7)
            brdf_pair_inplane(ti, tr, &s[n++].g);
    for (size_t k = 0; k < n; k++)
        latent_decoder_eval(dec, latent_decoder_latent(dec, (size_t)m), &s[k].g, 1, s[k].rgb);

    const struct fit_model_kind *kind = fit_model_find("latent");
    assert_non_null(kind);
    assert_non_null(kind->open);
    assert_ptr_equal(fit_model_for_kind("latent"), kind);
    struct fit_data data = {.rgb = s, .n_rgb = n};
    struct fit_model_options opt = fit_model_default_options();
    struct fit_model_file *f = NULL;
    struct fit_model_report rep = {0};
    if (kind->fit(&data, &opt, &f, &rep, &err) < 0)
        fail_msg("%s", err.msg);
    assert_string_equal(f->kind, "latent");
    assert_int_equal(f->n_data, (size_t)latent_decoder_nz(dec));
    char crc[16];
    snprintf(crc, sizeof crc, "%08x", (unsigned)latent_decoder_crc(dec));
    assert_string_equal(fit_model_file_get(f, "decoder_crc"), crc);

    char path[4200], spec[4300];
    snprintf(path, sizeof path, "%s/latent.model", tmpdir);
    if (fit_model_file_write(f, path, &err) < 0)
        fail_msg("%s", err.msg);
    snprintf(spec, sizeof spec, "model:%s", path);
    brdf_material *opened = fit_material_open(spec, &err);
    if (!opened)
        fail_msg("%s", err.msg);
    brdf_material *direct = latent_material(dec, f->data, NULL);
    struct brdf_pair p[3];
    brdf_pair_spherical(40, 0, 30, 100, &p[0]); /* out of plane */
    brdf_pair_inplane(20, 20, &p[1]);
    brdf_pair_from_hd(0.2, 0.9, 1.3, &p[2]);
    double a[9], b[9], t[9];
    brdf_material_eval(opened, p, 3, a);
    brdf_material_eval(direct, p, 3, b);
    latent_decoder_eval(dec, latent_decoder_latent(dec, (size_t)m), p, 3, t);
    for (int k = 0; k < 9; k++) {
        assert_true(a[k] == b[k]); /* the file holds z exactly */
        assert_close(a[k], t[k], 0.05 * t[k] + 1e-3); /* and z reproduces the material */
    }
    brdf_material_free(opened);
    brdf_material_free(direct);

    /* a model fitted with another decoder */
    assert_int_equal(fit_model_file_set(f, "decoder_crc", "%08x",
                                        (unsigned)latent_decoder_crc(dec) ^ 1u),
                     0);
    snprintf(path, sizeof path, "%s/other.model", tmpdir);
    if (fit_model_file_write(f, path, &err) < 0)
        fail_msg("%s", err.msg);
    snprintf(spec, sizeof spec, "model:%s", path);
    memset(&err, 0, sizeof err);
    assert_null(fit_material_open(spec, &err));
    assert_int_equal(err.code, GONIO_EBADDATA);
    if (!strstr(err.msg, path) || !strstr(err.msg, "CRC"))
        fail_msg("message: %s", err.msg);
    fit_model_file_free(f);
    latent_decoder_free(dec);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_registry_round_trip),
    };
    return cmocka_run_group_tests(tests, setup_tmp, NULL);
}
