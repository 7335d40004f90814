/* Inside capture/: whether a capture may turn its detector's readings into
 * BRDF (docs/cli.md, "gonio capture --uncalibrated"). A detector that
 * reports BRDF needs nothing; one that gives counts needs a calibration
 * (--calibrations ROOT, which capture/calibration.h looks up and checks),
 * or the capture says it goes without one (--uncalibrated: it journals the
 * counts and fits nothing). */
#ifndef GONIO_CAPTURE_CALIBRATION_CHECK_H
#define GONIO_CAPTURE_CALIBRATION_CHECK_H

#include "capture/capture.h"
#include "common/err.h"

/* 0 when cfg may capture from a detector that gives counts (counts 1) or
 * BRDF (counts 0), or only wants the estimate (estimate_only); else -GONIO_EUSAGE (exit 2) with a message naming the
 * detector (setup.json's name for it; NULL: "unknown") and the fix. */
int capture_calibration_check(const struct capture_config *cfg, int counts,
                              const char *detector, struct gonio_err *err);

#endif
