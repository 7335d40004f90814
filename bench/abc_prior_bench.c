/* ABC fits per plan with and without the population prior, and with the
 * grid or the differential-evolution start: full-domain log error, the
 * posterior standard deviation of log B and the final cost, per material.
 * Usage: abc_prior_bench [--de] [MATERIAL...] (needs the shared data).
 * The prior leaves the fitted material out (fit/abc_prior.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "brdf/abc.h"
#include "brdf/angles.h"
#include "brdf/domain.h"
#include "brdf/material.h"
#include "brdf/metrics.h"
#include "brdf/published.h"
#include "fit/abc_prior.h"
#include "fit/abc_prior_private.h"
#include "bench/bench_util.h"
#include "fit/fit.h"

static int print_table(const struct brdf_pair *g, size_t n)
{
    struct fit_sample *s = calloc(n, sizeof *s);
    double *rgb = malloc(3 * n * sizeof *rgb);
    for (size_t i = 0; i < abc_prior_n_rows; i++) {
        char spec[256];
        snprintf(spec, sizeof spec, "nbrdf:%s", abc_prior_rows[i].name);
        struct gonio_err e = {0};
        brdf_material *mat = brdf_material_open(spec, &e);
        if (!mat) {
            fprintf(stderr, "%s\n", e.msg);
            return 1;
        }
        brdf_material_eval(mat, g, n, rgb);
        brdf_material_free(mat);
        for (size_t k = 0; k < n; k++) {
            s[k].g = g[k];
            memcpy(s[k].rgb, rgb + 3 * k, sizeof s[k].rgb);
        }
        struct brdf_abc p;
        if (fit_abc(s, n, NULL, &p, NULL, &e) < 0) {
            fprintf(stderr, "%s: %s\n", spec, e.msg);
            return 1;
        }
        printf("    {\"%s\", {%.6g, %.6g, %.6g, %.6g, %.6g, %.6g, %.6g, %.6g, %.6g}},\n",
               abc_prior_rows[i].name, p.kd[0], p.kd[1], p.kd[2], p.A[0], p.A[1], p.A[2], p.B,
               p.C, p.eta);
        fflush(stdout);
    }
    free(s);
    free(rgb);
    return 0;
}

int main(int argc, char **argv)
{
    struct fit_options opt = fit_default_options();
    int first = 1;
    if (argc > 1 && !strcmp(argv[1], "--de")) {
        opt.global = FIT_GLOBAL_DE;
        first = 2;
    }
    const char *const *mats = bench_study_materials;
    int nm = BENCH_N_STUDY;
    if (argc > first) {
        mats = (const char *const *)argv + first;
        nm = argc - first;
    }
    static const char *const plans[4] = {"ds1", "ds2", "ds3", "ds4"};
    struct brdf_pair *ds[4];
    size_t nds[4];
    for (int d = 0; d < 4; d++)
        if (bench_plan_pairs(plans[d], &ds[d], &nds[d]) < 0)
            return 1;
    if (argc > 1 && !strcmp(argv[1], "--table"))
        return print_table(ds[0], nds[0]);
    struct gonio_err e = {0};
    struct brdf_domain full;
    if (brdf_domain_full(&full, &e) < 0) {
        fprintf(stderr, "%s\n", e.msg);
        return 1;
    }
    printf("start search: %s; prior sigma %.3f, leave-one-out\n",
           opt.global == FIT_GLOBAL_DE ? "differential evolution" : "grid", FIT_PRIOR_SIGMA);
    printf("%-24s %-4s %8s %8s %9s %9s %8s %8s\n", "material", "plan", "abc", "prior",
           "abc_pred", "pri_pred", "abc_ms", "pri_ms");
    double worst[4] = {0};
    for (int m = 0; m < nm; m++) {
        char spec[256];
        snprintf(spec, sizeof spec, "nbrdf:%s", mats[m]);
        brdf_material *mat = brdf_material_open(spec, &e);
        struct fit_abc_prior prior;
        if (!mat || fit_abc_prior_build(spec, &prior, &e) < 0) {
            fprintf(stderr, "%s\n", e.msg);
            return 1;
        }
        if (getenv("PRIOR_SIGMA"))
            prior.sigma = atof(getenv("PRIOR_SIGMA"));
        struct brdf_abc pub;
        if (brdf_published_abc(mats[m], &pub, &e) == 0) {
            brdf_material *mm = brdf_abc_material(&pub, "pub");
            struct brdf_errors pe;
            if (brdf_errors_material(mat, mm, &full, &pe, &e) >= 0)
                printf("%-24s published ABC fit: full-domain log error %.4f\n", mats[m], pe.log);
            brdf_material_free(mm);
        }
        for (int d = getenv("ONLY_DS4") ? 3 : 0; d < 4; d++) {
            size_t n = nds[d];
            struct fit_sample *s = calloc(n, sizeof *s);
            double *rgb = malloc(3 * n * sizeof *rgb);
            brdf_material_eval(mat, ds[d], n, rgb);
            for (size_t k = 0; k < n; k++) {
                s[k].g = ds[d][k];
                memcpy(s[k].rgb, rgb + 3 * k, sizeof s[k].rgb);
            }
            struct brdf_abc p0, p1;
            struct fit_info i0, i1;
            double t0 = bench_now_s();
            int r0 = fit_abc(s, n, &opt, &p0, &i0, &e);
            double t1 = bench_now_s();
            int r1 = fit_abc_map(s, n, &opt, &prior, &p1, &i1, &e);
            double t2 = bench_now_s();
            double err0 = NAN, err1 = NAN;
            struct brdf_errors be;
            if (r0 == 0) {
                brdf_material *mm = brdf_abc_material(&p0, "abc");
                if (brdf_errors_material(mat, mm, &full, &be, &e) >= 0)
                    err0 = be.log;
                brdf_material_free(mm);
            }
            if (r1 == 0) {
                brdf_material *mm = brdf_abc_material(&p1, "abc");
                if (brdf_errors_material(mat, mm, &full, &be, &e) >= 0)
                    err1 = be.log;
                brdf_material_free(mm);
            }
            if (err1 > worst[d] || !isfinite(err1))
                worst[d] = err1;
            printf("%-24s ds%d  %8.4f %8.4f %9.3f %9.3f %8.1f %8.1f\n", mats[m], d + 1, err0,
                   err1, i0.sd.pred_log, i1.sd.pred_log, 1e3 * (t1 - t0), 1e3 * (t2 - t1));
            if (d == 3)
                printf("    prior fit: kd %.3g %.3g %.3g A %.3g %.3g %.3g B %.4g C %.3g eta %.3g\n",
                       p1.kd[0], p1.kd[1], p1.kd[2], p1.A[0], p1.A[1], p1.A[2], p1.B, p1.C,
                       p1.eta);
            fflush(stdout);
            free(s);
            free(rgb);
        }
        brdf_material_free(mat);
    }
    printf("worst full-domain log error with the prior: DS1 %.4f DS2 %.4f DS3 %.4f DS4 %.4f\n",
           worst[0], worst[1], worst[2], worst[3]);
    brdf_domain_free(&full);
    for (int d = 0; d < 4; d++)
        free(ds[d]);
    return 0;
}
