/* Panels, frames and legends (plot.h). */
#include "report/plot.h"

#include <math.h>
#include <string.h>

#define GRID_COLOUR "#e3e3e3"
#define AXIS_COLOUR "#333333"
#define TEXT_COLOUR "#222222"
#define TICK_LEN 5.0
#define MINOR_LEN 3.0

double plot_px(const struct plot_panel *p, double v)
{
    return p->x + p->w * plot_axis_frac(&p->ax, v);
}

double plot_py(const struct plot_panel *p, double v)
{
    return p->y + p->h * (1 - plot_axis_frac(&p->ay, v));
}

void plot_draw_frame(svg_doc *s, const struct plot_panel *p, const char *title,
                     const char *xlabel, const char *ylabel)
{
    double x0 = p->x, y0 = p->y, x1 = p->x + p->w, y1 = p->y + p->h;
    for (size_t i = 0; i < p->ax.n_ticks; i++) {
        double x = plot_px(p, p->ax.ticks[i]);
        if (x > x0 + 0.5 && x < x1 - 0.5)
            svg_line(s, x, y0, x, y1, GRID_COLOUR, 0.8, NULL);
        svg_line(s, x, y1, x, y1 + TICK_LEN, AXIS_COLOUR, 1, NULL);
        svg_text(s, x, y1 + TICK_LEN + PLOT_FONT_SMALL + 1, SVG_MIDDLE, PLOT_FONT_SMALL, 0, 0,
                 TEXT_COLOUR, p->ax.labels[i]);
    }
    for (size_t i = 0; i < p->ax.n_minor; i++) {
        double x = plot_px(p, p->ax.minor[i]);
        svg_line(s, x, y1, x, y1 + MINOR_LEN, AXIS_COLOUR, 0.8, NULL);
    }
    for (size_t i = 0; i < p->ay.n_ticks; i++) {
        double y = plot_py(p, p->ay.ticks[i]);
        if (y > y0 + 0.5 && y < y1 - 0.5)
            svg_line(s, x0, y, x1, y, GRID_COLOUR, 0.8, NULL);
        svg_line(s, x0 - TICK_LEN, y, x0, y, AXIS_COLOUR, 1, NULL);
        svg_text(s, x0 - TICK_LEN - 3, y + PLOT_FONT_SMALL * 0.35, SVG_END, PLOT_FONT_SMALL, 0,
                 0, TEXT_COLOUR, p->ay.labels[i]);
    }
    for (size_t i = 0; i < p->ay.n_minor; i++) {
        double y = plot_py(p, p->ay.minor[i]);
        svg_line(s, x0 - MINOR_LEN, y, x0, y, AXIS_COLOUR, 0.8, NULL);
    }
    svg_rect(s, x0, y0, p->w, p->h, NULL, AXIS_COLOUR, 1);
    if (title)
        svg_text(s, x0 + p->w / 2, y0 - 7, SVG_MIDDLE, PLOT_FONT, 0, 1, TEXT_COLOUR, title);
    if (xlabel)
        svg_text(s, x0 + p->w / 2, y1 + TICK_LEN + PLOT_FONT_SMALL + PLOT_FONT + 6, SVG_MIDDLE,
                 PLOT_FONT, 0, 0, TEXT_COLOUR, xlabel);
    if (ylabel) {
        /* Left of the widest tick label (about 0.6 em a character). */
        size_t widest = 0;
        for (size_t i = 0; i < p->ay.n_ticks; i++) {
            size_t w = 0; /* characters, not bytes: "10⁻³" is four */
            for (const char *c = p->ay.labels[i]; *c; c++)
                w += ((unsigned char)*c & 0xC0) != 0x80;
            widest = w > widest ? w : widest;
        }
        double x = x0 - TICK_LEN - 8 - 0.6 * PLOT_FONT_SMALL * (double)widest - 4;
        svg_text(s, x, y0 + p->h / 2, SVG_MIDDLE, PLOT_FONT, -90, 0, TEXT_COLOUR, ylabel);
    }
}

void plot_draw_marker(svg_doc *s, const struct plot_style *st, double x, double y,
                      const char *tooltip)
{
    if (!(st->marker_size > 0) || !isfinite(x) || !isfinite(y))
        return;
    svg_marker(s, st->marker, x, y, st->marker_size, st->hollow ? "#ffffff" : st->color,
               st->color, tooltip);
}

#define SWATCH 26.0
#define ROW_H 17.0

static double entry_width(const struct plot_legend_entry *e)
{
    return SWATCH + 6 + 0.58 * PLOT_FONT_SMALL * (double)strlen(e->label) + 16;
}

/* Lay the entries out in rows; draw them when s is not NULL. */
static double legend(svg_doc *s, double x, double y, double width,
                     const struct plot_legend_entry *e, size_t n)
{
    if (!n)
        return 0;
    double cx = x, cy = y + ROW_H / 2;
    for (size_t i = 0; i < n; i++) {
        double w = entry_width(&e[i]);
        if (cx > x && cx + w > x + width) {
            cx = x;
            cy += ROW_H;
        }
        if (s) {
            const struct plot_style *st = &e[i].style;
            if (st->width > 0)
                svg_line(s, cx, cy, cx + SWATCH, cy, st->color, st->width, st->dash);
            plot_draw_marker(s, st, cx + SWATCH / 2, cy, NULL);
            svg_text(s, cx + SWATCH + 6, cy + PLOT_FONT_SMALL * 0.35, SVG_START, PLOT_FONT_SMALL,
                     0, 0, TEXT_COLOUR, e[i].label);
        }
        cx += w;
    }
    return cy + ROW_H / 2 - y;
}

double plot_draw_legend(svg_doc *s, double x, double y, double width,
                        const struct plot_legend_entry *e, size_t n)
{
    return legend(s, x, y, width, e, n);
}

double plot_legend_height(double width, const struct plot_legend_entry *e, size_t n)
{
    return legend(NULL, 0, 0, width, e, n);
}

const char *plot_color(size_t i)
{
    static const char *okabe_ito[] = {"#0072B2", "#D55E00", "#009E73", "#CC79A7",
                                      "#E69F00", "#56B4E9", "#F0E442", "#000000"};
    return okabe_ito[i % (sizeof okabe_ito / sizeof okabe_ito[0])];
}

void plot_grid(size_t n, size_t max_cols, size_t *cols, size_t *rows)
{
    if (!max_cols)
        max_cols = 1;
    *cols = n < max_cols ? (n ? n : 1) : max_cols;
    *rows = (n + *cols - 1) / *cols;
    if (!*rows)
        *rows = 1;
}
