/* The absolute method's calibration (docs/radiometry.md, "Absolute
 * method"): the sample removed, the arm facing the source, the direct beam
 * read through the rig's attenuator; the detector's solid angle and the
 * attenuator's transmittance from the rig profile's beam section
 * (rig/rig.h), recorded in the calibration as they were when it was read.
 * The run itself is an ordinary calibration run (cal_run_measure) of one
 * point, journalled and resumable like the others. */
#ifndef GONIO_CAPTURE_CALIBRATION_BEAM_H
#define GONIO_CAPTURE_CALIBRATION_BEAM_H

#include "capture/calibration.h"

/* m's beam geometry and spot (underfilled) from the rig profile; refused
 * (-GONIO_EBADCONFIG) when the profile states no beam section. */
int cal_beam_meta(struct cal_meta *m, const struct rig_profile *rig, struct gonio_err *err);

/* Where the beam is read: the sample axis at 0, the arm facing the source
 * (the profile's beam.arm_deg); theta_i 0 and theta_r the arm angle, the
 * angles its frames carry. */
void cal_beam_point(const struct rig_profile *rig, struct plan_point *pt);

#endif
