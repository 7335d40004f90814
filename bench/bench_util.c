#include "bench/bench_util.h"

#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "planner/planner.h"

const char *const bench_study_materials[BENCH_N_STUDY] = {
    "nylon", "tungsten-carbide", "specular-black-phenolic", "blue-acrylic", "brass",
    "gold-metallic-paint", "white-diffuse-bball", "red-plastic", "alum-bronze", "pearl-paint",
};

double bench_now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int bench_plan_pairs(const char *name, struct brdf_pair **out, size_t *n)
{
    struct gonio_err err = {0};
    struct rig_profile rig;
    struct plan *p = NULL;
    if (rig_profile_load("default", &rig, &err) < 0 || plan_load(name, &rig, &p, &err) < 0) {
        fprintf(stderr, "bench: %s\n", err.msg);
        return -1;
    }
    *n = plan_count(p);
    *out = malloc(*n * sizeof **out);
    if (!*out) {
        plan_free(p);
        return -1;
    }
    for (size_t i = 0; i < *n; i++) {
        const struct plan_point *pt = plan_point(p, i);
        if (pt->out_of_plane)
            brdf_pair_spherical(pt->theta_i, pt->phi_i, pt->theta_o, pt->phi_o, &(*out)[i]);
        else
            brdf_pair_inplane(pt->theta_i, pt->theta_r, &(*out)[i]);
    }
    plan_free(p);
    return 0;
}
