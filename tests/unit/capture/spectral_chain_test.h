/* What the spectral chain tests share: a test directory with the default
 * rig integrating 0.25 s, offline calibrations and a DS3 capture of a
 * rough diffuse material made through `gonio`, the capture's spectra.csv
 * assessed against the material's truth, its bands reduced again with an
 * edited calibration, and `gonio recalibrate` reducing them alike. Include
 * after tests/gonio_test.h. */
#ifndef GONIO_TESTS_SPECTRAL_CHAIN_TEST_H
#define GONIO_TESTS_SPECTRAL_CHAIN_TEST_H

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "brdf/material.h"
#include "brdf/spectral.h"
#include "capture/calibration.h"
#include "capture/capture_bands.h"
#include "capture/journal_plan.h"
#include "journal/journal.h"

#define SPECTRAL_PLAN "ds3"
#define SPECTRAL_MATERIAL "analytic:rough-diffuse"

/* A test's folders: dir holds rig.yaml, the calibrations cal and the
 * capture cap; id is the newest calibration's. */
struct spectral_chain {
    char dir[64], cal[128], cap[128], id[128], rig[128];
};

/* The shipped config name of kind into dst, each line through edit (which
 * may append to text ahead of the line). */
static inline int spectral_chain_rewrite(const char *name, const char *kind, const char *dst,
                                         void (*edit)(char *line, size_t size, char *text,
                                                      size_t text_size))
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

/* The rig integrating 0.25 s (auto-ranging starts there), so that the
 * sample reads with a signal-to-noise ratio above 100 in most bands and
 * the standard below the clip. */
static inline void spectral_chain_rig_edit(char *line, size_t size, char *text,
                                           size_t text_size)
{
    (void)text, (void)text_size;
    const char *at = strstr(line, "fixed_s:");
    if (at)
        snprintf(line + (at - line), size - (size_t)(at - line), "fixed_s: 0.25\n");
}

/* sc's directory, tagged tag, with its rig.yaml. */
static inline int spectral_chain_dir(struct spectral_chain *sc, const char *tag)
{
    if (gonio_test_dir_make(sc->dir, sizeof sc->dir, tag) < 0)
        return -1;
    snprintf(sc->rig, sizeof sc->rig, "%s/rig.yaml", sc->dir);
    snprintf(sc->cal, sizeof sc->cal, "%s/cal", sc->dir);
    snprintf(sc->cap, sizeof sc->cap, "%s/cap", sc->dir);
    return spectral_chain_rewrite("default", "rigs", sc->rig, spectral_chain_rig_edit);
}

/* `gonio calibrate <what[k]>` offline on scene (a shipped name or a file)
 * for each of the n steps, sc->id the last one's, then the capture. */
static inline int spectral_chain_run(struct spectral_chain *sc, const char *scene,
                                     const char *const *what, int n)
{
    const char *bin = getenv("GONIO_BIN");
    char cmd[1024];
    for (int k = 0; k < n; k++) {
        snprintf(cmd, sizeof cmd, "'%s/gonio' calibrate %s --offline --scene '%s' --rig '%s' "
                 "--out '%s'", bin ? bin : "build/bin", what[k], scene, sc->rig, sc->cal);
        FILE *p = popen(cmd, "r");
        if (!p || !fgets(sc->id, sizeof sc->id, p) || pclose(p) != 0)
            return -1;
        sc->id[strcspn(sc->id, "\n")] = '\0';
    }
    snprintf(cmd, sizeof cmd, "'%s/gonio' capture --offline --scene '%s' --material "
             SPECTRAL_MATERIAL " --rig '%s' --plan " SPECTRAL_PLAN " --calibrations '%s' "
             "--out '%s' >/dev/null", bin ? bin : "build/bin", scene, sc->rig, sc->cal, sc->cap);
    return system(cmd) == 0 ? 0 : -1;
}

static inline int spectral_chain_cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* A spectra.csv against the truth over its values with SNR >= 100 (u at
 * most 1 %: the counting noise and more). */
struct spectral_result {
    size_t rows, used, bands;
    double med;           /* median |measured/true - 1| */
    double bias;          /* mean measured/true - 1 */
    double band_bias_rms; /* over bands, of each band's mean measured/true - 1 */
};

/* folder's spectra.csv against the material lifted to spectra, as the
 * simulated detector sees it. */
static inline void spectral_chain_assess(const char *folder, struct spectral_result *r)
{
    struct gonio_err err = {0};
    brdf_material *m = brdf_material_open(SPECTRAL_MATERIAL, &err);
    assert_non_null(m);
    brdf_spectral *sp = brdf_spectral_lift(m, &err);
    assert_non_null(sp);
    char line[512];
    snprintf(line, sizeof line, "%s/spectra.csv", folder);
    FILE *f = fopen(line, "r");
    assert_non_null(f);
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
    qsort(err_rel, r->used, sizeof *err_rel, spectral_chain_cmp_double);
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

/* The capture's records (bands.csv, samples.csv, plan.json) reduced again
 * with cl into the folder sub of sc->dir, whose path goes to out. */
static inline void spectral_chain_reduce(const struct spectral_chain *sc,
                                         const struct cal_loaded *cl, const char *sub,
                                         char *out, size_t size)
{
    struct gonio_err err = {0};
    char path[512], cmd[1024];
    snprintf(out, size, "%s/%s", sc->dir, sub);
    mkdir(out, 0755);
    snprintf(cmd, sizeof cmd, "cp '%s/bands.csv' '%s/'", sc->cap, out);
    assert_int_equal(system(cmd), 0);
    struct journal_sample *s = NULL;
    struct plan_point *pts = NULL;
    size_t n = 0, np = 0;
    snprintf(path, sizeof path, "%s/samples.csv", sc->cap);
    assert_int_equal(journal_read(path, &s, &n, &err), 0);
    snprintf(path, sizeof path, "%s/plan.json", sc->cap);
    assert_int_equal(journal_plan_read(path, &pts, &np, &err), 0);
    struct journal_plan jp = {.points = pts, .count = np};
    assert_int_equal(capture_bands_reduce(cl, &jp, s, n, out, &err), 0);
    free(s);
    free(pts);
}

/* gonio recalibrate with the capture's own calibration reduces its bands
 * to the same spectra.csv, byte for byte. */
static inline void spectral_chain_assert_recalibrates_alike(const struct spectral_chain *sc)
{
    const char *bin = getenv("GONIO_BIN");
    char cmd[1024];
    snprintf(cmd, sizeof cmd, "'%s/gonio' recalibrate '%s' --calibration '%s' --calibrations "
             "'%s' -o '%s/recal' >/dev/null", bin ? bin : "build/bin", sc->cap, sc->id, sc->cal,
             sc->dir);
    assert_int_equal(system(cmd), 0);
    snprintf(cmd, sizeof cmd, "cmp -s '%s/spectra.csv' '%s/recal/spectra.csv'", sc->cap,
             sc->dir);
    assert_int_equal(system(cmd), 0);
}

#endif
