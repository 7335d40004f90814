/* What the three plot kinds share: a panel (plot area and two axes), its
 * frame, grid, ticks and labels, a legend, and the colour and marker
 * cycles. Figures are small multiples: one panel per material. */
#ifndef GONIO_REPORT_PLOT_H
#define GONIO_REPORT_PLOT_H

#include <stddef.h>

#include "report/axis.h"
#include "report/svg.h"

struct plot_panel {
    double x, y, w, h; /* plot area, SVG units */
    struct plot_axis ax, ay;
};

/* SVG coordinates of a data value (outside the area for values outside
 * the axis range; NAN where the axis cannot show the value). */
double plot_px(const struct plot_panel *p, double v);
double plot_py(const struct plot_panel *p, double v);

/* Frame, grid lines at the labelled ticks, tick marks (minor ones shorter),
 * tick labels, axis titles and the panel title (any of the strings may be
 * NULL). */
void plot_draw_frame(svg_doc *s, const struct plot_panel *p, const char *title,
                     const char *xlabel, const char *ylabel);

struct plot_style {
    const char *color;
    double width;          /* line width; 0: no line */
    const char *dash;      /* NULL: solid */
    enum svg_marker marker;
    double marker_size;    /* 0: no marker */
    int hollow;            /* marker outlined, white inside */
};

struct plot_legend_entry {
    const char *label;
    struct plot_style style;
};

/* A legend laid out in rows from (x, y) (top left) within width; returns
 * the height it took. */
double plot_draw_legend(svg_doc *s, double x, double y, double width,
                        const struct plot_legend_entry *e, size_t n);

/* The height plot_draw_legend will take for these entries. */
double plot_legend_height(double width, const struct plot_legend_entry *e, size_t n);

/* A colour-blind-safe palette (Okabe and Ito), cycled. */
const char *plot_color(size_t i);

/* Draw a marker in a style at SVG coordinates (nothing for NAN). */
void plot_draw_marker(svg_doc *s, const struct plot_style *st, double x, double y,
                      const char *tooltip);

/* Columns and rows for n panels: at most max_cols columns. */
void plot_grid(size_t n, size_t max_cols, size_t *cols, size_t *rows);

#define PLOT_FONT 12.0
#define PLOT_FONT_SMALL 10.5

#endif
