/* A grid of equal square images (ground truth next to each model's render):
 * cells left to right, wrapping after `columns`, separated by `gap` pixels
 * of a fill colour. */
#ifndef GONIO_RENDER_GRID_H
#define GONIO_RENDER_GRID_H

struct render_grid {
    int cells, cell, gap, columns, rows;
    int width, height; /* of the whole grid, pixels */
};

/* Lay out cells images of cell x cell pixels; columns <= 0 or more than
 * cells puts them all in one row. */
void render_grid_layout(int cells, int cell, int gap, int columns, struct render_grid *g);

/* Top-left pixel of cell index. */
void render_grid_origin(const struct render_grid *g, int index, int *x, int *y);

/* Fill the grid image (width x height interleaved RGB floats) with fill. */
void render_grid_fill(const struct render_grid *g, const double fill[3], float *grid_rgb);

/* Copy one cell image (cell x cell RGB floats) into its place. */
void render_grid_place(const struct render_grid *g, int index, const float *cell_rgb,
                       float *grid_rgb);

#endif
