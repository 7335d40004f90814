/* Writing self-contained HTML: escaped text, SVG inlined, images as
 * base64 data URIs (GLib's encoder). */
#ifndef GONIO_REPORT_HTML_H
#define GONIO_REPORT_HTML_H

#include <stddef.h>
#include <stdio.h>

/* Text with &, <, >, " and ' escaped (control characters dropped), valid
 * in HTML and in XML (SVG) alike. */
void html_text(FILE *f, const char *text);

/* An SVG document inlined into HTML: the XML namespace declaration is left
 * out (the HTML parser puts <svg> in the SVG namespace itself), so the
 * page carries no URL at all. */
void html_inline_svg(FILE *f, const char *svg, size_t len);

/* <img> with the PNG bytes as a data URI; alt is escaped. Returns 0, or -1
 * when memory ran out. */
int html_png_img(FILE *f, const unsigned char *png, size_t len, unsigned width,
                 unsigned height, const char *alt);

/* Numbers for tables: "0.0312", or "–" for NAN. */
void html_number(FILE *f, double v, int significant);

/* A duration in the unit a person reads it in: "45 s", "12.3 min",
 * "4.2 h", "2.1 d"; "–" for NAN. */
void html_duration(FILE *f, double seconds);

#endif
