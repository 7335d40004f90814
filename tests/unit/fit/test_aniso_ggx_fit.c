/* The anisotropic GGX model (fit/aniso_ggx_model.h): fitted to samples
 * of a known anisotropic GGX at pairs spread over the sample's azimuths,
 * it finds the truth's roughnesses and orientation, under either name of
 * the lobe (ax and ay swapped with phi + 90); its values stay finite at
 * grazing angles and at l = -v; its model file opens back to the same
 * material, and a file with a roughness out of range is refused. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/domain.h"
#include "fit/aniso_ggx_model.h"
#include "fit/model_file.h"
#include "fit/model_run.h"
#include "tests/gonio_test.h"

static char dir[64];

static int setup(void **state)
{
    (void)state;
    return gonio_test_dir_make(dir, sizeof dir, "aniso-ggx");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

/* n samples of a at random nodes of the full domain, each turned by its
 * own sample azimuth (a seeded draw), so that the half vector takes every
 * azimuth on the sample. */
static struct fit_sample *samples_of(const struct brdf_aniso_ggx *a, size_t n)
{
    struct brdf_domain d;
    struct gonio_err err = {0};
    assert_int_equal(brdf_domain_oop_random(&d, n, 7, &err), 0);
    struct fit_sample *s = calloc(n, sizeof *s);
    assert_non_null(s);
    uint64_t st = 11;
    for (size_t i = 0; i < n; i++) {
        s[i].g = d.pairs[i];
        brdf_pair_rotate(&s[i].g, 360.0 * (double)(brdf_splitmix64(&st) >> 11) * 0x1p-53);
        brdf_aniso_ggx_eval(a, &s[i].g, s[i].rgb);
        for (int k = 0; k < 3; k++)
            s[i].u[k] = NAN;
    }
    brdf_domain_free(&d);
    return s;
}

static brdf_material *fit(const struct fit_sample *s, size_t n, const char *name,
                          struct fit_model_report *rep)
{
    const struct fit_model_kind *kind = fit_model_find("aniso-ggx");
    assert_non_null(kind);
    struct fit_data data = {.rgb = s, .n_rgb = n};
    struct fit_model_options mo = fit_model_default_options();
    struct gonio_err err = {0};
    char path[256];
    snprintf(path, sizeof path, "%s/%s.model", dir, name);
    brdf_material *m = NULL;
    if (fit_model_run(kind, &data, &mo, path, rep, &m, &err) < 0)
        fail_msg("aniso-ggx fit: %s", err.msg);
    return m;
}

static void check_recovers(const struct brdf_aniso_ggx *truth, const char *name)
{
    const size_t n = 3000;
    struct fit_sample *s = samples_of(truth, n);
    struct fit_model_report rep;
    brdf_material *m = fit(s, n, name, &rep);
    char path[256];
    snprintf(path, sizeof path, "%s/%s.model", dir, name);
    struct gonio_err err = {0};
    struct fit_model_file *f = fit_model_file_read(path, &err);
    assert_non_null(f);
    struct brdf_aniso_ggx got;
    assert_int_equal(fit_aniso_ggx_params(f, path, &got, &err), 0);
    print_message("%s: %s\n", name, rep.note);
    /* the canonical name: ax <= ay, phi in [0, 180) */
    double ax = fmin(truth->ax, truth->ay), ay = fmax(truth->ax, truth->ay);
    double phi = fmod(truth->phi_deg + (truth->ax > truth->ay ? 90.0 : 0.0) + 360.0, 180.0);
    assert_rel_close(got.ax, ax, 0.01);
    assert_rel_close(got.ay, ay, 0.01);
    assert_close(got.phi_deg, phi, 0.5);
    for (int k = 0; k < 3; k++) {
        assert_rel_close(got.f0[k], truth->f0[k], 0.02);
        assert_close(got.rho[k], truth->rho[k], 0.005);
    }
    struct brdf_errors e;
    assert_int_equal(fit_sample_errors(m, s, n, &e, &err), 0);
    assert_true(e.log < 1e-3);
    assert_false(brdf_material_isotropic(m));
    fit_model_file_free(f);
    brdf_material_free(m);
    free(s);
}

static void test_recovers_truth(void **state)
{
    (void)state;
    check_recovers(&(struct brdf_aniso_ggx){0.08, 0.24, 30, {0.05, 0.1, 0.2}, {0.9, 0.7, 0.5}},
                   "ratio3");
    /* the other name of a lobe: ax > ay, phi beyond 180 */
    check_recovers(&(struct brdf_aniso_ggx){0.3, 0.2, 250, {0.2, 0.2, 0.2}, {0.05, 0.05, 0.05}},
                   "swapped");
}

static void test_grazing_finite(void **state)
{
    (void)state;
    const struct brdf_aniso_ggx a = {0.01, 0.5, 70, {0.1, 0.1, 0.1}, {1.5, 1, 0.04}};
    const double th[] = {0, 45, 89, 89.999999, 90};
    for (size_t i = 0; i < sizeof th / sizeof *th; i++)
        for (size_t j = 0; j < sizeof th / sizeof *th; j++)
            for (int az = 0; az < 360; az += 15) {
                struct brdf_pair p;
                brdf_pair_spherical(th[i], 0, th[j], az, &p);
                double rgb[3];
                brdf_aniso_ggx_eval(&a, &p, rgb);
                for (int k = 0; k < 3; k++)
                    if (!isfinite(rgb[k]) || rgb[k] < 0)
                        fail_msg("(%g, 0, %g, %d): %g", th[i], th[j], az, rgb[k]);
            }
    /* a fit whose samples reach grazing stays finite */
    struct fit_sample s[40];
    for (int i = 0; i < 40; i++) {
        brdf_pair_spherical(50 + i, 0, 89.9 - 0.5 * i, 9 * i, &s[i].g);
        brdf_aniso_ggx_eval(&a, &s[i].g, s[i].rgb);
        s[i].u[0] = s[i].u[1] = s[i].u[2] = NAN;
    }
    struct fit_model_report rep;
    brdf_material *m = fit(s, 40, "grazing", &rep);
    struct brdf_errors e;
    struct gonio_err err = {0};
    assert_int_equal(fit_sample_errors(m, s, 40, &e, &err), 0);
    assert_true(isfinite(e.log));
    brdf_material_free(m);
}

static void test_bad_file(void **state)
{
    (void)state;
    struct fit_model_file *f = fit_model_file_new("aniso-ggx", FIT_ANISO_GGX_FILE_VERSION);
    const double x[9] = {0.1, 0.1, 0.1, 0.9, 0.9, 0.9, 0.1, 3.5, 20};
    assert_int_equal(fit_model_file_set_data(f, x, 9), 0);
    struct gonio_err err = {0};
    struct brdf_aniso_ggx a;
    assert_true(fit_aniso_ggx_params(f, "bad.model", &a, &err) < 0);
    assert_non_null(strstr(err.msg, "bad.model"));
    assert_non_null(strstr(err.msg, "3.5"));
    fit_model_file_free(f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_recovers_truth),
        cmocka_unit_test(test_grazing_finite),
        cmocka_unit_test(test_bad_file),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
