/* The renderings of a study (docs/study.md, docs/render.md): one grid per
 * material, the ground truth first, then one cell per fitted model of one
 * capture scene, in the study's row order (plan, then model), labelled
 * PLAN/MODEL. Read from DIR/results.json; models that cannot predict out of
 * the plane (full_skipped > 0: the in-plane MLP) and failed fits are left
 * out, since their sphere would be black. */
#ifndef GONIO_RENDER_STUDY_H
#define GONIO_RENDER_STUDY_H

#include <stdio.h>

#include "common/err.h"

struct render_study_cell {
    char label[128]; /* PLAN/MODEL */
    char spec[4200]; /* model:DIR/jobs/JOB_ID/MODEL.model */
};

struct render_study_material {
    char name[128];  /* the study's material name: the output folder */
    char truth[512]; /* material_spec */
    int n;
    struct render_study_cell *cells;
};

/* Read DIR/results.json and group its rows of capture scene `scene` (NULL:
 * the study's first scene) by material. *out is malloc'd (free with
 * render_study_free), *n materials. Returns 0, or -GONIO_ENOTFOUND /
 * -GONIO_EBADDATA naming the file, the row and the field. */
int render_study_read(const char *dir, const char *scene, struct render_study_material **out,
                      int *n, struct gonio_err *err);

void render_study_free(struct render_study_material *m, int n);

struct render_scene;

/* Read DIR/results.json as above and write each material's images and grid
 * to DIR/renders/MATERIAL/ (render_write_set; `columns` 0: up to 6 a row),
 * calling progress (may be NULL) with the images done and their total as it
 * starts and after each material's grid. Every material is opened before
 * anything is written. Returns 0 or a negative code with err filled. */
int render_study_write(const char *dir, const char *scene, const struct render_scene *sc,
                       int size, int columns, void (*progress)(void *user, int done, int total),
                       void *user, struct gonio_err *err);

#endif
