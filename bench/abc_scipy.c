/* ABC fit in C against the same fit in SciPy (bench/abc_scipy.py), at
 * equal work.
 *
 * For each material: the DS1 samples of its NBRDF network in the fit's
 * canonical order (fit/sample_order.h), reduced to what the residuals need
 * (1 - n.h, v.h, G/(n.l n.v), n.l, RGB), and the start points of the grid
 * search, written to DIR/NAME.txt with the C fit's time, final cost and
 * status figures. The C time is the whole fit_abc call: validation, scale
 * and duplicates, canonical order, the grid search, the solves from the
 * five starts and the polish of the best, the covariance (sandwich when
 * weighted) and predictive sd, the rank and condition of the status, the
 * in-sample RMS and the five held-out refits. SciPy gets the grid's
 * starts, the canonical order and the predictive sd for free and does the
 * rest (abc_scipy.py says how), so the ratio is, if anything, generous to
 * SciPy. Times are the thread's CPU time, best of REPEATS: the machine is
 * shared, and CPU time is what the other load disturbs least.
 * Usage: abc_scipy DIR [MATERIAL...] (needs the shared data), then
 * python3 bench/abc_scipy.py DIR. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "brdf/abc.h"
#include "brdf/angles.h"
#include "brdf/material.h"
#include "fit/abc_problem.h"
#include "bench/bench_util.h"
#include "fit/fit.h"
#include "fit/sample_order.h"

#define REPEATS 20

static double cpu_now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: abc_scipy DIR [MATERIAL...]\n");
        return 2;
    }
    const char *dir = argv[1];
    const char *const *mats = bench_study_materials;
    int nm = BENCH_N_STUDY;
    if (argc > 2) {
        mats = (const char *const *)argv + 2;
        nm = argc - 2;
    }
    struct brdf_pair *g;
    size_t n;
    if (bench_plan_pairs("ds1", &g, &n) < 0)
        return 1;
    struct fit_sample *s = calloc(n, sizeof *s);
    double *rgb = malloc(3 * n * sizeof *rgb);
    struct fit_options opt = fit_default_options();
    for (int m = 0; m < nm; m++) {
        char spec[256], path[4096];
        snprintf(spec, sizeof spec, "nbrdf:%s", mats[m]);
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
        /* C: the best of REPEATS whole fits (the machine is shared) */
        double best_t = INFINITY;
        struct brdf_abc p;
        struct fit_info info;
        for (int r = 0; r < REPEATS; r++) {
            double t0 = cpu_now_s();
            if (fit_abc(s, n, &opt, &p, &info, &e) < 0) {
                fprintf(stderr, "%s: %s\n", spec, e.msg);
                return 1;
            }
            double t = cpu_now_s() - t0;
            if (t < best_t)
                best_t = t;
        }
        /* the starts fit_abc solved from: the grid's, on all samples in
         * their canonical order (DS1 is below the subset threshold) */
        struct fit_sample *sorted;
        unsigned char *no_flags;
        struct abc_problem pb;
        if (fit_samples_canonical(s, NULL, n, &sorted, &no_flags) < 0 ||
            abc_problem_init(&pb, sorted, NULL, n) < 0)
            return 1;
        free(sorted);
        double starts[32 * ABC_NPAR];
        int ns = abc_grid_starts(&pb, opt.n_starts, starts);
        snprintf(path, sizeof path, "%s/%s.txt", dir, mats[m]);
        FILE *f = fopen(path, "w");
        if (!f) {
            perror(path);
            return 1;
        }
        fprintf(f, "# material %s: n %zu starts %d c_time_s %.6f c_cost %.17g c_starts %d "
                   "c_iterations %d c_heldout %.17g c_insample %.17g c_rank %d c_cond %.17g "
                   "c_sd_logB %.17g\n",
                mats[m], n, ns, best_t, info.cost, info.starts, info.iterations,
                info.status.heldout, info.status.insample, info.status.rank, info.status.cond,
                info.sd.log_B);
        fprintf(f, "# limits logkd %g %g logA %g %g logB %g %g logC %g %g e %g %g eta_max %g\n",
                ABC_LOGKD_MIN, ABC_LOGKD_MAX, ABC_LOGA_MIN, ABC_LOGA_MAX, ABC_LOGB_MIN,
                ABC_LOGB_MAX, ABC_LOGC_MIN, ABC_LOGC_MAX, ABC_E_MIN, ABC_E_MAX, ABC_ETA_MAX);
        for (int k = 0; k < ns; k++) {
            fprintf(f, "start");
            for (int j = 0; j < ABC_NPAR; j++)
                fprintf(f, " %.17g", starts[k * ABC_NPAR + j]);
            fprintf(f, "\n");
        }
        for (size_t k = 0; k < n; k++)
            fprintf(f, "%.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", pb.x[k], pb.vh[k],
                    pb.gterm[k], pb.cosi[k], pb.f[3 * k], pb.f[3 * k + 1], pb.f[3 * k + 2]);
        fclose(f);
        abc_problem_free(&pb);
        printf("%-24s C: %.2f ms whole fit, cost %.10g (%d solves)\n", mats[m], 1e3 * best_t,
               info.cost, info.starts);
        fflush(stdout);
    }
    free(g);
    free(s);
    free(rgb);
    return 0;
}
