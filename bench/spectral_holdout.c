/* The spectral acceptance line (docs/results-spectral.md): the spectral
 * MLP (fit/mlp.h, same shape and reciprocity twins as mlp-spectral) trained
 * on spectral:gonio sampled at the DS2 plan's pairs on 31 bands 400-700 nm,
 * with every 5th pair (plan index % 5 == 2, all bands) and every 4th band
 * (band index % 4 == 2, on the remaining pairs) held out. The network is
 * trained on the true material (brdf/spectral.h) or, given SPECTRA.CSV, on
 * the spectra of a DS2 capture (`gonio capture --offline --scene
 * spectral-lab --material spectral:gonio --plan ds2`), detector noise
 * included. Reports relative RMSE sqrt(sum w (fhat - f)^2 / sum w f^2),
 * w = cos theta_i, and the RMS log error log(1 + f c) of brdf/metrics.h, on
 * each set, against the true material and, for a capture, also against the
 * captured values.
 *
 * usage: spectral_holdout [max_epochs (0: default budget)] [seed] [SPECTRA.CSV] */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/angles.h"
#include "brdf/spectral.h"
#include "fit/mlp.h"
#include "fit/models.h"
#include "planner/planner.h"
#include "rig/rig.h"

#define NB 31
#define DEG (3.14159265358979323846 / 180.0)

enum { SET_TRAIN, SET_ANGLE, SET_BAND, SET_N };

struct acc { double se, sf, sl; size_t n; };

static void acc_add(struct acc *a, double fh, double f, double w)
{
    double d = fh - f, dl = log1p(fh * w) - log1p(f * w);
    a->se += w * d * d, a->sf += w * f * f, a->sl += dl * dl, a->n++;
}

/* The captured value of each (plan pair, band) into meas[np * NB]; NaN
 * where the capture has none. Returns 0, or -1 with a message. */
static int read_capture(const char *path, const struct plan *plan, const double *lam,
                        double *meas)
{
    struct gonio_err err = {0};
    struct fit_spectral_sample *s = NULL;
    size_t n = 0, np = plan_count(plan);
    if (fit_spectral_samples_read(path, &s, &n, &err) < 0) {
        fprintf(stderr, "spectral_holdout: %s\n", err.msg);
        return -1;
    }
    for (size_t k = 0; k < np * NB; k++)
        meas[k] = NAN;
    size_t matched = 0;
    for (size_t r = 0; r < n; r++) {
        int b = (int)lround((s[r].wavelength_nm - lam[0]) / 10.0);
        if (b < 0 || b >= NB || fabs(s[r].wavelength_nm - lam[b]) > 1e-6)
            continue;
        for (size_t i = 0; i < np; i++) {
            const struct plan_point *pt = plan_point(plan, i);
            if (fabs(pt->theta_i - s[r].theta_i) < 1e-9 && fabs(pt->theta_r - s[r].theta_r) < 1e-9) {
                meas[i * NB + b] = s[r].value;
                matched++;
                break;
            }
        }
    }
    free(s);
    if (matched == 0) {
        fprintf(stderr, "spectral_holdout: %s: no sample matches a DS2 pair on the 400-700 nm bands\n",
                path);
        return -1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    int max_epochs = argc > 1 ? atoi(argv[1]) : 0;
    uint64_t seed = argc > 2 ? strtoull(argv[2], NULL, 10) : 1;
    const char *capture = argc > 3 ? argv[3] : NULL;
    struct gonio_err err = {0};
    struct rig_profile rig;
    rig_profile_default(&rig);
    struct plan *plan = NULL;
    if (plan_load("ds2", &rig, &plan, &err) < 0) {
        fprintf(stderr, "spectral_holdout: %s\n", err.msg);
        return 1;
    }
    brdf_spectral *mat = brdf_spectral_open("spectral:gonio", &err);
    if (!mat) {
        fprintf(stderr, "spectral_holdout: %s\n", err.msg);
        return 1;
    }
    size_t np = plan_count(plan), cap = 2 * np * NB;
    double lam[NB];
    for (int b = 0; b < NB; b++)
        lam[b] = 400 + 10 * b;
    double *u = malloc(cap * 3 * sizeof *u), *f = malloc(cap * sizeof *f);
    double *c = malloc(cap * sizeof *c), *truth = malloc(np * NB * sizeof *truth);
    double *meas = malloc(np * NB * sizeof *meas);
    size_t *twin = malloc(cap * sizeof *twin);
    int *set = malloc(np * NB * sizeof *set);
    if (!u || !f || !c || !truth || !meas || !twin || !set)
        return 1;
    if (capture && read_capture(capture, plan, lam, meas) < 0)
        return 1;
    size_t m = 0, used_pairs = 0;
    for (size_t i = 0; i < np; i++) {
        const struct plan_point *pt = plan_point(plan, i);
        double ti = pt->theta_i, tr = pt->theta_r;
        for (int b = 0; b < NB; b++)
            set[i * NB + b] = -1;
        if (pt->out_of_plane || !(cos(ti * DEG) > 0) || fabs(tr) >= 90)
            continue;
        used_pairs++;
        struct brdf_pair p;
        brdf_pair_inplane(ti, tr, &p);
        brdf_spectral_eval(mat, &p, lam, NB, &truth[i * NB]);
        if (!capture)
            memcpy(&meas[i * NB], &truth[i * NB], NB * sizeof *meas);
        for (int b = 0; b < NB; b++) {
            if (isnan(meas[i * NB + b]))
                continue;
            int s = i % 5 == 2 ? SET_ANGLE : b % 4 == 2 ? SET_BAND : SET_TRAIN;
            set[i * NB + b] = s;
            if (s != SET_TRAIN)
                continue;
            /* as fit_mlp_spectral_fit: the reciprocal twin joins the rows */
            u[3 * m] = ti, u[3 * m + 1] = tr, u[3 * m + 2] = lam[b];
            f[m] = meas[i * NB + b], c[m] = cos(ti * DEG), twin[m] = SIZE_MAX;
            m++;
            double ti2 = tr >= 0 ? tr : -tr, tr2 = tr >= 0 ? ti : -ti;
            if (fabs(ti2 - ti) < 1e-9 && fabs(tr2 - tr) < 1e-9)
                continue;
            u[3 * m] = ti2, u[3 * m + 1] = tr2, u[3 * m + 2] = lam[b];
            f[m] = meas[i * NB + b], c[m] = cos(ti2 * DEG);
            twin[m] = m - 1, twin[m - 1] = m;
            m++;
        }
    }
    static const int widths[] = {3, 10, 10, 10, 1};
    struct fit_mlp net = {0};
    struct fit_mlp_train_report rep;
    struct fit_mlp_train_options to = fit_mlp_default_train_options();
    to.seed = seed;
    to.max_epochs = max_epochs;
    to.quiet = 1;
    to.twin = twin;
    if (fit_mlp_init(&net, 4, widths, &err) < 0 ||
        fit_mlp_train(&net, u, f, c, m, &to, &rep, &err) < 0) {
        fprintf(stderr, "spectral_holdout: %s\n", err.msg);
        return 1;
    }
    struct acc a[SET_N] = {{0}}, am[SET_N] = {{0}};
    for (size_t i = 0; i < np; i++) {
        const struct plan_point *pt = plan_point(plan, i);
        for (int b = 0; b < NB; b++) {
            int s = set[i * NB + b];
            if (s < 0)
                continue;
            double x[3] = {pt->theta_i, pt->theta_r, lam[b]}, z;
            fit_mlp_forward(&net, x, 1, &z);
            double fh = fit_mlp_value(z), w = cos(pt->theta_i * DEG);
            acc_add(&a[s], fh, truth[i * NB + b], w);
            acc_add(&am[s], fh, meas[i * NB + b], w);
        }
    }
    static const char *names[SET_N] = {"in-sample", "held-out angles", "held-out bands"};
    printf("spectral:gonio on ds2 (%s): %zu in-plane pairs x %d bands, seed %llu, epochs %d "
           "(best %d), %zu training rows with twins\n",
           capture ? capture : "true values", used_pairs, NB, (unsigned long long)seed,
           rep.epochs, rep.best_epoch, m);
    printf("%-16s %8s %10s %10s", "set", "values", "rRMSE", "RMS log");
    printf(capture ? " %14s %14s\n" : "\n", "rRMSE vs meas", "RMS log vs meas");
    for (int s = 0; s < SET_N; s++) {
        printf("%-16s %8zu %10.4f %10.5f", names[s], a[s].n, sqrt(a[s].se / a[s].sf),
               sqrt(a[s].sl / (double)a[s].n));
        if (capture)
            printf(" %14.4f %14.5f", sqrt(am[s].se / am[s].sf), sqrt(am[s].sl / (double)am[s].n));
        printf("\n");
    }
    fit_mlp_free(&net);
    free(u), free(f), free(c), free(truth), free(meas), free(twin), free(set);
    brdf_spectral_free(mat);
    plan_free(plan);
    return 0;
}
