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
#include <math.h>
#include <sys/stat.h>

#include "brdf/material.h"
#include "brdf/spectral.h"
#include "capture/calibration.h"
#include "capture/calibration_bands.h"
#include "capture/capture_bands.h"
#include "capture/journal_plan.h"
#include "journal/journal.h"
#include "tests/gonio_test.h"

#define SCENE "spectral-lab"
#define PLAN "ds3"
#define MATERIAL "analytic:rough-diffuse"
#define INTEGRATION "0.25"

static char dir[64], cal[128], cap[128], id[128], rig_file[128];

static int setup(void **state)
{
    (void)state;
    if (gonio_test_dir_make(dir, sizeof dir, "spectral_chain") < 0)
        return -1;
    /* The default rig integrating INTEGRATION (auto-ranging starts there),
     * so that the sample reads with a signal-to-noise ratio above 100 in
     * most bands and the standard below the clip. */
    char src[4096], line[512], text[16384] = "";
    gonio_config_path("default", "rigs", src, sizeof src);
    FILE *f = fopen(src, "r");
    if (!f)
        return -1;
    while (fgets(line, sizeof line, f)) {
        const char *at = strstr(line, "fixed_s:");
        if (at)
            snprintf(line + (at - line), sizeof line - (size_t)(at - line),
                     "fixed_s: " INTEGRATION "\n");
        strncat(text, line, sizeof text - strlen(text) - 1);
    }
    fclose(f);
    snprintf(rig_file, sizeof rig_file, "%s/rig.yaml", dir);
    gonio_test_write_text(rig_file, text);
    snprintf(cal, sizeof cal, "%s/cal", dir);
    snprintf(cap, sizeof cap, "%s/cap", dir);
    const char *bin = getenv("GONIO_BIN");
    char cmd[1024];
    FILE *p;
    /* the reference read 8 times at each point: its noise is every
     * sample's too */
    const char *what[2] = {"dark", "reference --repeats 8 --plan " PLAN};
    for (int k = 0; k < 2; k++) {
        snprintf(cmd, sizeof cmd, "'%s/gonio' calibrate %s --offline --scene " SCENE
                 " --rig '%s' --out '%s'", bin ? bin : "build/bin", what[k], rig_file, cal);
        if (!(p = popen(cmd, "r")) || !fgets(id, sizeof id, p) || pclose(p) != 0)
            return -1;
        id[strcspn(id, "\n")] = '\0';
    }
    snprintf(cmd, sizeof cmd, "'%s/gonio' capture --offline --scene " SCENE " --material "
             MATERIAL " --rig '%s' --plan " PLAN " --calibrations '%s' --out '%s' >/dev/null",
             bin ? bin : "build/bin", rig_file, cal, cap);
    return system(cmd) == 0 ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

struct result {
    size_t rows, used, bands;
    double med, bias;
    double band_bias_rms; /* over bands, of each band's mean measured/true - 1 */
};

/* spectra.csv against the material lifted to spectra, as the
 * simulated detector sees it. */
static void assess(const char *path, struct result *r)
{
    struct gonio_err err = {0};
    brdf_material *m = brdf_material_open(MATERIAL, &err);
    assert_non_null(m);
    brdf_spectral *sp = brdf_spectral_lift(m, &err);
    assert_non_null(sp);
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    char line[512];
    assert_non_null(fgets(line, sizeof line, f));
    assert_string_equal(line, "theta_i,theta_r,wavelength_nm,value,acquisition,integration_s,"
                              "saturated,u,snr\n");
    static double err_rel[65536];
    double seen_nm[64], band_sum[64] = {0};
    size_t band_n[64] = {0};
    memset(r, 0, sizeof *r);
    while (fgets(line, sizeof line, f)) {
        double ti, tr, nm, v, t_int, u, snr;
        long acq;
        int sat;
        assert_int_equal(sscanf(line, "%lf,%lf,%lf,%lf,%ld,%lf,%d,%lf,%lf", &ti, &tr, &nm, &v,
                                &acq, &t_int, &sat, &u, &snr), 9);
        r->rows++;
        size_t b = 0;
        while (b < r->bands && seen_nm[b] != nm)
            b++;
        if (b == r->bands && r->bands < 64)
            seen_nm[r->bands++] = nm;
        struct brdf_pair p;
        double truth;
        brdf_pair_inplane(ti, tr, &p);
        brdf_spectral_eval(sp, &p, &nm, 1, &truth);
        if (truth > 0 && snr >= 100 && r->used < 65536 && b < 64) {
            r->bias += v / truth - 1;
            band_sum[b] += v / truth - 1;
            band_n[b]++;
            err_rel[r->used++] = fabs(v / truth - 1);
        }
    }
    fclose(f);
    qsort(err_rel, r->used, sizeof *err_rel, cmp_double);
    r->med = r->used ? err_rel[r->used / 2] : NAN;
    r->bias = r->used ? r->bias / (double)r->used : NAN;
    size_t nb = 0;
    for (size_t b = 0; b < r->bands; b++)
        if (band_n[b]) {
            double mb = band_sum[b] / (double)band_n[b];
            r->band_bias_rms += mb * mb;
            nb++;
        }
    r->band_bias_rms = nb ? sqrt(r->band_bias_rms / (double)nb) : NAN;
    brdf_spectral_free(sp);
    brdf_material_free(m);
}

static void test_bands_recover_the_brdf(void **state)
{
    (void)state;
    char path[512];
    struct result r;
    snprintf(path, sizeof path, "%s/spectra.csv", cap);
    assess(path, &r);
    fprintf(stderr, "per band: %zu values over %zu bands, %zu with SNR >= 100: median "
            "|measured/true - 1| %.4f %%, mean measured/true - 1 %+.4f %%, per-band mean's rms "
            "%.4f %%\n", r.rows, r.bands, r.used, 100 * r.med, 100 * r.bias,
            100 * r.band_bias_rms);
    assert_int_equal(r.bands, 31);
    assert_true(r.used >= 300);
    assert_true(r.med <= 0.005);
    assert_true(r.band_bias_rms <= 0.002); /* no band off by its own dark or certificate */
}

/* gonio recalibrate with the capture's own calibration reduces its bands
 * to the same spectra.csv, byte for byte. */
static void test_recalibrate_reduces_the_bands_alike(void **state)
{
    (void)state;
    const char *bin = getenv("GONIO_BIN");
    char cmd[1024];
    snprintf(cmd, sizeof cmd, "'%s/gonio' recalibrate '%s' --calibration '%s' --calibrations "
             "'%s' -o '%s/recal' >/dev/null", bin ? bin : "build/bin", cap, id, cal, dir);
    assert_int_equal(system(cmd), 0);
    snprintf(cmd, sizeof cmd, "cmp -s '%s/spectra.csv' '%s/recal/spectra.csv'", cap, dir);
    assert_int_equal(system(cmd), 0);
}

/* The same records reduced with the first band's dark for every band. */
static void test_one_dark_for_all_bands_is_worse(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    struct cal_loaded cl;
    assert_int_equal(cal_load(cal, id, &cl, &err), 0);
    assert_non_null(cl.bands);
    for (int g = 0; g < cl.bands->n_groups; g++)
        for (size_t j = 0; j < cl.bands->group[g].cal.n_darks; j++)
            for (int c = 0; c < 3; c++)
                cl.bands->group[g].darks[j].mean[c] = cl.bands->group[0].darks[j].mean[0];
    char path[512], broken[256], cmd[1024];
    snprintf(broken, sizeof broken, "%s/broken", dir);
    mkdir(broken, 0755);
    snprintf(cmd, sizeof cmd, "cp '%s/bands.csv' '%s/'", cap, broken);
    assert_int_equal(system(cmd), 0);
    struct journal_sample *s = NULL;
    struct plan_point *pts = NULL;
    size_t n = 0, np = 0;
    snprintf(path, sizeof path, "%s/samples.csv", cap);
    assert_int_equal(journal_read(path, &s, &n, &err), 0);
    snprintf(path, sizeof path, "%s/plan.json", cap);
    assert_int_equal(journal_plan_read(path, &pts, &np, &err), 0);
    struct journal_plan jp = {.points = pts, .count = np};
    assert_int_equal(capture_bands_reduce(&cl, &jp, s, n, broken, &err), 0);
    struct result good, bad;
    snprintf(path, sizeof path, "%s/spectra.csv", cap);
    assess(path, &good);
    snprintf(path, sizeof path, "%s/spectra.csv", broken);
    assess(path, &bad);
    fprintf(stderr, "one dark for all bands: median %.4f %%, per-band mean's rms %.4f %% (each "
            "band's dark: %.4f %%, %.4f %%)\n", 100 * bad.med, 100 * bad.band_bias_rms,
            100 * good.med, 100 * good.band_bias_rms);
    assert_true(bad.med > good.med);
    assert_true(bad.band_bias_rms >= 3 * good.band_bias_rms && bad.band_bias_rms > 0.004);
    free(s);
    free(pts);
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
