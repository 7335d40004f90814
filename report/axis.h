/* Plot axes: the shown range and its ticks, linear or logarithmic.
 *
 * A linear axis rounds its range out to a "nice" step (1, 2 or 5 times a
 * power of ten) so that both ends carry a tick. A log axis rounds out to
 * whole decades and labels them; when it spans a single decade it also
 * labels 2 and 5, so that every axis has at least three labelled ticks. A
 * duration axis is a log axis in seconds labelled in the units a person
 * reads rig time in (10 s, 1 min, 1 h, 1 d). */
#ifndef GONIO_REPORT_AXIS_H
#define GONIO_REPORT_AXIS_H

#include <stddef.h>

enum plot_scale { PLOT_LINEAR, PLOT_LOG, PLOT_DURATION };

#define PLOT_TICKS_MAX 40
#define PLOT_LABEL_MAX 32

struct plot_axis {
    enum plot_scale scale;
    double lo, hi; /* the shown range; lo < hi, both > 0 on log scales */
    size_t n_ticks;
    double ticks[PLOT_TICKS_MAX]; /* labelled ticks, ascending, within [lo, hi] */
    char labels[PLOT_TICKS_MAX][PLOT_LABEL_MAX]; /* UTF-8 */
    size_t n_minor;
    double minor[PLOT_TICKS_MAX]; /* unlabelled ticks (log: 2..9 x decade) */
};

/* Fit an axis to the data range [lo, hi] with at most max_ticks labelled
 * ticks (at least 3 are asked for). Non-finite bounds, lo > hi, or a bound
 * <= 0 on a log scale are refused (-1). lo == hi is widened around the
 * value. Returns 0. */
int plot_axis_fit(struct plot_axis *a, enum plot_scale scale, double lo, double hi,
                  int max_ticks);

/* Fix the shown range to exactly [lo, hi] (no rounding out), ticks inside
 * it at a nice step; for axes whose range is known (angles). */
int plot_axis_fixed(struct plot_axis *a, enum plot_scale scale, double lo, double hi,
                    int max_ticks);

/* Position of v along the axis, 0 at lo and 1 at hi (outside for values
 * outside the range; NAN for v <= 0 on a log scale or a non-finite v). */
double plot_axis_frac(const struct plot_axis *a, double v);

#endif
