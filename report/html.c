/* HTML output helpers (html.h). */
#include "report/html.h"

#include <math.h>
#include <string.h>

#include <glib.h>

void html_text(FILE *f, const char *t)
{
    for (; *t; t++) {
        switch (*t) {
        case '&': fputs("&amp;", f); break;
        case '<': fputs("&lt;", f); break;
        case '>': fputs("&gt;", f); break;
        case '"': fputs("&quot;", f); break;
        case '\'': fputs("&#39;", f); break;
        default:
            if ((unsigned char)*t >= 0x20 || *t == '\n' || *t == '\t')
                fputc(*t, f);
        }
    }
}

void html_inline_svg(FILE *f, const char *svg, size_t len)
{
    static const char ns[] = " xmlns=\"http://www.w3.org/2000/svg\"";
    const char *root = strstr(svg, "<svg");
    const char *at = root ? strstr(root, ns) : NULL;
    const char *gt = root ? strchr(root, '>') : NULL;
    if (at && gt && at < gt) {
        fwrite(svg, 1, (size_t)(at - svg), f);
        size_t skip = (size_t)(at - svg) + sizeof ns - 1;
        fwrite(svg + skip, 1, len - skip, f);
    } else {
        fwrite(svg, 1, len, f);
    }
}

int html_png_img(FILE *f, const unsigned char *png, size_t len, unsigned width,
                 unsigned height, const char *alt)
{
    gchar *b64 = g_base64_encode(png, len);
    if (!b64)
        return -1;
    fprintf(f, "<img width=\"%u\" height=\"%u\" alt=\"", width, height);
    html_text(f, alt);
    fprintf(f, "\" src=\"data:image/png;base64,%s\">", b64);
    g_free(b64);
    return 0;
}

void html_number(FILE *f, double v, int significant)
{
    if (!isfinite(v))
        fputs("–", f);
    else
        fprintf(f, "%.*g", significant, v);
}

void html_duration(FILE *f, double s)
{
    if (!isfinite(s))
        fputs("–", f);
    else if (s < 100)
        fprintf(f, "%.1f s", s);
    else if (s < 6000)
        fprintf(f, "%.1f min", s / 60);
    else if (s < 2 * 86400)
        fprintf(f, "%.1f h", s / 3600);
    else
        fprintf(f, "%.1f d", s / 86400);
}
