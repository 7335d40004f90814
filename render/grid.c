#include "render/grid.h"

#include <stddef.h>
#include <string.h>

void render_grid_layout(int cells, int cell, int gap, int columns, struct render_grid *g)
{
    if (columns <= 0 || columns > cells)
        columns = cells;
    g->cells = cells;
    g->cell = cell;
    g->gap = gap;
    g->columns = columns;
    g->rows = (cells + columns - 1) / columns;
    g->width = columns * cell + (columns - 1) * gap;
    g->height = g->rows * cell + (g->rows - 1) * gap;
}

void render_grid_origin(const struct render_grid *g, int index, int *x, int *y)
{
    *x = (index % g->columns) * (g->cell + g->gap);
    *y = (index / g->columns) * (g->cell + g->gap);
}

void render_grid_fill(const struct render_grid *g, const double fill[3], float *grid_rgb)
{
    size_t n = (size_t)g->width * (size_t)g->height;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            grid_rgb[3 * i + c] = (float)fill[c];
}

void render_grid_place(const struct render_grid *g, int index, const float *cell_rgb,
                       float *grid_rgb)
{
    int x0, y0;
    render_grid_origin(g, index, &x0, &y0);
    for (int y = 0; y < g->cell; y++)
        memcpy(&grid_rgb[3 * ((size_t)(y0 + y) * (size_t)g->width + (size_t)x0)],
               &cell_rgb[3 * (size_t)y * (size_t)g->cell], 3 * (size_t)g->cell * sizeof(float));
}
