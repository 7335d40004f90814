/* Render speed (docs/render.md): pixels per second of `gonio render`'s
 * sphere for the embedded default, a published ABC fit and an NBRDF
 * network, under the direct-only and the default (light + environment)
 * scenes; CPU time of this process, so a loaded machine still gives the
 * cost, and each row's ratio to ABC's.
 *
 *   render_bench [SIZE]      (default 256) */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "brdf/material.h"
#include "render/render.h"
#include "render/scene.h"

static double cpu_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int main(int argc, char **argv)
{
    int size = argc > 1 ? atoi(argv[1]) : 256;
    static const char *const specs[] = {"abc:nylon", "nbrdf:nylon", "builtin:nylon"};
    static const char *const scenes[] = {"direct", "default"};
    float *img = malloc(3 * (size_t)size * (size_t)size * sizeof *img);
    if (!img)
        return 1;
    printf("%-14s %-8s %9s %12s %12s %12s %9s\n", "material", "scene", "cpu_s", "sphere_px/s",
           "evals/s", "evals/px", "vs_abc");
    for (size_t s = 0; s < 2; s++) {
        struct render_scene sc;
        struct gonio_err err = {0};
        if (render_scene_load(scenes[s], &sc, &err) < 0) {
            fprintf(stderr, "render_bench: %s\n", err.msg);
            return 1;
        }
        double abc_rate = 0;
        for (size_t i = 0; i < sizeof specs / sizeof specs[0]; i++) {
            brdf_material *m = brdf_material_open(specs[i], &err);
            if (!m) {
                printf("%-14s %-8s (skipped: %s)\n", specs[i], scenes[s], err.msg);
                continue;
            }
            struct render_stats st;
            double t0 = cpu_s();
            int rc = render_sphere(&sc, m, size, img, &st, &err);
            double dt = cpu_s() - t0;
            brdf_material_free(m);
            if (rc < 0) {
                fprintf(stderr, "render_bench: %s\n", err.msg);
                return 1;
            }
            double rate = st.sphere_pixels / dt;
            if (i == 0)
                abc_rate = rate;
            printf("%-14s %-8s %9.3f %12.0f %12.0f %12.1f %9.2f\n", specs[i], scenes[s], dt, rate,
                   st.evaluations / dt, (double)st.evaluations / st.sphere_pixels,
                   abc_rate > 0 ? rate / abc_rate : 0.0);
        }
    }
    free(img);
    return 0;
}
