/* The reference standard read again after a capture's points
 * (capture/reference_after.h). */
#include "capture/reference_after.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "brdf/angles.h"
#include "capture/calibration_bands.h"
#include "capture/calibration_private.h"
#include "common/paths.h"

/* The geometries read again: up to REFERENCE_AFTER_GEOMETRIES of the
 * calibration's at its first integration, spread evenly over them in the
 * order it read them. *integration_s: theirs. */
static size_t after_points(const struct cal_loaded *cl, struct plan_point *out,
                           double *integration_s)
{
    const struct rad_ref *refs = cl->cal.refs;
    size_t n = 0, idx[256];
    *integration_s = cl->cal.n_refs ? refs[0].integration_s : 0;
    for (size_t k = 0; k < cl->cal.n_refs && n < sizeof idx / sizeof *idx; k++)
        if (refs[k].integration_s == *integration_s && refs[k].gain_state == refs[0].gain_state)
            idx[n++] = k;
    size_t m = n < REFERENCE_AFTER_GEOMETRIES ? n : REFERENCE_AFTER_GEOMETRIES;
    for (size_t j = 0; j < m; j++) {
        const struct rad_ref *r = &refs[idx[m > 1 ? j * (n - 1) / (m - 1) : 0]];
        struct plan_point pt = {.theta_i = r->theta_i, .theta_r = r->theta_r};
        brdf_inplane_to_axes(pt.theta_i, pt.theta_r, &pt.ax.s, &pt.ax.a);
        out[j] = pt;
    }
    return m;
}

/* The run that reads them, as a calibration run of the capture directory. */
struct after_run {
    struct plan_point pts[REFERENCE_AFTER_GEOMETRIES];
    struct cal_meta meta;
    struct rig_profile rig;
    struct cal_run run;
};

static void after_run(struct after_run *a, const struct rig_profile *rig, const char *dir,
                      const struct cal_loaded *cl)
{
    memset(a, 0, sizeof *a);
    a->rig = *rig;
    size_t n = after_points(cl, a->pts, &a->rig.integration_s);
    snprintf(a->meta.id, sizeof a->meta.id, "%s", REFERENCE_AFTER_ID);
    a->meta.kind = CAL_REFERENCE;
    snprintf(a->meta.standard, sizeof a->meta.standard, "%s", cl->meta.standard);
    a->run = (struct cal_run){.root = dir, .meta = &a->meta, .rig = &a->rig, .points = a->pts,
                              .n_points = n, .per_point = REFERENCE_AFTER_REPEATS};
}

int reference_after_read(const char *dir, const struct cal_loaded *cl, struct cal_frame **frames,
                         size_t *n, struct gonio_err *err)
{
    struct after_run a;
    after_run(&a, &(struct rig_profile){0}, dir, cl);
    char path[4200];
    snprintf(path, sizeof path, "%s/%s/journal.csv", dir, REFERENCE_AFTER_ID);
    struct cal_frame *f = NULL;
    size_t m = 0;
    struct stat st;
    if (stat(path, &st) == 0) {
        /* Without frames wanted, a journal a kill tore is only not whole
         * yet: the run continues it (cal_run_measure). */
        struct gonio_err ignored;
        int rc = cal_frames_read(path, &f, &m, frames ? err : &ignored);
        if (rc < 0 && frames)
            return rc;
        if (rc < 0)
            f = NULL, m = 0;
    }
    int whole = a.run.n_points > 0 && m >= cal_run_total(&a.run);
    if (frames)
        *frames = f, *n = m;
    else
        free(f);
    return whole;
}

int reference_after_measure(struct capture_devices *dev, const struct capture_rig *src,
                            const struct capture_hooks *hooks, const struct rig_profile *rig,
                            const char *dir, const struct cal_loaded *cl,
                            struct cal_frame **frames, size_t *n, int *aborted,
                            struct gonio_err *err)
{
    struct after_run a;
    after_run(&a, rig, dir, cl);
    *aborted = 0;
    if (!a.run.n_points)
        return gonio_err_set(err, GONIO_EBADCONFIG, "reference after the capture: calibration "
                             "%s has no reference geometry to read again", cl->meta.id);
    int rc = reference_after_read(dir, cl, NULL, NULL, err);
    if (rc < 0)
        return rc;
    /* the sample changer swaps them (and journals it), nobody is asked */
    struct cal_hooks h = {.control = hooks->control, .ask = hooks->ask, .user = hooks->user,
                          .mount = src->mount, .mount_user = src->user};
    return cal_run_measure(dev, &a.run, &h, frames, n, aborted, err);
}

/* One reading reduced as a sample at its geometry with cl (no drift):
 * its value over the standard's BRDF there, and that ratio's relative
 * variance from the terms that differ from reading to reading (counting,
 * dark, the monitor, the angle) and from the calibration's own reading
 * there (reference_noise), kept apart: the latter is shared by the
 * readings at one geometry. */
static int reading_ratio(const struct cal_loaded *cl, const struct cal_frame *fr,
                         double ratio[3], double var_each[3], double var_shared[3],
                         struct gonio_err *err)
{
    struct plan_point pt = {.theta_i = fr->theta_i, .theta_r = fr->theta_r};
    struct journal_plan one = {.points = &pt, .count = 1};
    struct journal_sample s;
    journal_sample_clear(&s);
    s.point = 0;
    s.counts = 1;
    memcpy(s.raw, fr->counts, sizeof s.raw);
    s.integration_s = fr->integration_s;
    s.gain_state = fr->gain_state;
    s.monitor = fr->monitor;
    struct rad_value v;
    int rc = cal_reduce_sample(cl, &one, NULL, 0, &s, &v, err);
    if (rc < 0)
        return rc;
    double f[3];
    brdf_standard_brdf(&cl->cal.standard, fr->theta_i, fr->theta_r, f);
    for (int c = 0; c < 3; c++) {
        ratio[c] = v.brdf[c] / f[c];
        var_each[c] = 0;
        static const enum rad_term each[] = {RAD_U_COUNTING, RAD_U_DARK, RAD_U_DRIFT,
                                             RAD_U_ANGLE};
        for (size_t t = 0; t < sizeof each / sizeof *each; t++)
            var_each[c] += v.rel[each[t]][c] * v.rel[each[t]][c];
        var_shared[c] = v.rel[RAD_U_REF_NOISE][c] * v.rel[RAD_U_REF_NOISE][c];
    }
    return 0;
}

int reference_after_derive(struct cal_loaded *cl, const struct cal_frame *f, size_t n,
                           double t_end_s, struct gonio_err *err)
{
    cl->drift = (struct cal_drift){0}; /* the readings reduced as the calibration has them */
    double sum[3] = {0}, var[3] = {0};
    size_t groups = 0;
    for (size_t k = 0; k < n;) {
        size_t e = k, used = 0;
        double g_sum[3] = {0}, g_each[3] = {0}, g_shared[3] = {0};
        while (e < n && f[e].theta_i == f[k].theta_i && f[e].theta_r == f[k].theta_r)
            e++;
        for (size_t j = k; j < e; j++) {
            double q[3], ve[3], vs[3];
            int rc = reading_ratio(cl, &f[j], q, ve, vs, err);
            if (rc < 0)
                return rc;
            if (!isfinite(q[0]) || !isfinite(q[1]) || !isfinite(q[2]))
                continue; /* clipped: no value */
            for (int c = 0; c < 3; c++)
                g_sum[c] += q[c], g_each[c] += ve[c], g_shared[c] = vs[c];
            used++;
        }
        k = e;
        if (!used)
            continue;
        for (int c = 0; c < 3; c++) {
            sum[c] += g_sum[c] / (double)used;
            var[c] += g_each[c] / ((double)used * (double)used) + g_shared[c];
        }
        groups++;
    }
    if (!groups)
        return gonio_err_set(err, GONIO_EBADDATA, "reference after the capture: no reading of "
                             "the standard with a value (%zu readings)", n);
    struct cal_drift *d = &cl->drift;
    for (int c = 0; c < 3; c++) {
        d->q[c] = sum[c] / (double)groups;
        d->u_q[c] = sqrt(var[c]) / (double)groups;
    }
    d->t_end_s = t_end_s;
    d->geometries = groups;
    d->frames = n;
    d->on = 1;
    /* A spectral detector's bands, each its own ratio (the lamp's drift
     * is not flat over the spectrum). */
    return cl->bands && f[0].n_bands > 0 ? cal_bands_drift(cl->bands, f, n, t_end_s, err) : 0;
}

/* The journal at path reduced again with cl into path's new version, and
 * renamed over it. */
static int rewrite(const struct cal_loaded *cl, const struct journal_plan *jp, const char *path,
                   struct gonio_err *err)
{
    struct journal_sample *all = NULL, *none = NULL;
    size_t m = 0, n0 = 0;
    int rc = journal_read(path, &all, &m, err);
    char tmp[4200];
    snprintf(tmp, sizeof tmp, "%s.drift", path);
    unlink(tmp); /* a rewrite a kill cut short */
    journal *j = rc == 0 ? journal_open(tmp, &none, &n0, err) : NULL;
    free(none);
    if (rc == 0 && !j)
        rc = -abs(err && err->code ? err->code : EIO);
    if (j)
        journal_set_lazy(j);
    for (size_t k = 0; rc == 0 && k < m; k++) {
        struct rad_value v;
        rc = cal_reduce_sample(cl, jp, all, k, &all[k], &v, err);
        if (rc == 0)
            rc = journal_append(j, &all[k], err);
    }
    if (j)
        journal_close(j);
    if (rc == 0 && rename(tmp, path) < 0)
        rc = gonio_err_set(err, errno, "%s: %s", path, strerror(errno));
    if (rc == 0)
        rc = gonio_fsync_parent(path, err);
    if (rc < 0)
        unlink(tmp);
    free(all);
    return rc;
}

int reference_after_apply(const struct cal_loaded *cl, const struct journal_plan *jp,
                          const char *path, struct journal_sample *samples, size_t n,
                          struct gonio_err *err)
{
    for (size_t k = 0; k < n; k++) {
        struct rad_value v;
        int rc = cal_reduce_sample(cl, jp, samples, k, &samples[k], &v, err);
        if (rc < 0)
            return rc;
    }
    return rewrite(cl, jp, path, err);
}
