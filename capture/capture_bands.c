/* A spectral detector's bands in a capture (capture/capture_bands.h). */
#include "capture/capture_bands.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "capture/calibration_bands.h"
#include "common/paths.h"

#define BANDS_HEADER "point,rig_time_s,bands\n"
#define LINE_MAX_LEN (128 + 56 * CAL_MAX_BANDS)

void capture_bands_take(struct capture_bands_reading *b, const struct drv_reading *r)
{
    b->n = r->unit == DRV_UNIT_COUNTS && r->bands && r->n_bands <= CAL_MAX_BANDS ? r->n_bands
                                                                                  : 0;
    for (int k = 0; k < b->n; k++)
        b->nm[k] = r->bands_nm[k], b->counts[k] = r->bands[k];
}

static int path_of(const char *dir, const char *name, char *path, size_t size,
                   struct gonio_err *err)
{
    if (snprintf(path, size, "%s/%s", dir, name) >= (int)size)
        return gonio_err_set(err, ENAMETOOLONG, "%s: path too long", dir);
    return 0;
}

int capture_bands_append(const char *dir, const struct journal_sample *s,
                         const struct capture_bands_reading *b, struct gonio_err *err)
{
    if (b->n == 0 || !s->counts)
        return 0;
    char path[4096];
    int rc = path_of(dir, "bands.csv", path, sizeof path, err);
    if (rc < 0)
        return rc;
    FILE *f = fopen(path, "a");
    if (!f)
        return gonio_err_set(err, errno, "%s: %s", path, strerror(errno));
    if (ftell(f) == 0)
        fputs(BANDS_HEADER, f);
    fprintf(f, "%d,%.17g,", s->point, s->rig_time_s);
    for (int k = 0; k < b->n; k++)
        fprintf(f, "%s%.10g:%.17g", k ? " " : "", b->nm[k], b->counts[k]);
    fputc('\n', f);
    /* durable with its journal record, before the next point */
    int bad = fflush(f) != 0 || fdatasync(fileno(f)) != 0;
    if (fclose(f) != 0 || bad)
        return gonio_err_set(err, EIO, "%s: write failed", path);
    return 0;
}

/* One bands.csv row; 0 on success. */
static int parse_row(const char *line, int *point, double *t, struct cal_band_record *r)
{
    char *end;
    *point = (int)strtol(line, &end, 10);
    if (*end != ',')
        return -1;
    *t = strtod(end + 1, &end);
    if (*end != ',')
        return -1;
    const char *p = end + 1;
    r->n_bands = 0;
    while (*p && *p != '\n') {
        if (r->n_bands == CAL_MAX_BANDS)
            return -1;
        r->nm[r->n_bands] = strtod(p, &end);
        if (end == p || *end != ':')
            return -1;
        p = end + 1;
        r->counts[r->n_bands++] = strtod(p, &end);
        if (end == p || (*end != ' ' && *end != '\n' && *end))
            return -1;
        p = *end == ' ' ? end + 1 : end;
    }
    return r->n_bands > 0 ? 0 : -1;
}

/* Each counts record's bands from bands.csv, into rec (the last row of a
 * record's point and rig time: a point measured again after a crash has
 * its earlier row too). */
static int read_bands(FILE *f, const char *path, const struct journal_sample *samples, size_t n,
                      struct cal_band_record *rec, size_t *m, struct gonio_err *err)
{
    char line[LINE_MAX_LEN];
    struct cal_band_record row;
    int lineno = 1;
    if (!fgets(line, sizeof line, f) || strcmp(line, BANDS_HEADER) != 0)
        return gonio_err_set(err, GONIO_EBADDATA, "%s:1: not a bands file", path);
    *m = 0;
    for (size_t i = 0; i < n; i++)
        if (samples[i].counts && !(samples[i].flags & JOURNAL_FLAG_DARK)) {
            rec[*m].s = samples[i];
            rec[(*m)++].n_bands = -1;
        }
    while (fgets(line, sizeof line, f)) {
        int point;
        double t;
        lineno++;
        if (parse_row(line, &point, &t, &row) < 0)
            return gonio_err_set(err, GONIO_EBADDATA, "%s:%d: not a bands record", path,
                                 lineno);
        for (size_t i = 0; i < *m; i++)
            if (rec[i].s.point == point && rec[i].s.rig_time_s == t) {
                row.s = rec[i].s;
                rec[i] = row;
            }
    }
    for (size_t i = 0; i < *m; i++)
        if (rec[i].n_bands < 0)
            return gonio_err_set(err, GONIO_EBADDATA, "%s: no bands for the record of point "
                                 "%d at rig time %.17g s", path, rec[i].s.point,
                                 rec[i].s.rig_time_s);
    return 0;
}

static int write_spectra(const char *dir, const struct cal_band_record *rec, size_t m, int nb,
                         const struct cal_band_value *val, struct gonio_err *err)
{
    char path[4096];
    int rc = path_of(dir, "spectra.csv", path, sizeof path, err);
    size_t cap = 128 + m * (size_t)nb * 160, len = 0;
    char *buf = rc < 0 ? NULL : malloc(cap);
    if (rc < 0 || !buf)
        return rc < 0 ? rc : gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    len += (size_t)snprintf(buf, cap, "theta_i,theta_r,wavelength_nm,value,acquisition,"
                                      "integration_s,saturated,u,snr\n");
    for (size_t i = 0; i < m; i++)
        for (int k = 0; k < nb; k++) {
            const struct cal_band_value *v = &val[i * (size_t)nb + k];
            if (!isfinite(v->brdf)) /* clipped: no value, the journal keeps its counts */
                continue;
            len += (size_t)snprintf(buf + len, cap - len, "%.17g,%.17g,%g,%.17g,%zu,%.17g,0,"
                                    "%.17g,%.4g\n", rec[i].s.theta_i, rec[i].s.theta_r,
                                    rec[i].nm[k], v->brdf, i + 1, rec[i].s.integration_s,
                                    v->u, v->snr);
        }
    rc = gonio_write_file_atomic(path, buf, len, err);
    free(buf);
    return rc;
}

int capture_bands_reduce(const struct cal_loaded *cl, const struct journal_plan *plan,
                         const struct journal_sample *samples, size_t n, const char *dir,
                         struct gonio_err *err)
{
    char path[4096];
    int rc = path_of(dir, "bands.csv", path, sizeof path, err);
    FILE *f = rc < 0 ? NULL : fopen(path, "r");
    if (!f)
        return rc < 0 ? rc : errno == ENOENT ? 0 : gonio_err_set(err, errno, "%s: %s", path,
                                                                  strerror(errno));
    if (!cl->bands) {
        fclose(f);
        return gonio_err_set(err, GONIO_EBADCONFIG, "%s: the detector gave bands and "
                             "calibration %s holds none: calibrate it again", path,
                             cl->meta.id);
    }
    int nb = cl->bands->n_bands;
    struct cal_band_record *rec = malloc((n ? n : 1) * sizeof *rec);
    struct cal_band_value *val = malloc((n ? n : 1) * (size_t)nb * sizeof *val);
    size_t m = 0;
    rc = rec && val ? 0 : gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    if (rc == 0)
        rc = read_bands(f, path, samples, n, rec, &m, err);
    fclose(f);
    if (rc == 0)
        rc = cal_bands_reduce(cl->bands, plan, rec, m, val, err);
    if (rc == 0)
        rc = write_spectra(dir, rec, m, nb, val, err);
    free(rec);
    free(val);
    return rc;
}
