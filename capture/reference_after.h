/* Inside capture/: the reference standard read again after a capture's
 * points (capture_config.reference_after), what a lab's relative method
 * does to bracket the lamp's drift: the standard before (the calibration)
 * and after the sample, and the sample's values reduced with the
 * standard's response interpolated in rig time between the two
 * (docs/radiometry.md, "Drift").
 *
 * The readings are journalled as a calibration run is (cal_run_measure),
 * in the capture directory's reference-after/journal.csv: a run killed
 * between the sample's last point and the end of these readings resumes
 * them and loses nothing. */
#ifndef GONIO_CAPTURE_REFERENCE_AFTER_H
#define GONIO_CAPTURE_REFERENCE_AFTER_H

#include <stddef.h>

#include "capture/calibration.h"
#include "capture/capture.h"
#include "capture/journal_plan.h"
#include "journal/journal.h"

#define REFERENCE_AFTER_ID "reference-after"
/* The geometries read again (spread over the calibration's) and the
 * readings at each: 20 readings put the ratio's noise near a single
 * sample reading's over 4. */
#define REFERENCE_AFTER_GEOMETRIES 5
#define REFERENCE_AFTER_REPEATS 4

/* 1 when DIR's reference read again is complete (its journal holds every
 * reading the calibration cl asks); *frames (malloc'd, may be NULL when
 * not wanted) the readings it holds either way. */
int reference_after_read(const char *dir, const struct cal_loaded *cl, struct cal_frame **frames,
                         size_t *n, struct gonio_err *err);

/* Read the standard again on dev into DIR/reference-after: mounted by
 * src->mount (and the sample mounted back after), else the operator asked
 * through hooks->ask. A journal already there is continued. *frames
 * (malloc'd) all its readings; *aborted 1 when the host stopped it. */
int reference_after_measure(struct capture_devices *dev, const struct capture_rig *src,
                            const struct capture_hooks *hooks, const struct rig_profile *rig,
                            const char *dir, const struct cal_loaded *cl,
                            struct cal_frame **frames, size_t *n, int *aborted,
                            struct gonio_err *err);

/* The drift the readings show against the calibration (cl->drift), placed
 * at rig time t_end_s: each reading reduced with cl as a sample at its
 * geometry, over the standard's BRDF there, averaged per geometry, then
 * over the geometries. */
int reference_after_derive(struct cal_loaded *cl, const struct cal_frame *f, size_t n,
                           double t_end_s, struct gonio_err *err);

/* Every counts record of journal path reduced again with cl (its drift
 * set), in journal order, each with the records before it, as the capture
 * reduced it while it measured; the journal written again in its place
 * (atomically: a new file renamed over it), raw counts unchanged. samples
 * (the capture's records without its dark frames, n of them, in journal
 * order) take the same values. */
int reference_after_apply(const struct cal_loaded *cl, const struct journal_plan *jp,
                          const char *path, struct journal_sample *samples, size_t n,
                          struct gonio_err *err);

#endif
