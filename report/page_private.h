/* Sections of the report page that live in their own files. */
#ifndef GONIO_REPORT_PAGE_PRIVATE_H
#define GONIO_REPORT_PAGE_PRIVATE_H

#include <stdio.h>

/* A note for the reader (and on stderr unless quiet): something the page
 * left out and why. */
void report_note(FILE *f, int quiet, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

/* The renderings of `gonio render` (docs/render.md) found under
 * DIR/renders: DIR/renders/render.json and DIR/renders/NAME/render.json.
 * A manifest with a grid is shown as its grid image with the cell labels,
 * one without as its single images. Returns the number of images shown. */
int report_page_renders(FILE *f, const char *dir, int quiet);

#endif
