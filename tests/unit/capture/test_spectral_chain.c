/* The calibration chain band by band on the spectral-lab scene, whose
 * spectral detector gives raw counts per band (an offset that differs from
 * band to band, dark, shot and read noise, a nonlinearity, a drifting lamp
 * with its monitor): `gonio calibrate dark` and `gonio calibrate
 * reference` offline, then a DS3 capture of the default material, whose
 * bands are reduced with each band's dark, reference and the standard's
 * certificate at the band's wavelength into spectra.csv. The reduced BRDF
 * comes back to a median |measured / true - 1| of at most 0.5 % over the
 * values with u at most 1 % (a signal-to-noise ratio of 100 or more:
 * u holds the counting noise and more); reduced again with one band's dark
 * for every band, it is measurably worse: the dark is per band; `gonio
 * recalibrate` with the same calibration reduces the bands alike. */
#include "capture/calibration_bands.h"
#include "tests/gonio_test.h"

#include "spectral_chain_test.h"

static struct spectral_chain sc;

static int setup(void **state)
{
    (void)state;
    /* the reference read 8 times at each point: its noise is every
     * sample's too */
    const char *const what[2] = {"dark", "reference --repeats 8 --plan " SPECTRAL_PLAN};
    if (spectral_chain_dir(&sc, "spectral_chain") < 0)
        return -1;
    return spectral_chain_run(&sc, "spectral-lab", what, 2);
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(sc.dir);
}

static void test_bands_recover_the_brdf(void **state)
{
    (void)state;
    struct spectral_result r;
    spectral_chain_assess(sc.cap, &r);
    fprintf(stderr, "per band: %zu values over %zu bands, %zu with SNR >= 100: median "
            "|measured/true - 1| %.4f %%, mean measured/true - 1 %+.4f %%, per-band mean's rms "
            "%.4f %%\n", r.rows, r.bands, r.used, 100 * r.med, 100 * r.bias,
            100 * r.band_bias_rms);
    assert_int_equal(r.bands, 31);
    assert_true(r.used >= 300);
    assert_true(r.med <= 0.005);
    assert_true(r.band_bias_rms <= 0.002); /* no band off by its own dark or certificate */
}

static void test_recalibrate_reduces_the_bands_alike(void **state)
{
    (void)state;
    spectral_chain_assert_recalibrates_alike(&sc);
}

/* The same records reduced with the first band's dark for every band. */
static void test_one_dark_for_all_bands_is_worse(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    struct cal_loaded cl;
    assert_int_equal(cal_load(sc.cal, sc.id, &cl, &err), 0);
    assert_non_null(cl.bands);
    for (int g = 0; g < cl.bands->n_groups; g++)
        for (size_t j = 0; j < cl.bands->group[g].cal.n_darks; j++)
            for (int c = 0; c < 3; c++)
                cl.bands->group[g].darks[j].mean[c] = cl.bands->group[0].darks[j].mean[0];
    char broken[256];
    spectral_chain_reduce(&sc, &cl, "broken", broken, sizeof broken);
    struct spectral_result good, bad;
    spectral_chain_assess(sc.cap, &good);
    spectral_chain_assess(broken, &bad);
    fprintf(stderr, "one dark for all bands: median %.4f %%, per-band mean's rms %.4f %% (each "
            "band's dark: %.4f %%, %.4f %%)\n", 100 * bad.med, 100 * bad.band_bias_rms,
            100 * good.med, 100 * good.band_bias_rms);
    assert_true(bad.med > good.med);
    assert_true(bad.band_bias_rms >= 3 * good.band_bias_rms && bad.band_bias_rms > 0.004);
    cal_loaded_free(&cl);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bands_recover_the_brdf),
        cmocka_unit_test(test_one_dark_for_all_bands_is_worse),
        cmocka_unit_test(test_recalibrate_reduces_the_bands_alike),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
