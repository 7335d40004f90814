/* A minimal SVG 1.1 writer: the few elements gonio's plots are made of,
 * written straight into a memory buffer (no plotting runtime).
 *
 * Coordinates are user units (pixels at scale 1), y pointing down. Text is
 * escaped here, so any string (a material name, a file name) is safe to
 * pass. Colours and dash patterns are SVG attribute values ("#1f77b4",
 * "none", "4 2") and come from the caller's code, not from data. Element
 * ids carry a prefix given at creation, so several plots inlined into one
 * HTML page never share an id. */
#ifndef GONIO_REPORT_SVG_H
#define GONIO_REPORT_SVG_H

#include <stddef.h>

typedef struct svg_doc svg_doc;

enum svg_anchor { SVG_START, SVG_MIDDLE, SVG_END };

enum svg_marker { SVG_CIRCLE, SVG_SQUARE, SVG_DIAMOND, SVG_TRIANGLE, SVG_TRIANGLE_DOWN,
                  SVG_CROSS, SVG_PLUS, SVG_STAR, SVG_N_MARKERS };

/* A document of the given size; id_prefix (letters, digits, '-', '_'
 * only; others are dropped) names its clip paths. NULL when out of memory. */
svg_doc *svg_new(double width, double height, const char *id_prefix);

void svg_rect(svg_doc *s, double x, double y, double w, double h, const char *fill,
              const char *stroke, double stroke_width);
void svg_line(svg_doc *s, double x1, double y1, double x2, double y2, const char *stroke,
              double width, const char *dash);

/* A polyline through (x[i], y[i]); a non-finite coordinate breaks the line
 * (a gap, as for a value a log axis cannot show). */
void svg_polyline(svg_doc *s, const double *x, const double *y, size_t n, const char *stroke,
                  double width, const char *dash);

/* A marker of size (its width) centred on (x, y). tooltip, when not NULL,
 * becomes its <title> (shown on hover in a browser). */
void svg_marker(svg_doc *s, enum svg_marker shape, double x, double y, double size,
                const char *fill, const char *stroke, const char *tooltip);

/* Text at (x, y) (baseline), turned by rotate_deg about that point. */
void svg_text(svg_doc *s, double x, double y, enum svg_anchor anchor, double size,
              double rotate_deg, int bold, const char *fill, const char *text);

/* Start a group clipped to a rectangle (plot area); end it with
 * svg_group_end. */
void svg_clip_begin(svg_doc *s, double x, double y, double w, double h);
void svg_group_end(svg_doc *s);

/* Close the document and return it as a NUL-terminated string (malloc'd,
 * caller frees) with its length in *len; the document is freed. NULL when
 * memory ran out at any point. */
char *svg_finish(svg_doc *s, size_t *len);

/* Free a document without finishing it (NULL is a no-op). */
void svg_free(svg_doc *s);

#endif
