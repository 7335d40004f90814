/* gonio recalibrate: a capture's journalled raw counts reduced again with
 * another calibration and refitted, into a new directory; the original
 * record is never written (capture/capture.h, docs/radiometry.md). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <jansson.h>

#include "capture/calibration.h"
#include "capture/capture_bands.h"
#include "capture/capture_files.h"
#include "capture/final_fit.h"
#include "capture/journal_plan.h"
#include "capture/reference_after.h"
#include "common/paths.h"

/* The capture's own description: setup.json's rig name, detector and
 * material, results.json's model. */
struct recal_setup {
    json_t *setup;
    char rig[64], detector[32], material[512], model[32], plan[128];
};

static int read_setup(const char *dir, struct recal_setup *su, struct gonio_err *err)
{
    char path[4200];
    json_error_t je;
    snprintf(path, sizeof path, "%s/setup.json", dir);
    if (!(su->setup = json_load_file(path, 0, &je)))
        return gonio_err_set(err, GONIO_ENOTFOUND, "%s: %s", path, je.text);
    const char *rig = json_string_value(json_object_get(json_object_get(su->setup, "rig"), "name"));
    const char *det = json_string_value(json_object_get(su->setup, "detector"));
    const char *mat = json_string_value(json_object_get(su->setup, "material"));
    if (!rig || !det)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: no %s", path, rig ? "'detector'" : "'rig.name'");
    snprintf(su->rig, sizeof su->rig, "%s", rig);
    snprintf(su->detector, sizeof su->detector, "%s", det);
    snprintf(su->material, sizeof su->material, "%s", mat ? mat : "");
    snprintf(path, sizeof path, "%s/results.json", dir);
    json_t *res = json_load_file(path, 0, &je);
    const char *model = json_string_value(json_object_get(res, "model"));
    snprintf(su->model, sizeof su->model, "%s", model ? model : "abc");
    const char *plan = json_string_value(json_object_get(res, "plan"));
    snprintf(su->plan, sizeof su->plan, "%s", plan ? plan : "");
    json_decref(res);
    return 0;
}

/* A calibration for this capture's rig and detector, or a refusal naming
 * what differs. Its validity is not checked: a recalibration applies the
 * calibration the operator names, whenever it was taken. */
static int check_match(const char *dir, const struct recal_setup *su, const struct cal_loaded *cl,
                       struct gonio_err *err)
{
    if (strcmp(su->rig, cl->meta.rig))
        return gonio_err_set(err, GONIO_EBADCONFIG,
                             "calibration %s is for rig '%s', the capture %s was taken on rig '%s'",
                             cl->meta.id, cl->meta.rig, dir, su->rig);
    if (strcmp(su->detector, cl->meta.detector))
        return gonio_err_set(err, GONIO_EBADCONFIG,
                             "calibration %s is for detector '%s', the capture %s was taken with "
                             "detector '%s'",
                             cl->meta.id, cl->meta.detector, dir, su->detector);
    return 0;
}

static int copy_text(const char *from, const char *to, struct gonio_err *err)
{
    FILE *f = fopen(from, "rb");
    if (!f)
        return gonio_err_set(err, errno, "%s: %s", from, strerror(errno));
    char *buf = NULL;
    size_t len = 0, cap = 0, got;
    char chunk[8192];
    while ((got = fread(chunk, 1, sizeof chunk, f)) > 0) {
        if (len + got > cap) {
            char *b = realloc(buf, cap = 2 * (len + got));
            if (!b) {
                free(buf);
                fclose(f);
                return gonio_err_set(err, ENOMEM, "out of memory");
            }
            buf = b;
        }
        memcpy(buf + len, chunk, got);
        len += got;
    }
    fclose(f);
    int rc = gonio_write_file_atomic(to, buf ? buf : "", len, err);
    free(buf);
    return rc;
}

/* OUT: plan.json as it was, setup.json naming the new calibration and
 * what it recalibrates. Refused when OUT already holds a capture. */
static int prepare_out(const char *dir, const char *out, struct recal_setup *su,
                       const char *id, struct gonio_err *err)
{
    char from[4200], to[4200];
    snprintf(to, sizeof to, "%s/samples.csv", out);
    struct stat st;
    if (stat(to, &st) == 0)
        return gonio_err_set(err, GONIO_EUSAGE, "%s: already holds a capture; name a new -o OUT",
                             out);
    int rc = gonio_mkdir_p(out, err);
    snprintf(from, sizeof from, "%s/plan.json", dir);
    snprintf(to, sizeof to, "%s/plan.json", out);
    if (rc == 0)
        rc = copy_text(from, to, err);
    /* a spectral detector's bands: the record its spectra.csv is reduced from */
    snprintf(from, sizeof from, "%s/bands.csv", dir);
    snprintf(to, sizeof to, "%s/bands.csv", out);
    if (rc == 0 && stat(from, &st) == 0)
        rc = copy_text(from, to, err);
    json_object_set_new(su->setup, "calibration", json_string(id));
    json_object_set_new(su->setup, "recalibrated_from", json_string(dir));
    char *text = json_dumps(su->setup, JSON_INDENT(2) | JSON_REAL_PRECISION(17));
    snprintf(to, sizeof to, "%s/setup.json", out);
    if (rc == 0)
        rc = text ? gonio_write_file_atomic(to, text, strlen(text), err)
                  : gonio_err_set(err, ENOMEM, "out of memory");
    free(text);
    return rc;
}

/* Every record reduced again, in journal order, each with the records
 * before it, as the capture reduced it; then journalled to OUT. */
static int reduce_all(const struct cal_loaded *cl, const struct journal_plan *jp,
                      struct journal_sample *s, size_t n, const char *out,
                      struct gonio_err *err)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/samples.csv", out);
    struct journal_sample *none = NULL;
    size_t n0 = 0;
    journal *j = journal_open(path, &none, &n0, err);
    free(none);
    if (!j)
        return -abs(err ? err->code : EIO);
    journal_set_lazy(j);
    int rc = 0;
    for (size_t k = 0; k < n && rc == 0; k++) {
        struct rad_value v;
        rc = cal_reduce_sample(cl, jp, s, k, &s[k], &v, err);
        if (rc == 0)
            rc = journal_append(j, &s[k], err);
    }
    journal_close(j);
    return rc;
}

static int refit(const struct recal_setup *su, const struct cal_loaded *cl,
                 const struct journal_plan *jp, const struct journal_sample *s, size_t n,
                 const char *out, struct gonio_err *err)
{
    const struct fit_model_kind *kind = fit_model_find_rgb(su->model, "model", err);
    if (!kind)
        return -GONIO_EUSAGE;
    struct capture_summary sum;
    memset(&sum, 0, sizeof sum);
    snprintf(sum.model, sizeof sum.model, "%s", su->model);
    snprintf(sum.plan, sizeof sum.plan, "%s", su->plan);
    snprintf(sum.material, sizeof sum.material, "%s", su->material);
    snprintf(sum.stop_reason, sizeof sum.stop_reason, "complete");
    sum.samples = n;
    sum.rig_time_s = n ? s[n - 1].rig_time_s : 0;
    brdf_material *fitted = NULL;
    double usys[3];
    rad_systematic_rel_u(&cl->cal, usys);
    int rc = capture_fit_samples(s, n, NULL, kind, out, su->material[0] ? su->material : NULL,
                                 0, usys, &sum, &fitted, err);
    brdf_material_free(fitted);
    if (rc == 0)
        rc = capture_files_results(out, &sum, err);
    if (rc == 0)
        rc = cal_results_budget(cl, jp, s, n, out, err);
    return rc;
}

/* The records, refused without raw counts, checked against plan.json. */
static int read_records(const char *dir, const struct journal_plan *jp, double band,
                        struct journal_sample **s, size_t *n, struct gonio_err *err)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/samples.csv", dir);
    int rc = journal_read(path, s, n, err);
    if (rc < 0)
        return rc;
    size_t counts = 0;
    for (size_t k = 0; k < *n; k++)
        counts += (*s)[k].counts != 0;
    if (!counts)
        return gonio_err_set(err, GONIO_EBADCONFIG,
                             "%s: no record holds raw counts (its detector reported BRDF); "
                             "there is nothing to recalibrate",
                             path);
    return journal_plan_check(path, *s, *n, jp, band, err);
}

/* The drift the capture's standard read again after its points shows,
 * against this calibration, as the capture derived it (placed at its last
 * sample's rig time); none when it read none. */
static int drift_of(const char *dir, struct cal_loaded *cl, const struct journal_sample *s,
                    size_t n, struct gonio_err *err)
{
    struct cal_frame *f = NULL;
    size_t nf = 0;
    double t_end = 0;
    for (size_t k = 0; k < n; k++)
        if (!(s[k].flags & JOURNAL_FLAG_DARK))
            t_end = s[k].rig_time_s;
    int rc = reference_after_read(dir, cl, &f, &nf, err);
    if (rc > 0)
        rc = reference_after_derive(cl, f, nf, t_end, err);
    free(f);
    return rc < 0 ? rc : 0;
}

int capture_recalibrate(const char *dir, const char *root, const char *id, const char *out,
                        struct gonio_err *err)
{
    struct recal_setup su = {0};
    struct cal_loaded cl = {0};
    struct plan_point *pts = NULL;
    struct journal_sample *s = NULL;
    size_t n = 0, count = 0;
    char path[4200];
    snprintf(path, sizeof path, "%s/plan.json", dir);
    int rc = read_setup(dir, &su, err);
    if (rc == 0)
        rc = journal_plan_read(path, &pts, &count, err);
    struct journal_plan jp = {.points = pts, .count = count};
    double band = json_real_value(
        json_object_get(json_object_get(su.setup, "rig"), "in_position_deg"));
    if (rc == 0)
        rc = read_records(dir, &jp, band > 0 ? band : 1e9, &s, &n, err);
    int loaded = rc == 0 && (rc = cal_load(root, id, &cl, err)) == 0;
    if (rc == 0)
        rc = check_match(dir, &su, &cl, err);
    if (rc == 0)
        rc = drift_of(dir, &cl, s, n, err);
    if (rc == 0)
        rc = prepare_out(dir, out, &su, id, err);
    if (rc == 0)
        rc = reduce_all(&cl, &jp, s, n, out, err);
    if (rc == 0)
        rc = capture_bands_reduce(&cl, &jp, s, n, out, err);
    if (rc == 0)
        rc = refit(&su, &cl, &jp, s, n, out, err);
    if (loaded)
        cal_loaded_free(&cl);
    json_decref(su.setup);
    free(pts);
    free(s);
    return rc;
}
