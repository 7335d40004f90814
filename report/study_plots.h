/* The study's two summary figures, one panel per material:
 *  - accuracy against rig time: every (plan, model) of a scene as a point
 *    (colour: model, marker: plan), with the material's Pareto front as a
 *    staircase (the best error each rig time buys);
 *  - bars of an error per plan (groups) and model (bars), from 0 on a
 *    linear axis, or from the axis floor on a log axis (said in the panel
 *    title) when a panel's errors span more than a factor 30. */
#ifndef GONIO_REPORT_STUDY_PLOTS_H
#define GONIO_REPORT_STUDY_PLOTS_H

#include <stddef.h>

#include "common/err.h"
#include "report/results.h"

struct report_plot_opts {
    const char *scene; /* rows of this scene only; NULL: the first scene */
    enum report_domain domain;
    enum report_metric metric;
    const char *title; /* NULL: made from the options */
};

/* Draw the figure as an SVG document (malloc'd into *svg, length *len).
 * Returns 0, or a negative code (no row with a value to plot: GONIO_EUSAGE
 * naming the scene, domain and metric). */
int report_plot_pareto(const struct report_results *r, const struct report_plot_opts *o,
                       const char *id_prefix, char **svg, size_t *len, struct gonio_err *err);
int report_plot_bars(const struct report_results *r, const struct report_plot_opts *o,
                     const char *id_prefix, char **svg, size_t *len, struct gonio_err *err);

#endif
