#include "render/output.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "brdf/exr.h"
#include "common/paths.h"
#include "render/grid.h"
#include "render/png.h"
#include "render/render.h"
#include "render/tonemap.h"

void render_file_stem(const char *label, char *out, size_t size)
{
    size_t i = 0;
    for (; label[i] && i + 1 < size; i++) {
        char c = label[i];
        int ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                 c == '.' || c == '_';
        out[i] = ok ? c : '-';
    }
    out[i] = '\0';
    if (i == 0) /* never "" */
        snprintf(out, size, "image");
    else if (out[0] == '.') /* never a hidden file, never ".." */
        out[0] = '_';
}

/* Write one image as DIR/STEM.exr and DIR/STEM.png. */
static int write_pair(const char *dir, const char *stem, int w, int h, const float *rgb,
                      const struct render_scene *sc, struct gonio_err *err)
{
    char path[4096];
    uint8_t *srgb = malloc(3 * (size_t)w * (size_t)h);
    if (!srgb)
        return gonio_err_set(err, ENOMEM, "render: out of memory");
    int rc;
    if (snprintf(path, sizeof path, "%s/%s.exr", dir, stem) >= (int)sizeof path) {
        rc = gonio_err_set(err, ENAMETOOLONG, "%s/%s: path too long", dir, stem);
    } else if ((rc = brdf_exr_write_rgb(path, w, h, rgb, err)) == 0) {
        render_tonemap(rgb, (size_t)w * (size_t)h, sc->exposure, sc->curve, srgb);
        snprintf(path, sizeof path, "%s/%s.png", dir, stem);
        rc = render_png_write(path, w, h, srgb, err);
    }
    free(srgb);
    return rc;
}

static int write_manifest(const char *dir, json_t *root, struct gonio_err *err)
{
    char path[4096];
    if (snprintf(path, sizeof path, "%s/render.json", dir) >= (int)sizeof path)
        return gonio_err_set(err, ENAMETOOLONG, "%s: path too long", dir);
    char *text = json_dumps(root, JSON_INDENT(2));
    if (!text)
        return gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    size_t len = strlen(text);
    int rc = gonio_write_file_atomic(path, text, len, err);
    free(text);
    return rc;
}

int render_write_set(const char *dir, const struct render_scene *sc,
                     const struct render_item *items, int n,
                     const struct render_set_options *opt, struct gonio_err *err)
{
    int size = opt->size;
    if (n < 1 || size < RENDER_MIN_SIZE || size > RENDER_MAX_SIZE)
        return gonio_err_set(err, GONIO_EUSAGE, "render: %d images of %d pixels", n, size);
    int rc = gonio_mkdir_p(dir, err);
    if (rc < 0)
        return rc;
    size_t cell = 3 * (size_t)size * (size_t)size;
    float *images = malloc((size_t)n * cell * sizeof *images);
    char (*stems)[128] = calloc((size_t)n, sizeof *stems);
    json_t *root = json_object(), *list = json_array(), *fx = json_array();
    if (!images || !stems || !root || !list || !fx) {
        rc = gonio_err_set(err, ENOMEM, "render: out of memory");
        goto done;
    }
    json_object_set_new(root, "scene", json_string(sc->path[0] ? sc->path : "(built-in default)"));
    json_object_set_new(root, "size", json_integer(size));
    for (int i = 0; i < sc->n_effects; i++)
        json_array_append_new(fx, json_string(render_effect_name(sc->effects[i])));
    json_object_set(root, "effects", fx);
    json_object_set(root, "images", list);

    for (int i = 0; i < n && rc == 0; i++) {
        const char *label = items[i].label ? items[i].label : items[i].spec;
        char base[112];
        render_file_stem(label, base, sizeof base);
        snprintf(stems[i], sizeof stems[i], "%s", base);
        for (int k = 2, taken = 1; taken; k++) {
            taken = !strcmp(stems[i], "grid") || !strcmp(stems[i], "render");
            for (int j = 0; j < i && !taken; j++)
                taken = !strcmp(stems[j], stems[i]);
            if (taken)
                snprintf(stems[i], sizeof stems[i], "%s-%d", base, k);
        }
        struct render_stats st;
        float *img = images + (size_t)i * cell;
        if ((rc = render_sphere(sc, items[i].m, size, img, &st, err)) < 0 ||
            (rc = write_pair(dir, stems[i], size, size, img, sc, err)) < 0)
            break;
        if (opt->progress)
            fprintf(opt->progress,
                    "render: %-28s %dx%d  %.2f s  %.0f px/s  %ld evaluations%s\n", label, size,
                    size, st.seconds, st.seconds > 0 ? st.sphere_pixels / st.seconds : 0.0,
                    st.evaluations, st.no_data ? "  (some without data: black)" : "");
        char exr[160], png[160];
        snprintf(exr, sizeof exr, "%s.exr", stems[i]);
        snprintf(png, sizeof png, "%s.png", stems[i]);
        json_array_append_new(
            list, json_pack("{s:s, s:s, s:s, s:s, s:I, s:I, s:I, s:f}", "label", label, "spec",
                            items[i].spec, "exr", exr, "png", png, "sphere_pixels",
                            (json_int_t)st.sphere_pixels, "evaluations",
                            (json_int_t)st.evaluations, "no_data", (json_int_t)st.no_data,
                            "seconds", st.seconds));
    }
    if (rc == 0 && opt->grid) {
        struct render_grid g;
        render_grid_layout(n, size, RENDER_GRID_GAP, opt->columns, &g);
        float *grid = malloc(3 * (size_t)g.width * (size_t)g.height * sizeof *grid);
        json_t *cells = json_array();
        if (!grid || !cells) {
            free(grid);
            json_decref(cells);
            rc = gonio_err_set(err, ENOMEM, "render: out of memory");
            goto done;
        }
        render_grid_fill(&g, sc->background, grid);
        for (int i = 0; i < n; i++) {
            render_grid_place(&g, i, images + (size_t)i * cell, grid);
            json_array_append_new(cells, json_string(items[i].label ? items[i].label
                                                                    : items[i].spec));
        }
        rc = write_pair(dir, "grid", g.width, g.height, grid, sc, err);
        free(grid);
        json_object_set_new(root, "grid",
                            json_pack("{s:s, s:s, s:i, s:i, s:i, s:i, s:o}", "exr", "grid.exr",
                                      "png", "grid.png", "columns", g.columns, "rows", g.rows,
                                      "cell", g.cell, "gap", g.gap, "cells", cells));
    }
    if (rc == 0)
        rc = write_manifest(dir, root, err);
done:
    json_decref(fx);
    json_decref(list);
    json_decref(root);
    free(stems);
    free(images);
    return rc;
}
