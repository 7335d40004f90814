/* A calibration run, journalled frame by frame (capture/calibration.h,
 * cal_run_measure): a run killed anywhere keeps what it read, and the same
 * run started again continues its journal. */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "capture/calibration_private.h"
#include "common/paths.h"
#include "drivers/drivers.h"

size_t cal_run_total(const struct cal_run *run)
{
    size_t per = run->per_point > 0 ? (size_t)run->per_point : 0;
    if (run->meta->kind == CAL_DARK)
        return run->meta->n_integrations * per;
    /* reference and stray: the plan's points, or the run's own */
    if (run->points)
        return run->n_points * per;
    return run->plan ? plan_count(run->plan) * per : 0;
}

static const struct plan_point *run_point(const struct cal_run *run, size_t i)
{
    return run->points ? &run->points[i] : plan_point(run->plan, i);
}

/* What frame idx of the run is: its integration and plan angles. */
static void expected(const struct cal_run *run, size_t idx, double *ti, double *tr,
                     double *integration_s)
{
    size_t i = idx / (size_t)run->per_point;
    if (run->meta->kind == CAL_DARK) {
        *ti = *tr = NAN;
        *integration_s = run->meta->integrations[i];
        return;
    }
    const struct plan_point *pt = run_point(run, i);
    *ti = pt->theta_i, *tr = pt->theta_r;
    /* the direct beam at its own integration (the dark must cover it) */
    *integration_s = run->meta->kind == CAL_BEAM ? run->meta->integrations[0]
                                                 : run->rig->integration_s;
}

static int same(double a, double b, double rel)
{
    return (isnan(a) && isnan(b)) || fabs(a - b) <= rel * fmax(fabs(a), fabs(b)) + 1e-12;
}

/* A journal's frames all belong to this run, in its order. */
static int check_journal(const struct cal_run *run, const char *path, const struct cal_frame *f,
                         size_t n, struct gonio_err *err)
{
    if (n > cal_run_total(run))
        return gonio_err_set(err, GONIO_EBADDATA, "%s: %zu frames, more than the run's %zu: "
                             "not this calibration's journal", path, n, cal_run_total(run));
    for (size_t k = 0; k < n; k++) {
        double ti, tr, t;
        expected(run, k, &ti, &tr, &t);
        /* The bus carries the integration as binary32. */
        if (f[k].kind != run->meta->kind || !same(f[k].theta_i, ti, 1e-9) ||
            !same(f[k].theta_r, tr, 1e-9) || !same(f[k].integration_s, t, 1e-6))
            return gonio_err_set(err, GONIO_EBADDATA, "%s: frame %zu (%s at %g, %g, %g s) is "
                                 "not the run's (%s at %g, %g, %g s): not this calibration's "
                                 "journal", path, k + 1, cal_kind_name(f[k].kind),
                                 f[k].theta_i, f[k].theta_r, f[k].integration_s,
                                 cal_kind_name(run->meta->kind), ti, tr, t);
    }
    return 0;
}

/* Open the journal for appending, its frames so far in f: a torn last line
 * (a kill mid-write) is cut off, a new journal gets its header. */
static int open_journal(const struct cal_run *run, const char *path, struct cal_frames *f,
                        int *fd_out, struct gonio_err *err)
{
    int fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0)
        return gonio_err_set(err, errno, "%s: %s", path, strerror(errno));
    struct stat st;
    off_t keep = 0;
    char *text = NULL;
    int rc = fstat(fd, &st) < 0 ? -errno : 0;
    if (rc == 0 && st.st_size > 0 && !(text = malloc((size_t)st.st_size)))
        rc = -ENOMEM;
    if (rc == 0 && text && pread(fd, text, (size_t)st.st_size, 0) != st.st_size)
        rc = -EIO;
    for (off_t k = rc == 0 && text ? st.st_size : 0; k > 0; k--)
        if (text[k - 1] == '\n') {
            keep = k;
            break;
        }
    if (rc == 0 && keep < (off_t)strlen(CAL_FRAMES_HEADER))
        keep = 0; /* not even the header whole: start again */
    free(text);
    if (rc == 0 && keep != st.st_size && ftruncate(fd, keep) < 0)
        rc = -errno;
    if (rc == 0 && keep == 0) {
        size_t len = strlen(CAL_FRAMES_HEADER);
        rc = write(fd, CAL_FRAMES_HEADER, len) == (ssize_t)len && fdatasync(fd) == 0 ? 0 : -EIO;
        if (rc == 0)
            rc = gonio_fsync_parent(path, err);
    } else if (rc == 0) {
        rc = cal_frames_read(path, &f->v, &f->n, err);
        f->cap = f->n;
        if (rc == 0)
            rc = check_journal(run, path, f->v, f->n, err);
    }
    if (rc < 0) {
        close(fd);
        return err && err->msg[0] ? rc : gonio_err_set(err, -rc, "%s: %s", path,
                                                        gonio_strerror(rc));
    }
    lseek(fd, 0, SEEK_END);
    *fd_out = fd;
    return 0;
}

static int append(int fd, const char *path, const struct cal_frame *fr, struct gonio_err *err)
{
    char line[CAL_FRAME_LINE_MAX];
    int len = cal_frame_line(fr, line, sizeof line);
    if (write(fd, line, (size_t)len) != len || fdatasync(fd) < 0)
        return gonio_err_set(err, errno ? errno : EIO, "%s: %s", path, strerror(errno));
    return 0;
}

/* Before the first frame of a run: the light path as the kind needs it,
 * with the operator's hand where the rig has none. */
static int prepare(struct capture_devices *dev, const struct cal_run *run, const char *dir,
                   const struct cal_hooks *h, int *aborted, struct gonio_err *err)
{
    char say[512];
    int rc = 0;
    if (run->meta->kind == CAL_DARK) {
        rc = run->rig->shutter ? drv_detector_shutter(dev->detector, 1, err) : -ENOTSUP;
        if (rc != -ENOTSUP)
            return rc;
        if (!h->ask)
            return gonio_err_set(err, GONIO_EUSAGE, "dark frames: rig '%s' has no shutter "
                                 "and nobody is asked to cover the detector (run the "
                                 "calibration through goniod)", run->rig->name);
        snprintf(say, sizeof say, "dark frames: rig '%s' has no shutter: cover the detector "
                 "(or turn the lamp off), then: gonio resume", run->rig->name);
    } else {
        if (run->rig->shutter && (rc = drv_detector_shutter(dev->detector, 0, err)) < 0 &&
            rc != -ENOTSUP)
            return rc;
        /* The sample changer swaps the standard or the trap in, nobody is asked;
         * it has no empty slot, so the beam's sample is removed by hand. */
        if (h->mount && run->meta->kind != CAL_BEAM)
            return cal_changer_put(dir, h, dev,
                                   run->meta->kind == CAL_STRAY ? CAPTURE_SLOT_TRAP
                                                                : CAPTURE_SLOT_STANDARD,
                                   run->meta->standard, err);
        if (!h->ask)
            return 0;
        if (run->meta->kind == CAL_STRAY)
            snprintf(say, sizeof say, "stray light: remove the sample (a light trap in its "
                     "place), then: gonio resume");
        else if (run->meta->kind == CAL_BEAM)
            snprintf(say, sizeof say, "beam: remove the sample and put the beam's attenuator "
                     "in front of the detector, then: gonio resume");
        else
            snprintf(say, sizeof say, "reference: mount the standard '%s' in the sample's "
                     "place, then: gonio resume", run->meta->standard);
    }
    *aborted = h->ask(h->user, say) == CAPTURE_ABORT;
    return 0;
}

int cal_run_measure(struct capture_devices *dev, const struct cal_run *run,
                    const struct cal_hooks *h, struct cal_frame **frames, size_t *n,
                    int *aborted, struct gonio_err *err)
{
    char dir[4096], path[4200];
    struct cal_frames f = {0};
    int fd = -1;
    *aborted = 0;
    if (run->per_point < 1)
        return gonio_err_set(err, GONIO_EUSAGE, "calibration: at least one frame a point");
    snprintf(dir, sizeof dir, "%s/%s", run->root, run->meta->id);
    snprintf(path, sizeof path, "%s/journal.csv", dir);
    int rc = gonio_mkdir_p(dir, err);
    if (rc == 0)
        rc = open_journal(run, path, &f, &fd, err);
    size_t total = cal_run_total(run);
    if (rc == 0 && h->on_frame) /* where the run stands: the journal's frames */
        h->on_frame(h->user, f.n, total, f.n ? f.v[f.n - 1].rig_time_s : NAN);
    if (rc == 0 && f.n < total)
        rc = prepare(dev, run, dir, h, aborted, err);
    size_t moved_to = (size_t)-1;
    for (size_t idx = f.n; rc == 0 && !*aborted && idx < total; idx = f.n) {
        if (h->control && h->control(h->user) == CAPTURE_ABORT) {
            *aborted = 1;
            break;
        }
        double ti, tr, t;
        expected(run, idx, &ti, &tr, &t);
        size_t point = idx / (size_t)run->per_point;
        if (run->meta->kind != CAL_DARK && point != moved_to) {
            if ((rc = cal_go_to(dev, run->rig, run_point(run, point), err)) < 0)
                break;
            moved_to = point;
        }
        if ((rc = cal_read_frame(dev, run->meta->kind, ti, tr, t, &f, err)) < 0 ||
            (rc = append(fd, path, &f.v[f.n - 1], err)) < 0)
            break;
        if (h->on_frame)
            h->on_frame(h->user, f.n, total, f.v[f.n - 1].rig_time_s);
    }
    if (run->meta->kind == CAL_DARK && run->rig->shutter && fd >= 0) {
        struct gonio_err ignored;
        drv_detector_shutter(dev->detector, 0, &ignored); /* the light back for what follows */
    }
    if (fd >= 0)
        close(fd);
    /* The sample back in its place, whatever happened (also when the run's
     * directory or journal could not be opened), and when a run killed
     * after its swap is started again (the changer's journal). */
    if (h->mount && cal_changer_journalled(dir) >= 0) {
        struct gonio_err ignored;
        int back = cal_changer_put(dir, h, dev, CAPTURE_SLOT_SAMPLE, NULL,
                                   rc < 0 ? &ignored : err);
        if (rc == 0 && back < 0)
            rc = back;
    }
    /* A driver's wait cut short by the host's abort is the abort. */
    if (rc < 0 && h->control && rc == -ECANCELED)
        *aborted = 1, rc = 0;
    if (rc < 0) {
        free(f.v);
        return rc;
    }
    *frames = f.v, *n = f.n;
    return 0;
}

void cal_discard(const char *root, const char *id)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/%s/journal.csv", root, id);
    unlink(path);
    snprintf(path, sizeof path, "%s/%s/%s", root, id, CAL_CHANGER_JOURNAL);
    unlink(path);
    snprintf(path, sizeof path, "%s/%s", root, id);
    rmdir(path);
}
