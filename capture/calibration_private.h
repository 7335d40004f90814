/* What the calibration files share inside capture/: a growing array of
 * frames, one reading, a move to a plan point, and frames.csv's line
 * format, which the run's journal uses too. */
#ifndef GONIO_CAPTURE_CALIBRATION_PRIVATE_H
#define GONIO_CAPTURE_CALIBRATION_PRIVATE_H

#include "capture/calibration.h"

struct cal_frames {
    struct cal_frame *v;
    size_t n, cap;
};

int cal_frames_push(struct cal_frames *f, const struct cal_frame *fr, struct gonio_err *err);

/* One reading at integration_s, appended to f with the plan's angles. */
int cal_read_frame(struct capture_devices *dev, enum cal_kind kind, double ti, double tr,
                   double integration_s, struct cal_frames *f, struct gonio_err *err);

/* Move the axes to a point and let them settle. */
int cal_go_to(struct capture_devices *dev, const struct rig_profile *rig,
              const struct plan_point *pt, struct gonio_err *err);

#define CAL_FRAMES_HEADER "kind,theta_i,theta_r,integration_s,gain_state,r,g,b,monitor," \
                          "full_scale,nonlinearity,rig_time_s\n"

/* A frame as a frames.csv line (with its newline); the length written.
 * A spectral detector's frame adds one field after rig_time_s, its bands
 * as "nm:counts" separated by spaces; an RGB frame's line is unchanged. */
#define CAL_FRAME_LINE_MAX (512 + 56 * CAL_MAX_BANDS)
int cal_frame_line(const struct cal_frame *f, char *buf, size_t size);

/* Read a frames file (the header and lines of cal_frame_line); *out is
 * malloc'd. */
int cal_frames_read(const char *path, struct cal_frame **out, size_t *n, struct gonio_err *err);

/* The run directory's changer journal: "slot N swapping" before the
 * changer is asked for slot N, "slot N in" once it is there; gone once
 * the sample is back in its place. */
#define CAL_CHANGER_JOURNAL "changer"

/* Put slot in the sample's place through h->mount, journalled in dir. */
int cal_changer_put(const char *dir, const struct cal_hooks *h, struct capture_devices *dev,
                    enum capture_slot slot, const char *standard, struct gonio_err *err);

/* The slot dir's changer journal names, swapping or in alike (either way
 * the sample is not in its place, and asking the changer again for a slot
 * it holds does not move it); -1 when there is no journal (the sample in
 * its place), CAPTURE_SLOT_TRAP + 1 when it cannot be read. */
int cal_changer_journalled(const char *dir);

#endif
