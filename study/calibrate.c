/* A study job on a scene whose detector gives counts (lab, bad-day) is
 * calibrated before it captures, as an operator calibrates before a
 * capture (docs/radiometry.md, "The chain"): a dark, then the shipped
 * reference standard mounted as the sample and read at the job's plan
 * points, on the job's own simulated rig, into JOBDIR/calibrations. The
 * capture then reduces its counts with that calibration, so a realistic
 * row's figures stand on the chain they would on hardware, and its rig
 * time says what the chain cost. */
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "capture/calibration.h"
#include "common/paths.h"
#include "sim_source/sim_source.h"
#include "study/study_private.h"

#define DARK_FRAMES 16       /* gonio calibrate's defaults */
#define REFERENCE_REPEATS 4
#define STANDARD "spectralon-99"
/* The simulated detector does not drift with temperature: a study rerun
 * days later resumes its captures with the calibration they began with. */
#define VALID_S (365 * 86400.0)

/* One calibration of kind on scene's rig (material: the standard for a
 * reference), written into root; its id into meta, its rig time added to
 * *rig_time_s. *counts is 0 (and nothing written) when the detector
 * reports BRDF itself. */
static int measure(const char *scene, const char *plan_name, const char *root,
                   struct cal_meta *meta, int *counts, double *rig_time_s,
                   struct gonio_err *err)
{
    sim_source *src = sim_source_new(scene, meta->kind == CAL_REFERENCE ? "standard:" STANDARD
                                                                        : NULL,
                                     NULL, err);
    if (!src)
        return -abs(err->code ? err->code : EINVAL);
    struct capture_rig crig;
    sim_source_rig(src, &crig);
    *counts = crig.counts;
    struct rig_profile prof;
    struct plan *plan = NULL;
    struct cal_frame *frames = NULL;
    size_t n = 0;
    int rc = crig.counts ? rig_profile_load(crig.profile, &prof, err) : 0;
    if (rc >= 0 && crig.counts && meta->kind == CAL_REFERENCE &&
        (rc = plan_load(plan_name, &prof, &plan, err)) > 0)
        rc = 0;
    struct capture_devices dev;
    /* The dark covers every rung of the auto-ranging ladder, as an operator's
     * `gonio calibrate dark --ladder` does, so that the capture ranges: at
     * the fixed integration alone a metal's peak clips and a dark tail
     * drowns in read noise. The reference, at the fixed integration, serves
     * every rung. */
    if (rc >= 0 && crig.counts) {
        meta->integrations[0] = prof.integration_s;
        meta->n_integrations = 1;
        if (meta->kind == CAL_DARK)
            cal_add_ladder(meta, &prof);
    }
    if (rc >= 0 && crig.counts && (rc = crig.open(crig.user, &prof, root, &dev, err)) >= 0) {
        rc = meta->kind == CAL_DARK
                 ? cal_measure_dark(&dev, meta->integrations, meta->n_integrations, DARK_FRAMES,
                                    &frames, &n, err)
                 : cal_measure_reference(&dev, &prof, plan, REFERENCE_REPEATS, &frames, &n,
                                         err);
        crig.close(crig.user, &dev);
    }
    if (rc >= 0 && crig.counts) {
        snprintf(meta->rig, sizeof meta->rig, "%s", prof.name);
        snprintf(meta->detector, sizeof meta->detector, "%s",
                 crig.detector ? crig.detector : "unknown");
        meta->in_position_deg = prof.mech.in_position_deg;
        meta->gain_state = n > 0 ? frames[0].gain_state : 0;
        cal_new_id(root, meta->kind, meta->created, meta->id, sizeof meta->id);
        rc = cal_write(root, meta, frames, n, err);
        if (n > 0)
            *rig_time_s += frames[n - 1].rig_time_s;
    }
    free(frames);
    plan_free(plan);
    sim_source_free(src);
    return rc < 0 ? rc : 0;
}

/* The rig time of the calibrations in root (a rerun's, measured before). */
static int rig_time_of(const char *root, double *rig_time_s, struct gonio_err *err)
{
    DIR *d = opendir(root);
    if (!d)
        return gonio_err_set(err, errno, "%s: cannot list", root);
    int rc = 0;
    struct dirent *e;
    while (rc >= 0 && (e = readdir(d))) {
        if (e->d_name[0] == '.')
            continue;
        struct cal_meta m;
        struct cal_frame *f = NULL;
        size_t n = 0;
        rc = cal_read(root, e->d_name, &m, &f, &n, err);
        if (rc >= 0 && n > 0)
            *rig_time_s += f[n - 1].rig_time_s;
        free(f);
    }
    closedir(d);
    return rc < 0 ? rc : 0;
}

int study_calibrate(const char *scene, const char *plan, const char *jobdir, char *root,
                    size_t size, double *rig_time_s, struct gonio_err *err)
{
    *rig_time_s = 0;
    if (snprintf(root, size, "%s/calibrations", jobdir) >= (int)size)
        return gonio_err_set(err, GONIO_EUSAGE, "%s: path too long", jobdir);
    struct stat st;
    if (stat(root, &st) == 0) /* a rerun: the capture resumes with it */
        return rig_time_of(root, rig_time_s, err);
    /* Measured in a folder of its own, renamed when whole: a job stopped
     * part way measures again (the newest reference there is the one). */
    char tmp[4200];
    snprintf(tmp, sizeof tmp, "%s.partial", root);
    int rc = gonio_mkdir_p(tmp, err);
    struct cal_meta dark = {.kind = CAL_DARK, .created = time(NULL), .valid_s = VALID_S,
                            .spot = RAD_SPOT_OVERFILLED};
    int counts = 0;
    if (rc >= 0)
        rc = measure(scene, plan, tmp, &dark, &counts, rig_time_s, err);
    if (rc >= 0 && counts) {
        struct cal_meta ref = {.kind = CAL_REFERENCE, .created = dark.created,
                               .valid_s = VALID_S, .spot = RAD_SPOT_OVERFILLED};
        snprintf(ref.standard, sizeof ref.standard, "%s", STANDARD);
        snprintf(ref.dark, sizeof ref.dark, "%s", dark.id);
        rc = measure(scene, plan, tmp, &ref, &counts, rig_time_s, err);
    }
    if (rc >= 0 && !counts) { /* the detector reports BRDF: no calibration */
        rmdir(tmp);
        root[0] = '\0';
        return 0;
    }
    if (rc >= 0 && rename(tmp, root) != 0)
        rc = gonio_err_set(err, errno, "%s: cannot rename to %s", tmp, root);
    return rc;
}
