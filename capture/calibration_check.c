#include "capture/calibration_check.h"

int capture_calibration_check(const struct capture_config *cfg, int counts,
                              const char *detector, struct gonio_err *err)
{
    if (!counts || cfg->uncalibrated || cfg->calibrations || cfg->estimate_only)
        return 0; /* a calibration named is looked up and checked when the job resolves */
    return gonio_err_set(err, GONIO_EUSAGE,
                         "the detector (%s) gives counts and the capture names no calibration "
                         "to turn them into BRDF: give --calibration ID, or --uncalibrated to "
                         "journal the counts and fit nothing", detector ? detector : "unknown");
}
