/* The renderings section of the report (page_private.h). */
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <jansson.h>

#include "report/html.h"
#include "report/page_private.h"
#include "report/raster.h"

#define MAX_MANIFESTS 256

static int read_file(const char *path, unsigned char **data, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return -1;
    size_t cap = 65536, n = 0;
    unsigned char *buf = malloc(cap);
    while (buf) {
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap)
            break;
        unsigned char *p = cap < (256u << 20) ? realloc(buf, 2 * cap) : NULL;
        if (!p) {
            free(buf);
            buf = NULL;
            break;
        }
        buf = p;
        cap *= 2;
    }
    int bad = ferror(f);
    fclose(f);
    if (!buf || bad) {
        free(buf);
        return -1;
    }
    *data = buf;
    *len = n;
    return 0;
}

/* A manifest names files beside it; anything with a path is refused, so a
 * manifest cannot pull other files into the page. */
static int plain_name(const char *name)
{
    return name && *name && !strchr(name, '/') && strcmp(name, ".") && strcmp(name, "..");
}

/* One PNG of a manifest's folder as an <img>; 0 or -1 (noted). */
static int embed(FILE *f, const char *folder, const char *name, const char *caption, int quiet)
{
    char path[4400];
    if (!plain_name(name)) {
        report_note(f, quiet, "%s/render.json: image '%s' is not a file name beside the "
                    "manifest; left out", folder, name ? name : "(none)");
        return -1;
    }
    snprintf(path, sizeof path, "%.4000s/%.300s", folder, name);
    unsigned char *png = NULL;
    size_t len = 0;
    unsigned w, h;
    struct gonio_err err = {0};
    if (read_file(path, &png, &len)) {
        report_note(f, quiet, "%s: cannot be read; left out", path);
        return -1;
    }
    if (report_png_size(png, len, &w, &h, &err)) {
        report_note(f, quiet, "%s: %s; left out", path, err.msg);
        free(png);
        return -1;
    }
    fputs("<figure class=\"render\">", f);
    html_png_img(f, png, len, w, h, caption);
    fputs("<figcaption>", f);
    html_text(f, caption);
    fputs("</figcaption></figure>\n", f);
    free(png);
    return 0;
}

static int one_manifest(FILE *f, const char *folder, const char *title, int quiet)
{
    char path[4400];
    snprintf(path, sizeof path, "%.4000s/render.json", folder);
    json_error_t je;
    json_t *root = json_load_file(path, 0, &je);
    if (!root) {
        report_note(f, quiet, "%s: line %d: %s; left out", path, je.line, je.text);
        return 0;
    }
    fputs("<h3>", f);
    html_text(f, title);
    fputs("</h3>\n", f);
    int shown = 0;
    json_t *grid = json_object_get(root, "grid");
    if (json_is_object(grid)) {
        /* The grid with its labels in reading order (images carry no text). */
        char caption[2048] = "";
        size_t at = 0, i;
        json_t *cell;
        json_array_foreach(json_object_get(grid, "cells"), i, cell)
        {
            if (json_is_string(cell) && at < sizeof caption)
                at += (size_t)snprintf(caption + at, sizeof caption - at, "%s%s",
                                       i ? " | " : "", json_string_value(cell));
        }
        json_t *png = json_object_get(grid, "png");
        if (!embed(f, folder, json_is_string(png) ? json_string_value(png) : NULL,
                   caption[0] ? caption : "grid", quiet))
            shown++;
    } else {
        size_t i;
        json_t *img;
        json_array_foreach(json_object_get(root, "images"), i, img)
        {
            json_t *png = json_object_get(img, "png"), *label = json_object_get(img, "label"),
                   *spec = json_object_get(img, "spec");
            char caption[600];
            snprintf(caption, sizeof caption, "%s%s%s",
                     json_is_string(label) ? json_string_value(label) : "",
                     json_is_string(label) && json_is_string(spec) ? ": " : "",
                     json_is_string(spec) ? json_string_value(spec) : "");
            if (!embed(f, folder, json_is_string(png) ? json_string_value(png) : NULL,
                       caption, quiet))
                shown++;
        }
    }
    json_decref(root);
    return shown;
}

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

int report_page_renders(FILE *f, const char *dir, int quiet)
{
    char renders[4200], sub[4500], manifest[4600];
    snprintf(renders, sizeof renders, "%.4000s/renders", dir);
    struct stat st;
    if (stat(renders, &st) || !S_ISDIR(st.st_mode))
        return 0;
    int shown = 0;
    snprintf(manifest, sizeof manifest, "%s/render.json", renders);
    if (!stat(manifest, &st))
        shown += one_manifest(f, renders, "renders", quiet);
    DIR *d = opendir(renders);
    if (!d)
        return shown;
    char *names[MAX_MANIFESTS];
    size_t n = 0;
    struct dirent *e;
    while ((e = readdir(d)) && n < MAX_MANIFESTS) {
        if (e->d_name[0] == '.')
            continue;
        snprintf(manifest, sizeof manifest, "%s/%.255s/render.json", renders, e->d_name);
        if (!stat(manifest, &st) && S_ISREG(st.st_mode) && (names[n] = strdup(e->d_name)))
            n++;
    }
    closedir(d);
    qsort(names, n, sizeof *names, cmp_str);
    for (size_t i = 0; i < n; i++) {
        snprintf(sub, sizeof sub, "%s/%.255s", renders, names[i]);
        shown += one_manifest(f, sub, names[i], quiet);
        free(names[i]);
    }
    return shown;
}
