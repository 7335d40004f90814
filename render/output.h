/* A set of renderings written to a directory: one linear OpenEXR and one
 * sRGB PNG per material, optionally a grid of them, and render.json naming
 * every file (the layout in docs/render.md, which the report reads). */
#ifndef GONIO_RENDER_OUTPUT_H
#define GONIO_RENDER_OUTPUT_H

#include <stdio.h>

#include "brdf/material.h"
#include "common/err.h"
#include "render/scene.h"

struct render_item {
    const char *spec;         /* as given (nbrdf:nylon, model:FILE, ...) */
    const char *label;        /* NULL: the spec */
    const brdf_material *m;   /* opened by the caller (fit_material_open for model:) */
};

struct render_set_options {
    int size;      /* pixels per side of each image */
    int grid;      /* 1: also grid.exr/png, items[0] first (the truth) */
    int columns;   /* grid columns, 0 for one row */
    FILE *progress; /* a line per image, or NULL */
};

#define RENDER_GRID_GAP 4

/* The file stem of an item: its label (or spec) with every character
 * outside [A-Za-z0-9._] replaced by '-'. */
void render_file_stem(const char *label, char *out, size_t size);

/* Render every item and write the set into dir (created if needed). Stems
 * that repeat get -2, -3, ... Returns 0 or a negative code with err. */
int render_write_set(const char *dir, const struct render_scene *sc,
                     const struct render_item *items, int n,
                     const struct render_set_options *opt, struct gonio_err *err);

#endif
