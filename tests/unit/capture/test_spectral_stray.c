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

#define PLAN "ds3"
#define MATERIAL "analytic:rough-diffuse"
#define STRAY_FLOOR "0.005"

static char dir[64], cal[128], cap[128], id[128], rig_file[128], scene[128];

/* src (a shipped config) into dst, each line through edit. */
static int rewrite(const char *name, const char *kind, const char *dst,
                   void (*edit)(char *line, size_t size, char *text, size_t text_size))
{
    char src[4096], line[512], text[16384] = "";
    gonio_config_path(name, kind, src, sizeof src);
    FILE *f = fopen(src, "r");
    if (!f)
        return -1;
    while (fgets(line, sizeof line, f)) {
        edit(line, sizeof line, text, sizeof text);
        strncat(text, line, sizeof text - strlen(text) - 1);
    }
    fclose(f);
    gonio_test_write_text(dst, text);
    return 0;
}

/* The rig integrating 0.25 s: the sample reads at SNR > 100 in most bands. */
static void rig_edit(char *line, size_t size, char *text, size_t text_size)
{
    (void)text, (void)text_size;
    const char *at = strstr(line, "fixed_s:");
    if (at)
        snprintf(line + (at - line), size - (size_t)(at - line), "fixed_s: 0.25\n");
}

/* spectral-lab with a stray light floor, its first effect. */
static void scene_edit(char *line, size_t size, char *text, size_t text_size)
{
    (void)size;
    if (!strncmp(line, "effects:", 8)) {
        strncat(text, line, text_size - strlen(text) - 1);
        snprintf(line, size, "  - {name: stray_light, floor: " STRAY_FLOOR "}\n");
    }
}

static int run_id(const char *cmd, char *out, size_t size)
{
    FILE *p = popen(cmd, "r");
    if (!p || !fgets(out, (int)size, p) || pclose(p) != 0)
        return -1;
    out[strcspn(out, "\n")] = '\0';
    return 0;
}

static int setup(void **state)
{
    (void)state;
    if (gonio_test_dir_make(dir, sizeof dir, "spectral_stray") < 0)
        return -1;
    snprintf(rig_file, sizeof rig_file, "%s/rig.yaml", dir);
    snprintf(scene, sizeof scene, "%s/scene.yaml", dir);
    if (rewrite("default", "rigs", rig_file, rig_edit) < 0 ||
        rewrite("spectral-lab", "scenes", scene, scene_edit) < 0)
        return -1;
    snprintf(cal, sizeof cal, "%s/cal", dir);
    snprintf(cap, sizeof cap, "%s/cap", dir);
    const char *bin = getenv("GONIO_BIN");
    char cmd[1024];
    const char *what[3] = {"dark", "stray --repeats 8 --plan " PLAN,
                           "reference --repeats 8 --plan " PLAN " --stray newest"};
    for (int k = 0; k < 3; k++) {
        snprintf(cmd, sizeof cmd, "'%s/gonio' calibrate %s --offline --scene '%s' --rig '%s' "
                 "--out '%s'", bin ? bin : "build/bin", what[k], scene, rig_file, cal);
        if (run_id(cmd, id, sizeof id) < 0)
            return -1;
    }
    snprintf(cmd, sizeof cmd, "'%s/gonio' capture --offline --scene '%s' --material "
             MATERIAL " --rig '%s' --plan " PLAN " --calibrations '%s' --out '%s' >/dev/null",
             bin ? bin : "build/bin", scene, rig_file, cal, cap);
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
    size_t used;
    double med, bias; /* median |measured/true - 1|, mean measured/true - 1 */
};

/* spectra.csv's values with SNR >= 100 against the material lifted to
 * spectra, as the simulated detector sees it. */
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
    static double err_rel[65536];
    memset(r, 0, sizeof *r);
    while (fgets(line, sizeof line, f)) {
        double ti, tr, nm, v, t_int, u, snr;
        long acq;
        int sat;
        assert_int_equal(sscanf(line, "%lf,%lf,%lf,%lf,%ld,%lf,%d,%lf,%lf", &ti, &tr, &nm, &v,
                                &acq, &t_int, &sat, &u, &snr), 9);
        struct brdf_pair p;
        double truth;
        brdf_pair_inplane(ti, tr, &p);
        brdf_spectral_eval(sp, &p, &nm, 1, &truth);
        if (truth > 0 && snr >= 100 && r->used < 65536) {
            r->bias += v / truth - 1;
            err_rel[r->used++] = fabs(v / truth - 1);
        }
    }
    fclose(f);
    qsort(err_rel, r->used, sizeof *err_rel, cmp_double);
    r->med = r->used ? err_rel[r->used / 2] : NAN;
    r->bias = r->used ? r->bias / (double)r->used : NAN;
    brdf_spectral_free(sp);
    brdf_material_free(m);
}

static void test_bands_subtract_their_stray_light(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    struct cal_loaded cl;
    assert_int_equal(cal_load(cal, id, &cl, &err), 0);
    assert_non_null(cl.bands);
    assert_int_equal(cl.bands->n_bands, 31);
    for (int g = 0; g < cl.bands->n_groups; g++)
        assert_int_equal(cl.bands->group[g].cal.n_strays, cl.cal.n_strays);
    cal_loaded_free(&cl);
    char path[512];
    struct result r;
    snprintf(path, sizeof path, "%s/spectra.csv", cap);
    assess(path, &r);
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
    assert_int_equal(cal_load(cal, id, &cl, &err), 0);
    for (int g = 0; g < cl.bands->n_groups; g++)
        cl.bands->group[g].cal.n_strays = 0;
    char path[512], broken[256], cmd[1024];
    snprintf(broken, sizeof broken, "%s/nostray", dir);
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
    fprintf(stderr, "per band, stray light not subtracted: median %.4f %%, mean %+.4f %% "
            "(subtracted: %.4f %%, %+.4f %%)\n", 100 * bad.med, 100 * bad.bias,
            100 * good.med, 100 * good.bias);
    assert_true(bad.bias > good.bias + 0.01);
    assert_true(bad.med > 2 * good.med);
    free(s);
    free(pts);
    cal_loaded_free(&cl);
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

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bands_subtract_their_stray_light),
        cmocka_unit_test(test_bands_without_their_stray_light_are_high),
        cmocka_unit_test(test_recalibrate_reduces_the_bands_alike),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
