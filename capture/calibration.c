/* Measuring a calibration on the rig's devices (capture/calibration.h):
 * dark frames behind the closed shutter, the standard at the plan's points. */
#include "capture/calibration.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "brdf/angles.h"
#include "capture/autorange.h"
#include "capture/calibration_private.h"
#include "drivers/drivers.h"

int cal_frames_push(struct cal_frames *f, const struct cal_frame *fr, struct gonio_err *err)
{
    if (f->n == f->cap) {
        size_t cap = f->cap ? 2 * f->cap : 64;
        struct cal_frame *v = realloc(f->v, cap * sizeof *v);
        if (!v)
            return gonio_err_set(err, ENOMEM, "calibration: out of memory");
        f->v = v, f->cap = cap;
    }
    f->v[f->n++] = *fr;
    return 0;
}

int cal_read_frame(struct capture_devices *dev, enum cal_kind kind, double ti, double tr,
                   double integration_s, struct cal_frames *f, struct gonio_err *err)
{
    struct drv_reading r;
    int rc = drv_detector_acquire(dev->detector, integration_s, &r, err);
    if (rc < 0)
        return rc;
    if (r.unit != DRV_UNIT_COUNTS)
        return gonio_err_set(err, GONIO_EUSAGE, "calibration: the detector reports BRDF, not "
                             "counts: it calibrates itself, there is nothing to calibrate");
    struct cal_frame fr = {.kind = kind, .theta_i = ti, .theta_r = tr,
                           .integration_s = r.integration_s, .gain_state = r.gain_state,
                           .monitor = r.monitor, .full_scale = r.full_scale,
                           .nonlinearity = r.nonlinearity,
                           .rig_time_s = drv_clock_now(dev->clock)};
    memcpy(fr.counts, r.rgb, sizeof fr.counts);
    if (r.n_bands > CAL_MAX_BANDS)
        return gonio_err_set(err, GONIO_EDEVICE, "calibration: the detector gives %d bands, "
                             "at most %d are kept", r.n_bands, CAL_MAX_BANDS);
    fr.n_bands = r.n_bands;
    for (int k = 0; k < r.n_bands; k++)
        fr.bands_nm[k] = r.bands_nm[k], fr.bands[k] = r.bands[k];
    return cal_frames_push(f, &fr, err);
}

int cal_measure_dark(struct capture_devices *dev, const double *integrations, size_t n_int,
                     int frames, struct cal_frame **out, size_t *n_out, struct gonio_err *err)
{
    struct cal_frames f = {0};
    int rc = drv_detector_shutter(dev->detector, 1, err);
    for (size_t i = 0; rc >= 0 && i < n_int; i++)
        for (int k = 0; rc >= 0 && k < frames; k++)
            rc = cal_read_frame(dev, CAL_DARK, NAN, NAN, integrations[i], &f, err);
    struct gonio_err ignored;
    if (rc != -ENOTSUP)
        drv_detector_shutter(dev->detector, 0, rc < 0 ? &ignored : err);
    if (rc < 0) {
        free(f.v);
        return rc;
    }
    *out = f.v, *n_out = f.n;
    return 0;
}

int cal_go_to(struct capture_devices *dev, const struct rig_profile *rig,
              const struct plan_point *pt, struct gonio_err *err)
{
    drv_axis *axes[3] = {dev->sample, dev->arm, dev->azimuth};
    const double to[3] = {pt->ax.s, pt->ax.a, pt->ax.az};
    int n = dev->azimuth && rig->out_of_plane ? 3 : 2, rc;
    for (int i = 0; i < n; i++)
        if ((rc = drv_axis_start_move(axes[i], to[i], err)) < 0)
            return rc;
    for (int i = 0; i < n; i++)
        if ((rc = drv_axis_wait(axes[i], err)) < 0)
            return rc;
    if (rig->settle_s > 0 && (rc = drv_clock_sleep(dev->clock, rig->settle_s)) < 0)
        return gonio_err_set(err, -rc, "settle: %s", gonio_strerror(rc));
    return 0;
}

/* The reference's points for an out-of-plane plan: in the plane, every
 * REF_GRID_STEP deg of theta_i from 0 to the plan's largest and of theta_r
 * from -REF_GRID_STEP (so that a row brackets theta_r = 0 across the blind
 * zone) to its largest theta_o, the instrument factor's theta_r for an
 * out-of-plane point (cal_instrument_theta_r); rows in snake order, the
 * points the rig cannot reach left out. *out malloc'd. */
#define REF_GRID_STEP 5.0
static int oop_reference_points(const struct plan *plan, const struct rig_profile *rig,
                                 struct plan_point **out, size_t *n, struct gonio_err *err)
{
    double ti_max = 0, tr_max = 0;
    for (size_t p = 0; p < plan_count(plan); p++) {
        const struct plan_point *pt = plan_point(plan, p);
        ti_max = fmax(ti_max, pt->theta_i);
        tr_max = fmax(tr_max, cal_instrument_theta_r(pt));
    }
    int rows = (int)ceil(ti_max / REF_GRID_STEP - 1e-9) + 1;
    int cols = (int)ceil(tr_max / REF_GRID_STEP - 1e-9) + 2;
    struct plan_point *v = malloc((size_t)rows * (size_t)cols * sizeof *v);
    if (!v)
        return gonio_err_set(err, ENOMEM, "calibration: out of memory");
    size_t m = 0;
    for (int i = 0; i < rows; i++)
        for (int k = 0; k < cols; k++) {
            int col = i % 2 ? cols - 1 - k : k;
            struct plan_point pt = {.theta_i = i * REF_GRID_STEP,
                                    .theta_r = (col - 1) * REF_GRID_STEP};
            char why[160];
            if (plan_point_place(&pt, rig, why, sizeof why) == 0)
                v[m++] = pt;
        }
    *out = v, *n = m;
    return 0;
}

int cal_measure_reference(struct capture_devices *dev, const struct rig_profile *rig,
                          const struct plan *plan, int repeats, struct cal_frame **out,
                          size_t *n_out, struct gonio_err *err)
{
    struct cal_frames f = {0};
    struct plan_point *grid = NULL;
    size_t n_grid = 0;
    int oop = plan_is_out_of_plane(plan);
    int rc = oop ? oop_reference_points(plan, rig, &grid, &n_grid, err) : 0;
    if (rc >= 0)
        rc = drv_detector_shutter(dev->detector, 0, err);
    if (rc == -ENOTSUP)
        rc = 0; /* no shutter: the light path is open */
    size_t count = oop ? n_grid : plan_count(plan);
    for (size_t p = 0; rc >= 0 && p < count; p++) {
        const struct plan_point *pt = oop ? &grid[p] : plan_point(plan, p);
        if (pt->out_of_plane) {
            rc = gonio_err_set(err, GONIO_EUSAGE, "calibration: the reference is read in "
                               "plane only (point %zu is out of plane)", p + 1);
            break;
        }
        rc = cal_go_to(dev, rig, pt, err);
        /* The plan's angles: the sample's point is matched by them, and
         * where the axes rested inside their band is the angle term. */
        for (int k = 0; rc >= 0 && k < repeats; k++)
            rc = cal_read_frame(dev, CAL_REFERENCE, pt->theta_i, pt->theta_r, rig->integration_s,
                            &f, err);
    }
    free(grid);
    if (rc < 0) {
        free(f.v);
        return rc;
    }
    *out = f.v, *n_out = f.n;
    return 0;
}

void cal_new_id(const char *root, enum cal_kind kind, time_t now, char *id, size_t size)
{
    struct tm tm;
    gmtime_r(&now, &tm);
    char stamp[32];
    strftime(stamp, sizeof stamp, "%Y%m%dT%H%M%SZ", &tm);
    const char *what = kind == CAL_DARK ? "dark" : "reference";
    snprintf(id, size, "%s-%s", what, stamp);
    for (int k = 2; k < 1000; k++) {
        char path[4096];
        struct stat st;
        snprintf(path, sizeof path, "%s/%s", root, id);
        if (stat(path, &st) != 0)
            return;
        snprintf(id, size, "%s-%s-%d", what, stamp, k);
    }
}

void cal_add_ladder(struct cal_meta *m, const struct rig_profile *rig)
{
    struct autorange ar;
    autorange_init(&ar, rig);
    double ladder[AUTORANGE_RUNGS];
    size_t n = autorange_ladder(&ar, ladder, AUTORANGE_RUNGS);
    for (size_t k = 0; k < n && m->n_integrations < CAL_MAX_INTEGRATIONS; k++) {
        size_t i = 0;
        while (i < m->n_integrations && fabs(m->integrations[i] - ladder[k]) > 1e-9 * ladder[k])
            i++;
        if (i == m->n_integrations)
            m->integrations[m->n_integrations++] = ladder[k];
    }
}
