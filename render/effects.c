/* The render effects: a directional light and a sky/ground environment. */
#include <math.h>
#include <stdint.h>

#include "render/effects_private.h"

#define FX_PI 3.14159265358979323846

void render_batch_flush(struct render_batch *b)
{
    if (!b->n)
        return;
    brdf_material_eval(b->m, b->pairs, b->n, b->f);
    b->stats->evaluations += (long)b->n;
    for (size_t j = 0; j < b->n; j++) {
        const double *f = &b->f[3 * j];
        /* No data (a MERL cell never measured) or a model's overflow at
         * grazing angles: that pair contributes nothing, the pixel stays
         * finite. */
        if (!isfinite(f[0]) || !isfinite(f[1]) || !isfinite(f[2])) {
            b->stats->no_data++;
            continue;
        }
        double *out = &b->accum[3 * b->pixel[j]];
        for (int c = 0; c < 3; c++)
            out[c] += b->weight[3 * j + c] * f[c];
    }
    b->n = 0;
}

void render_batch_add(struct render_batch *b, const double wi[3], const double wo[3],
                      size_t pixel, const double weight[3])
{
    if (b->n == RENDER_BATCH)
        render_batch_flush(b);
    brdf_pair_from_dirs(wi, wo, &b->pairs[b->n]);
    for (int c = 0; c < 3; c++)
        b->weight[3 * b->n + c] = weight[c];
    b->pixel[b->n] = pixel;
    b->n++;
}

static double dot3(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* The camera-frame direction d in the local frame of point i. */
static void to_local(const struct render_points *p, size_t i, const double d[3], double out[3])
{
    out[0] = dot3(&p->tangent[3 * i], d);
    out[1] = dot3(&p->bitangent[3 * i], d);
    out[2] = dot3(&p->normal[3 * i], d);
}

static const double to_camera[3] = {0, 0, 1};

/* Direct light: f(wi, wo) * E * cos(theta_i) where the light is above the
 * point's horizon; nothing (and no evaluation) where it is not. */
static void stage_direct(const struct render_scene *sc, const struct render_points *pts,
                         struct render_batch *b)
{
    const struct render_direct *d = &sc->direct;
    for (size_t i = 0; i < pts->n; i++) {
        double wi[3], wo[3];
        to_local(pts, i, d->direction, wi);
        if (!(wi[2] > 0))
            continue;
        to_local(pts, i, to_camera, wo);
        double w[3] = {d->irradiance[0] * wi[2], d->irradiance[1] * wi[2],
                       d->irradiance[2] * wi[2]};
        render_batch_add(b, wi, wo, pts->pixel[i], w);
    }
}

/* Environment: the fixed cosine-weighted directions of every point, so the
 * estimate is (pi / K) sum f L, smooth from pixel to pixel (the same set
 * everywhere: bias, not noise) and exact for a diffuse material under a
 * constant sky. */
static void stage_environment(const struct render_scene *sc, const struct render_points *pts,
                              struct render_batch *b)
{
    const struct render_environment *e = &sc->env;
    double scale = FX_PI / e->samples;
    static _Thread_local double dirs[RENDER_ENV_MAX_SAMPLES][3];
    for (int k = 0; k < e->samples; k++)
        render_env_direction(e, k, dirs[k]);
    for (size_t i = 0; i < pts->n; i++) {
        double wo[3];
        to_local(pts, i, to_camera, wo);
        const double *t = &pts->tangent[3 * i], *bt = &pts->bitangent[3 * i],
                     *n = &pts->normal[3 * i];
        for (int k = 0; k < e->samples; k++) {
            const double *d = dirs[k];
            double world[3], L[3];
            for (int c = 0; c < 3; c++)
                world[c] = d[0] * t[c] + d[1] * bt[c] + d[2] * n[c];
            render_env_radiance(e, world, L);
            if (L[0] == 0 && L[1] == 0 && L[2] == 0)
                continue;
            double w[3] = {L[0] * scale, L[1] * scale, L[2] * scale};
            render_batch_add(b, d, wo, pts->pixel[i], w);
        }
    }
}

render_stage_fn render_effect_stage(enum render_effect_kind kind)
{
    static const render_stage_fn stages[RENDER_FX_KINDS] = {
        [RENDER_FX_DIRECT] = stage_direct,
        [RENDER_FX_ENVIRONMENT] = stage_environment,
    };
    return (unsigned)kind < RENDER_FX_KINDS ? stages[kind] : NULL;
}

/* splitmix64's finaliser: the seed's two offsets. */
static uint64_t mix64(uint64_t z)
{
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

void render_env_direction(const struct render_environment *env, int k, double d[3])
{
    /* A rotated Fibonacci lattice on the unit disc: u1 stratified in
     * [k/K, (k+1)/K), u2 spread by the golden ratio; the seed shifts both. */
    uint64_t h1 = mix64((uint64_t)env->seed), h2 = mix64(h1);
    double r1 = (double)(h1 >> 11) * 0x1p-53, r2 = (double)(h2 >> 11) * 0x1p-53;
    double u1 = (k + r1) / env->samples;
    double u2 = fmod(k * 0.6180339887498949 + r2, 1.0);
    double rad = sqrt(u1), phi = 2 * FX_PI * u2;
    d[0] = rad * cos(phi);
    d[1] = rad * sin(phi);
    d[2] = sqrt(1 - u1);
}

void render_env_radiance(const struct render_environment *env, const double d[3], double L[3])
{
    for (int c = 0; c < 3; c++)
        L[c] = d[1] < 0 ? env->ground[c] : env->horizon[c] + (env->sky[c] - env->horizon[c]) * d[1];
}
