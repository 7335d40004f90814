/* The study report: one self-contained HTML page (docs/report.md) with the
 * study's tables, its figures as inline SVG, in-plane slices of the fitted
 * models and the renderings as data URIs. The page references nothing
 * outside itself (no link, script, font or image file), so it opens the
 * same from a mail attachment, offline. */
#ifndef GONIO_REPORT_PAGE_H
#define GONIO_REPORT_PAGE_H

#include "common/err.h"

struct report_page_opts {
    const char *out_html;     /* NULL: DIR/report.html */
    const char *plots_dir;    /* each figure also as NAME.svg and NAME.png here; NULL: none */
    const char *slices_plans; /* comma-separated plans drawn as slices; NULL: ds2 and ds4
                                 (those present), else the study's first plan */
    int quiet;                /* no notes on stderr */
};

/* Read the study in dir (results.json, its capture folders, renders/) and
 * write the page (atomically). A missing or bad results.json fails
 * (GONIO_ENOTFOUND / GONIO_EBADDATA); a capture, model or rendering that
 * cannot be read is left out with a note on the page and on stderr. */
int report_write_page(const char *dir, const struct report_page_opts *o, struct gonio_err *err);

#endif
