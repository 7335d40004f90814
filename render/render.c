/* The sphere's geometry and the render driver: shading points, then the
 * scene's stages in the order of its file. */
#include "render/render.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/clock.h"
#include "render/effects_private.h"

int render_pixel_normal(int size, int x, int y, double n[3])
{
    double u = ((x + 0.5) / size * 2 - 1) * RENDER_EXTENT;
    double v = (1 - (y + 0.5) / size * 2) * RENDER_EXTENT;
    double r2 = u * u + v * v;
    if (!(r2 < 1))
        return 0;
    n[0] = u;
    n[1] = v;
    n[2] = sqrt(1 - r2); /* > 0: a rim pixel is grazing, never edge-on */
    return 1;
}

void render_tangent_frame(const double n[3], double t[3], double b[3])
{
    /* The rotation taking +z to n about the axis z x n (Duff et al. 2017's
     * branch for n.z > -1): continuous over the whole visible hemisphere,
     * its one singularity (n = -z) faces away from the camera, so the
     * environment's fixed directions never swirl across the picture. */
    double s = 1.0 / (1.0 + n[2]), xy = -n[0] * n[1] * s;
    t[0] = 1 - n[0] * n[0] * s;
    t[1] = xy;
    t[2] = -n[0];
    b[0] = xy;
    b[1] = 1 - n[1] * n[1] * s;
    b[2] = -n[1];
}

int render_sphere(const struct render_scene *sc, const brdf_material *m, int size, float *rgb,
                  struct render_stats *stats, struct gonio_err *err)
{
    if (size < RENDER_MIN_SIZE || size > RENDER_MAX_SIZE)
        return gonio_err_set(err, GONIO_EUSAGE, "render size %d outside %d..%d", size,
                             RENDER_MIN_SIZE, RENDER_MAX_SIZE);
    double t0 = gonio_monotonic_s();
    struct render_stats st = {.pixels = (long)size * size};
    size_t npix = (size_t)size * (size_t)size;
    double *accum = calloc(3 * npix, sizeof *accum);
    double *geo = malloc(9 * npix * sizeof *geo);
    size_t *pixel = malloc(npix * sizeof *pixel);
    struct render_batch *batch = malloc(sizeof *batch);
    int rc = 0;
    if (!accum || !geo || !pixel || !batch) {
        rc = gonio_err_set(err, ENOMEM, "render: out of memory for %dx%d pixels", size, size);
        goto done;
    }
    double *normal = geo, *tangent = geo + 3 * npix, *bitangent = geo + 6 * npix;
    size_t n = 0;
    for (int y = 0; y < size; y++)
        for (int x = 0; x < size; x++)
            if (render_pixel_normal(size, x, y, &normal[3 * n])) {
                render_tangent_frame(&normal[3 * n], &tangent[3 * n], &bitangent[3 * n]);
                pixel[n++] = (size_t)y * (size_t)size + (size_t)x;
            }
    st.sphere_pixels = (long)n;
    struct render_points pts = {n, normal, tangent, bitangent, pixel};

    /* The pipeline: only the stages the scene names. */
    render_stage_fn stages[RENDER_FX_KINDS];
    int n_stages = 0;
    for (int i = 0; i < sc->n_effects; i++)
        stages[n_stages++] = render_effect_stage(sc->effects[i]);

    batch->m = m;
    batch->accum = accum;
    batch->stats = &st;
    batch->n = 0;
    for (int s = 0; s < n_stages; s++) {
        stages[s](sc, &pts, batch);
        render_batch_flush(batch);
    }

    for (size_t i = 0; i < npix; i++)
        for (int c = 0; c < 3; c++)
            rgb[3 * i + c] = (float)sc->background[c];
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            /* sums of finite values can still overflow a float (or a
             * double, and inf - inf is NaN): keep every pixel finite */
            double v = accum[3 * pixel[i] + c];
            rgb[3 * pixel[i] + c] = isnan(v)        ? 0.0f
                                    : v > FLT_MAX  ? FLT_MAX
                                    : v < -FLT_MAX ? -FLT_MAX
                                                   : (float)v;
        }
    st.seconds = gonio_monotonic_s() - t0;
    if (stats)
        *stats = st;
done:
    free(accum);
    free(geo);
    free(pixel);
    free(batch);
    return rc;
}
