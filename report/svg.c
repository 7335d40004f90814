/* SVG writer over open_memstream (svg.h). */
#include "report/svg.h"

#include "report/html.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

struct svg_doc {
    FILE *f;
    char *buf;
    size_t len;
    char prefix[32];
    int n_clips;
};

svg_doc *svg_new(double width, double height, const char *id_prefix)
{
    svg_doc *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    s->f = open_memstream(&s->buf, &s->len);
    if (!s->f) {
        free(s);
        return NULL;
    }
    size_t k = 0;
    for (const char *p = id_prefix ? id_prefix : ""; *p && k + 1 < sizeof s->prefix; p++)
        if ((*p >= 'a' && *p <= 'z') || (*p >= 'A' && *p <= 'Z') ||
            (*p >= '0' && *p <= '9') || *p == '-' || *p == '_')
            s->prefix[k++] = *p;
    s->prefix[k] = '\0';
    if (!k || (s->prefix[0] >= '0' && s->prefix[0] <= '9')) { /* an id starts with a letter */
        if (k + 1 >= sizeof s->prefix)
            k--;
        memmove(s->prefix + 1, s->prefix, k + 1);
        s->prefix[0] = 'p';
    }
    fprintf(s->f,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"%.0f\" "
            "height=\"%.0f\" viewBox=\"0 0 %.0f %.0f\" "
            "font-family=\"DejaVu Sans, Liberation Sans, Arial, sans-serif\">\n",
            width, height, width, height);
    fprintf(s->f, "<rect x=\"0\" y=\"0\" width=\"%.0f\" height=\"%.0f\" fill=\"#ffffff\"/>\n",
            width, height);
    return s;
}

static void dash_attr(FILE *f, const char *dash)
{
    if (dash && *dash)
        fprintf(f, " stroke-dasharray=\"%s\"", dash);
}

void svg_rect(svg_doc *s, double x, double y, double w, double h, const char *fill,
              const char *stroke, double stroke_width)
{
    fprintf(s->f, "<rect x=\"%.2f\" y=\"%.2f\" width=\"%.2f\" height=\"%.2f\" fill=\"%s\"", x,
            y, w, h, fill ? fill : "none");
    if (stroke)
        fprintf(s->f, " stroke=\"%s\" stroke-width=\"%.2f\"", stroke, stroke_width);
    fputs("/>\n", s->f);
}

void svg_line(svg_doc *s, double x1, double y1, double x2, double y2, const char *stroke,
              double width, const char *dash)
{
    fprintf(s->f,
            "<line x1=\"%.2f\" y1=\"%.2f\" x2=\"%.2f\" y2=\"%.2f\" stroke=\"%s\" "
            "stroke-width=\"%.2f\"",
            x1, y1, x2, y2, stroke, width);
    dash_attr(s->f, dash);
    fputs("/>\n", s->f);
}

void svg_polyline(svg_doc *s, const double *x, const double *y, size_t n, const char *stroke,
                  double width, const char *dash)
{
    size_t i = 0;
    while (i < n) {
        while (i < n && !(isfinite(x[i]) && isfinite(y[i])))
            i++;
        size_t j = i;
        while (j < n && isfinite(x[j]) && isfinite(y[j]))
            j++;
        if (j - i >= 2) {
            fputs("<polyline points=\"", s->f);
            for (size_t k = i; k < j; k++)
                fprintf(s->f, "%s%.1f,%.1f", k > i ? " " : "", x[k], y[k]);
            fprintf(s->f,
                    "\" fill=\"none\" stroke=\"%s\" stroke-width=\"%.2f\" "
                    "stroke-linejoin=\"round\" stroke-linecap=\"round\"",
                    stroke, width);
            dash_attr(s->f, dash);
            fputs("/>\n", s->f);
        }
        i = j;
    }
}

static void close_marker(svg_doc *s, const char *tooltip)
{
    if (tooltip) {
        fputs("><title>", s->f);
        html_text(s->f, tooltip);
        fputs("</title></path>\n", s->f);
    } else {
        fputs("/>\n", s->f);
    }
}

void svg_marker(svg_doc *s, enum svg_marker shape, double x, double y, double size,
                const char *fill, const char *stroke, const char *tooltip)
{
    double r = size / 2;
    fputs("<path d=\"", s->f);
    switch (shape) {
    case SVG_SQUARE:
        r *= 0.88; /* same visual weight as the circle */
        fprintf(s->f, "M%.2f,%.2fh%.2fv%.2fh%.2fz", x - r, y - r, 2 * r, 2 * r, -2 * r);
        break;
    case SVG_DIAMOND:
        r *= 1.2;
        fprintf(s->f, "M%.2f,%.2fL%.2f,%.2fL%.2f,%.2fL%.2f,%.2fz", x, y - r, x + r, y, x,
                y + r, x - r, y);
        break;
    case SVG_TRIANGLE:
    case SVG_TRIANGLE_DOWN: {
        double d = shape == SVG_TRIANGLE ? 1 : -1;
        r *= 1.2;
        fprintf(s->f, "M%.2f,%.2fL%.2f,%.2fL%.2f,%.2fz", x, y - d * r, x + 0.866 * r,
                y + d * 0.5 * r, x - 0.866 * r, y + d * 0.5 * r);
        break;
    }
    case SVG_CROSS:
        fprintf(s->f, "M%.2f,%.2fL%.2f,%.2fM%.2f,%.2fL%.2f,%.2f", x - r, y - r, x + r, y + r,
                x - r, y + r, x + r, y - r);
        fill = "none";
        break;
    case SVG_PLUS:
        r *= 1.2;
        fprintf(s->f, "M%.2f,%.2fL%.2f,%.2fM%.2f,%.2fL%.2f,%.2f", x - r, y, x + r, y, x,
                y - r, x, y + r);
        fill = "none";
        break;
    case SVG_STAR: {
        r *= 1.3;
        for (int k = 0; k < 10; k++) {
            double a = PI / 2 + k * PI / 5, rr = k % 2 ? 0.45 * r : r;
            fprintf(s->f, "%c%.2f,%.2f", k ? 'L' : 'M', x + rr * cos(a), y - rr * sin(a));
        }
        fputc('z', s->f);
        break;
    }
    case SVG_CIRCLE:
    default:
        fprintf(s->f, "M%.2f,%.2fa%.2f,%.2f 0 1,0 %.2f,0a%.2f,%.2f 0 1,0 %.2f,0z", x - r, y, r,
                r, 2 * r, r, r, -2 * r);
        break;
    }
    fprintf(s->f, "\" fill=\"%s\" stroke=\"%s\" stroke-width=\"1.2\"", fill ? fill : "none",
            stroke ? stroke : "none");
    close_marker(s, tooltip);
}

void svg_text(svg_doc *s, double x, double y, enum svg_anchor anchor, double size,
              double rotate_deg, int bold, const char *fill, const char *text)
{
    static const char *anchors[] = {"start", "middle", "end"};
    fprintf(s->f, "<text x=\"%.2f\" y=\"%.2f\" font-size=\"%.1f\" text-anchor=\"%s\" fill=\"%s\"",
            x, y, size, anchors[anchor], fill ? fill : "#000000");
    if (bold)
        fputs(" font-weight=\"bold\"", s->f);
    if (rotate_deg != 0)
        fprintf(s->f, " transform=\"rotate(%.1f %.2f %.2f)\"", rotate_deg, x, y);
    fputc('>', s->f);
    html_text(s->f, text);
    fputs("</text>\n", s->f);
}

void svg_clip_begin(svg_doc *s, double x, double y, double w, double h)
{
    int id = s->n_clips++;
    fprintf(s->f,
            "<clipPath id=\"%s-clip%d\"><rect x=\"%.2f\" y=\"%.2f\" width=\"%.2f\" "
            "height=\"%.2f\"/></clipPath>\n<g clip-path=\"url(#%s-clip%d)\">\n",
            s->prefix, id, x, y, w, h, s->prefix, id);
}

void svg_group_end(svg_doc *s)
{
    fputs("</g>\n", s->f);
}

char *svg_finish(svg_doc *s, size_t *len)
{
    fputs("</svg>\n", s->f);
    int bad = ferror(s->f) != 0;
    if (fclose(s->f))
        bad = 1;
    char *out = s->buf;
    if (len)
        *len = s->len;
    free(s);
    if (bad) {
        free(out);
        return NULL;
    }
    return out;
}

void svg_free(svg_doc *s)
{
    if (!s)
        return;
    fclose(s->f);
    free(s->buf);
    free(s);
}
