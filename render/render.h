/* Render a material on a sphere: the picture `gonio render` writes.
 *
 * A unit sphere at the origin is seen down -z by an orthographic camera
 * whose square image spans [-RENDER_EXTENT, RENDER_EXTENT] on both axes.
 * Each pixel centre on the sphere is one shading point; its radiance is the
 * sum of what the scene's effects contribute (render/scene.h), each BRDF
 * value coming from brdf_material_eval in the pixel's tangent frame. Pixels
 * off the sphere are exactly the scene's background.
 *
 * The geometry below is public so that a reader (a test, a report) can
 * recompute any pixel from the material directly. */
#ifndef GONIO_RENDER_RENDER_H
#define GONIO_RENDER_RENDER_H

#include "brdf/material.h"
#include "common/err.h"
#include "render/scene.h"

#define RENDER_EXTENT 1.05
#define RENDER_MIN_SIZE 8
#define RENDER_MAX_SIZE 4096

struct render_stats {
    long pixels;        /* size * size */
    long sphere_pixels; /* pixels whose centre is on the sphere */
    long evaluations;   /* direction pairs evaluated by the material */
    long no_data;       /* of those, values without data or not finite: rendered black */
    double seconds;     /* wall time of the render */
};

/* Render m under sc into rgb[3 * size * size]: linear RGB floats, row-major,
 * top row first. No pixel is NaN or infinite. Returns 0, or a negative code
 * (-GONIO_EUSAGE for a size outside RENDER_MIN_SIZE..RENDER_MAX_SIZE,
 * -ENOMEM) with err filled. */
int render_sphere(const struct render_scene *sc, const brdf_material *m, int size, float *rgb,
                  struct render_stats *stats, struct gonio_err *err);

/* The unit normal (camera frame) at pixel (x, y) of a size x size image.
 * Returns 1 when the pixel centre lies on the sphere, 0 otherwise. */
int render_pixel_normal(int size, int x, int y, double n[3]);

/* The tangent frame of a normal with n.z > 0 (every pixel on the sphere):
 * the rotation that takes +z to n about z x n carries +x to t and +y to b,
 *   t = (1 - nx^2 / (1 + nz), -nx ny / (1 + nz), -nx),
 *   b = (-nx ny / (1 + nz), 1 - ny^2 / (1 + nz), -ny).
 * A camera-frame direction d has the local coordinates (d.t, d.b, d.n) the
 * material is evaluated in. */
void render_tangent_frame(const double n[3], double t[3], double b[3]);

/* The k-th of the environment's fixed directions, in the local frame
 * (z = normal): cosine-weighted, stratified in cos^2 theta, placed by the
 * seed. Every one has z > 0, so a shading point's environment radiance is
 * (pi / samples) * sum_k f(d_k, wo) * L(world d_k). */
void render_env_direction(const struct render_environment *env, int k, double d[3]);

/* Radiance of the environment along the camera-frame unit direction d. */
void render_env_radiance(const struct render_environment *env, const double d[3], double L[3]);

#endif
