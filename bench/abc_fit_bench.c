/* abc_fit_bench: fit the ABC model to NBRDF materials sampled on DS1, DS4
 * and 200k random nodes of the full out-of-plane domain, and report the
 * full-domain log error and the fit time of each.
 *
 *   abc_fit_bench [--starts N | --naive] [MATERIAL...]
 *
 * (default: the 10 study materials). --naive skips the start search and
 * refines from one generic start (kd 0.1, A 1, B 100, C 1, eta 1.5), to show
 * what the grid and the multi-start buy.
 *
 * The 200k set is the oop200k reference plan's (brdf_domain_oop_random with
 * the plan's seed). Needs the shared data (GONIO_SHARED or ../shared). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "brdf/abc.h"
#include "brdf/angles.h"
#include "brdf/domain.h"
#include "brdf/material.h"
#include "bench/bench_util.h"
#include "fit/fit.h"

static double log_error(const struct brdf_abc *p, const struct brdf_pair *g, const double *ref,
                        size_t n)
{
    double s = 0;
    for (size_t k = 0; k < n; k++) {
        double f[3];
        brdf_abc_eval(p, &g[k], f);
        double ci = g[k].wi[2];
        for (int c = 0; c < 3; c++)
            s += fabs(log1p(f[c] * ci) - log1p(ref[3 * k + c] * ci));
    }
    return s / (3.0 * (double)n);
}

static int fit_set(const struct brdf_pair *g, const double *ref, size_t n,
                   const struct fit_options *opt, struct brdf_abc *p, double *t,
                   struct fit_info *info)
{
    struct fit_sample *s = calloc(n, sizeof *s);
    for (size_t k = 0; k < n; k++) {
        s[k].g = g[k];
        memcpy(s[k].rgb, ref + 3 * k, sizeof s[k].rgb);
    }
    struct gonio_err e = {0};
    double t0 = bench_now_s();
    int rc = fit_abc(s, n, opt, p, info, &e);
    *t = bench_now_s() - t0;
    free(s);
    if (rc < 0)
        fprintf(stderr, "fit failed: %s\n", e.msg);
    return rc;
}

static void print_params(const char *tag, const struct brdf_abc *p)
{
    printf("    %-5s kd %.4g %.4g %.4g  A %.4g %.4g %.4g  B %.4g  C %.4g  eta %.4g\n", tag,
           p->kd[0], p->kd[1], p->kd[2], p->A[0], p->A[1], p->A[2], p->B, p->C, p->eta);
}

int main(int argc, char **argv)
{
    struct fit_options opt = fit_default_options();
    int first = 1;
    static const struct brdf_abc generic = {
        .kd = {0.1, 0.1, 0.1}, .A = {1, 1, 1}, .B = 100, .C = 1, .eta = 1.5};
    if (argc > 2 && strcmp(argv[1], "--starts") == 0) {
        opt.n_starts = atoi(argv[2]);
        first = 3;
    } else if (argc > 1 && strcmp(argv[1], "--naive") == 0) {
        opt.warm_start = &generic;
        first = 2;
    }
    const char *const *mats = bench_study_materials;
    int nm = BENCH_N_STUDY;
    if (argc > first) {
        mats = (const char *const *)argv + first;
        nm = argc - first;
    }

    struct brdf_pair *ds1, *ds2, *ds3, *ds4;
    size_t n1, n2, n3, n4;
    if (bench_plan_pairs("ds1", &ds1, &n1) < 0 || bench_plan_pairs("ds2", &ds2, &n2) < 0 ||
        bench_plan_pairs("ds3", &ds3, &n3) < 0 || bench_plan_pairs("ds4", &ds4, &n4) < 0)
        return 1;
    struct brdf_domain fd;
    struct gonio_err ferr = {0};
    if (brdf_domain_full(&fd, &ferr) < 0) {
        fprintf(stderr, "%s\n", ferr.msg);
        return 1;
    }
    size_t nf = fd.n;
    const struct brdf_pair *full = fd.pairs;
    /* the oop200k reference plan's nodes (brdf/domain.h) */
    struct brdf_domain od;
    struct gonio_err derr = {0};
    if (brdf_domain_oop_random(&od, BRDF_DOMAIN_OOP200K_N, BRDF_DOMAIN_OOP200K_SEED, &derr) < 0) {
        fprintf(stderr, "%s\n", derr.msg);
        return 1;
    }
    size_t n200 = od.n;
    const struct brdf_pair *oop = od.pairs;
    printf("DS1 %zu, DS2 %zu, DS3 %zu pairs; full domain %zu nodes, oop200k %zu, starts %d\n",
           n1, n2, n3, nf, n200,
           opt.n_starts);

    double *rf = malloc(3 * nf * sizeof *rf), *r1 = malloc(3 * n1 * sizeof *r1);
    double *r200 = malloc(3 * n200 * sizeof *r200), r4[18];
    double *r2 = malloc(3 * n2 * sizeof *r2), *r3 = malloc(3 * n3 * sizeof *r3);
    double sum1 = 0, sum200 = 0;
    for (int m = 0; m < nm; m++) {
        char spec[256];
        snprintf(spec, sizeof spec, "nbrdf:%s", mats[m]);
        struct gonio_err e = {0};
        brdf_material *mat = brdf_material_open(spec, &e);
        if (!mat) {
            fprintf(stderr, "%s\n", e.msg);
            return 1;
        }
        brdf_material_eval(mat, full, nf, rf);
        brdf_material_eval(mat, ds1, n1, r1);
        brdf_material_eval(mat, ds4, 6, r4);
        brdf_material_eval(mat, ds2, n2, r2);
        brdf_material_eval(mat, ds3, n3, r3);
        brdf_material_eval(mat, oop, n200, r200);
        brdf_material_free(mat);

        struct brdf_abc p1, p4, p200;
        struct fit_info i1, i4, i200;
        double t1, t4, t200;
        fit_set(ds1, r1, n1, &opt, &p1, &t1, &i1);
        fit_set(ds4, r4, 6, &opt, &p4, &t4, &i4);
        struct brdf_abc p2, p3;
        struct fit_info i2, i3;
        double t2, t3;
        fit_set(ds2, r2, n2, &opt, &p2, &t2, &i2);
        fit_set(ds3, r3, n3, &opt, &p3, &t3, &i3);
        fit_set(oop, r200, n200, &opt, &p200, &t200, &i200);
        double e1 = log_error(&p1, full, rf, nf), e4 = log_error(&p4, full, rf, nf);
        double e200 = log_error(&p200, full, rf, nf);
        sum1 += e1;
        sum200 += e200;
        printf("%-24s DS1 %.4f (%.3f s, %d it)  DS4 %.4f (%.3f s)  oop200k %.4f (%.2f s, %d it)\n",
               mats[m], e1, t1, i1.iterations, e4, t4, e200, t200, i200.iterations);
        printf("    DS2 %.4f (%.3f s)  DS3 %.4f (%.3f s)\n", log_error(&p2, full, rf, nf), t2,
               log_error(&p3, full, rf, nf), t3);
        printf("    reasons: DS1 %s; DS4 %s; oop %s\n", i1.reason, i4.reason, i200.reason);
        print_params("DS1", &p1);
        print_params("DS4", &p4);
        print_params("oop", &p200);
        fflush(stdout);
    }
    printf("mean full-domain log error: DS1 %.4f, oop200k %.4f, ratio %.3f\n", sum1 / nm,
           sum200 / nm, sum1 / sum200);
    free(ds1);
    free(ds2);
    free(ds3);
    free(ds4);
    free(r2);
    free(r3);
    brdf_domain_free(&fd);
    brdf_domain_free(&od);
    free(rf);
    free(r1);
    free(r200);
    return 0;
}
