/* In-plane BRDF slices: BRDF against theta_r for each theta_i on a log
 * axis, one panel per theta_i, with the ground truth, the captured samples
 * and any number of fitted models together. Truth and models are anything
 * behind the material interface (brdf/material.h), so a fitted model
 * (model:FILE) and a ground truth are drawn the same way. */
#ifndef GONIO_REPORT_SLICES_H
#define GONIO_REPORT_SLICES_H

#include <stddef.h>

#include "brdf/material.h"
#include "common/err.h"

/* One measured in-plane sample (a capture's samples.csv record). */
struct report_sample {
    double theta_i, theta_r; /* degrees */
    double rgb[3];           /* 1/sr */
};

/* What is plotted of an RGB value. */
enum report_channel { REPORT_R, REPORT_G, REPORT_B, REPORT_Y };

#define REPORT_SLICES_MAX_PANELS 12

struct report_slices {
    const char *title;               /* figure title, may be NULL */
    const brdf_material *truth;      /* may be NULL */
    const char *truth_label;         /* NULL: "ground truth" */
    const brdf_material *const *models;
    const char *const *model_labels; /* NULL entries: the material's name */
    size_t n_models;
    const struct report_sample *samples;
    size_t n_samples;
    /* The panels' theta_i; n_theta_i = 0 takes them from the samples (up to
     * six, evenly spread; samples at fewer than three incidences are shown
     * among 0, 15, ..., 75) or, without samples, 0, 15, ..., 75. */
    const double *theta_i;
    size_t n_theta_i;
    enum report_channel channel;
};

/* The value of a channel of an RGB triple: a channel, or the luminance Y
 * of linear sRGB (0.2126 R + 0.7152 G + 0.0722 B). */
double report_channel_value(enum report_channel c, const double rgb[3]);

/* The theta_i of the panels for these options (at most
 * REPORT_SLICES_MAX_PANELS) into out; returns their number, or a negative
 * code when a given theta_i is outside [0, 89]. */
int report_slices_theta_i(const struct report_slices *in, double *out, struct gonio_err *err);

/* Draw the figure as an SVG document (malloc'd into *svg, length *len);
 * id_prefix keeps its element ids apart from other inlined plots.
 * Returns 0 or a negative code (nothing to draw, out of memory). */
int report_plot_slices(const struct report_slices *in, const char *id_prefix, char **svg,
                       size_t *len, struct gonio_err *err);

#endif
