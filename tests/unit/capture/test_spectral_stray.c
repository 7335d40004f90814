/* The stray light band by band: a spectral detector on the spectral-lab
 * scene with a stray light floor of 0.005 1/sr in every band (ten times
 * lab's, so that it lifts a diffuse sample's bands by about 2 %), calibrated
 * offline with its stray-light step (`gonio calibrate dark`, `stray` with
 * the sample removed, `reference --stray newest`), then a DS3 capture of a
 * diffuse sample. Its bands come back without the stray light's lift
 * (median |measured/true - 1| at most 0.5 %, mean measured/true - 1 within
 * 0.3 %); the same records reduced with the bands' stray light left out
 * are measurably high; `gonio recalibrate` with the same calibration
 * reduces the bands alike. */
#include "capture/calibration_bands.h"
#include "tests/gonio_test.h"

#include "spectral_chain_test.h"

#define STRAY_FLOOR "0.005"

static struct spectral_chain sc;
static char scene[128];

/* spectral-lab with a stray light floor, its first effect. */
static void scene_edit(char *line, size_t size, char *text, size_t text_size)
{
    (void)size;
    if (!strncmp(line, "effects:", 8)) {
        strncat(text, line, text_size - strlen(text) - 1);
        snprintf(line, size, "  - {name: stray_light, floor: " STRAY_FLOOR "}\n");
    }
}

static int setup(void **state)
{
    (void)state;
    const char *const what[3] = {"dark", "stray --repeats 8 --plan " SPECTRAL_PLAN,
                                 "reference --repeats 8 --plan " SPECTRAL_PLAN " --stray newest"};
    if (spectral_chain_dir(&sc, "spectral_stray") < 0)
        return -1;
    snprintf(scene, sizeof scene, "%s/scene.yaml", sc.dir);
    if (spectral_chain_rewrite("spectral-lab", "scenes", scene, scene_edit) < 0)
        return -1;
    return spectral_chain_run(&sc, scene, what, 3);
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(sc.dir);
}

static void test_bands_subtract_their_stray_light(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    struct cal_loaded cl;
    assert_int_equal(cal_load(sc.cal, sc.id, &cl, &err), 0);
    assert_non_null(cl.bands);
    assert_int_equal(cl.bands->n_bands, 31);
    for (int g = 0; g < cl.bands->n_groups; g++)
        assert_int_equal(cl.bands->group[g].cal.n_strays, cl.cal.n_strays);
    cal_loaded_free(&cl);
    struct spectral_result r;
    spectral_chain_assess(sc.cap, &r);
    fprintf(stderr, "per band, stray light subtracted: %zu values with SNR >= 100: median "
            "|measured/true - 1| %.4f %%, mean measured/true - 1 %+.4f %%\n", r.used,
            100 * r.med, 100 * r.bias);
    assert_true(r.used >= 300);
    assert_true(r.med <= 0.005);
    assert_true(fabs(r.bias) <= 0.003);
}

/* The same records reduced with the bands' stray light left out. */
static void test_bands_without_their_stray_light_are_high(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    struct cal_loaded cl;
    assert_int_equal(cal_load(sc.cal, sc.id, &cl, &err), 0);
    for (int g = 0; g < cl.bands->n_groups; g++)
        cl.bands->group[g].cal.n_strays = 0;
    char broken[256];
    spectral_chain_reduce(&sc, &cl, "nostray", broken, sizeof broken);
    struct spectral_result good, bad;
    spectral_chain_assess(sc.cap, &good);
    spectral_chain_assess(broken, &bad);
    fprintf(stderr, "per band, stray light not subtracted: median %.4f %%, mean %+.4f %% "
            "(subtracted: %.4f %%, %+.4f %%)\n", 100 * bad.med, 100 * bad.bias,
            100 * good.med, 100 * good.bias);
    assert_true(bad.bias > good.bias + 0.01);
    assert_true(bad.med > 2 * good.med);
    cal_loaded_free(&cl);
}

static void test_recalibrate_reduces_the_bands_alike(void **state)
{
    (void)state;
    spectral_chain_assert_recalibrates_alike(&sc);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bands_subtract_their_stray_light),
        cmocka_unit_test(test_bands_without_their_stray_light_are_high),
        cmocka_unit_test(test_recalibrate_reduces_the_bands_alike),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
