/* latent_table: the latent model's acceptance table (docs/results-latent.md).
 *
 *   latent_table [--decoder FILE] [--markdown] [--starts N] [--iter N] [--lambda X]
 *                [--prior-scale B] [--bandwidth H] [--lr X] [--max-samples N]
 *                [--sets ds1,ds2,ds3,ds4,oop200k] [--bins] [MATERIAL...]
 *
 * For each material (default: the 10 held-out study materials) the NBRDF
 * network nbrdf:NAME is sampled at the points of the DS1..DS4 plans (built
 * by the planner against the default rig) and at the oop200k domain subset;
 * z is fitted to each sample set with the frozen decoder, and the fitted
 * material is scored against the network on the full domain and on the
 * in-plane domain (log error and relative RMSE, brdf/metrics.h). The
 * acceptance ratio is full-domain log error (DS1 fit) / (oop200k fit).
 * --bins also prints each fit's full-domain log error by theta_d and by the
 * distance of phi_d from the incidence plane: where an in-plane fit's error
 * comes from (docs/results-latent.md).
 * Needs the shared data (GONIO_SHARED or ../shared). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "brdf/domain.h"
#include "brdf/material.h"
#include "brdf/metrics.h"
#include "fit/latent.h"
#include "planner/planner.h"
#include "rig/rig.h"
#include "bench/bench_util.h"

enum { NSET = 5 };
static const char *set_names[NSET] = {"ds1", "ds2", "ds3", "ds4", "oop200k"};

/* Mean log residual |r| (and mean signed r: fhat above the truth > 0) over
 * the full domain, by theta_d (4 bins of 22.5 degrees) and by the distance of
 * phi_d from the incidence plane (phi_d = 0 or pi; 6 bins of 15 degrees). */
static int print_bins(const brdf_material *truth, const brdf_material *model,
                      const struct brdf_domain *full, const char *set)
{
    enum { ND = 4, NP = 6 };
    double *ft = malloc(full->n * 3 * sizeof *ft), *fm = malloc(full->n * 3 * sizeof *fm);
    if (!ft || !fm) {
        free(ft);
        free(fm);
        fprintf(stderr, "latent_table: out of memory\n");
        return -1;
    }
    brdf_material_eval(truth, full->pairs, full->n, ft);
    brdf_material_eval(model, full->pairs, full->n, fm);
    double abs_r[ND][NP] = {{0}}, sum_r[ND][NP] = {{0}}, cnt[ND][NP] = {{0}};
    for (size_t q = 0; q < full->n; q++) {
        const struct brdf_pair *p = &full->pairs[q];
        double pd = fabs(p->phi_d), off = pd < 90 * BRDF_DEG ? pd : 180 * BRDF_DEG - pd;
        int a = (int)(off / (90 * BRDF_DEG) * NP), b = (int)(p->theta_d / (90 * BRDF_DEG) * ND);
        a = a < NP ? a : NP - 1;
        b = b < ND ? b : ND - 1;
        for (int ch = 0; ch < 3; ch++) {
            double r = log1p(fm[3 * q + ch] * p->wi[2]) - log1p(ft[3 * q + ch] * p->wi[2]);
            abs_r[b][a] += fabs(r);
            sum_r[b][a] += r;
            cnt[b][a] += 1;
        }
    }
    printf("  %s fit, full-domain mean |r| (mean r) by theta_d (rows) and phi_d off the "
           "plane (columns 0-15, ..., 75-90 degrees):\n", set);
    for (int b = 0; b < ND; b++) {
        printf("    theta_d %2.0f-%2.0f:", b * 22.5, (b + 1) * 22.5);
        for (int a = 0; a < NP; a++)
            printf(" %.4f (%+.4f)", abs_r[b][a] / cnt[b][a], sum_r[b][a] / cnt[b][a]);
        printf("\n");
    }
    free(ft);
    free(fm);
    return 0;
}

/* What the command line asked for. */
struct table_opts {
    char dpath[4096];
    int markdown, bins, want[NSET];
    struct latent_fit_options fo;
    const char *const *mats; /* the materials, nm of them */
    int nm;
};

/* 0, or 2 after the usage line (an unknown option). */
static int parse_options(int argc, char **argv, struct table_opts *o)
{
    int first = 1;
    struct latent_fit_options *fo = &o->fo;
    while (first < argc && argv[first][0] == '-') {
        if (!strcmp(argv[first], "--starts") && first + 1 < argc) {
            fo->n_starts = atoi(argv[first + 1]);
            first += 2;
        } else if (!strcmp(argv[first], "--iter") && first + 1 < argc) {
            fo->max_iter = atoi(argv[first + 1]);
            first += 2;
        } else if (!strcmp(argv[first], "--lambda") && first + 1 < argc) {
            fo->lambda_z = atof(argv[first + 1]);
            first += 2;
        } else if (!strcmp(argv[first], "--prior-scale") && first + 1 < argc) {
            fo->prior_scale = atof(argv[first + 1]);
            first += 2;
        } else if (!strcmp(argv[first], "--bandwidth") && first + 1 < argc) {
            fo->bandwidth = atof(argv[first + 1]);
            first += 2;
        } else if (!strcmp(argv[first], "--max-samples") && first + 1 < argc) {
            fo->max_samples = (size_t)atol(argv[first + 1]);
            first += 2;
        } else if (!strcmp(argv[first], "--lr") && first + 1 < argc) {
            fo->lr = atof(argv[first + 1]);
            first += 2;
        } else if (!strcmp(argv[first], "--decoder") && first + 1 < argc) {
            snprintf(o->dpath, sizeof o->dpath, "%s", argv[first + 1]);
            first += 2;
        } else if (!strcmp(argv[first], "--sets") && first + 1 < argc) {
            for (int k = 0; k < NSET; k++) {
                const char *hit = strstr(argv[first + 1], set_names[k]);
                size_t len = strlen(set_names[k]);
                o->want[k] = hit && (hit == argv[first + 1] || hit[-1] == ',') &&
                             (hit[len] == 0 || hit[len] == ',');
            }
            first += 2;
        } else if (!strcmp(argv[first], "--bins")) {
            o->bins = 1;
            first++;
        } else if (!strcmp(argv[first], "--markdown")) {
            o->markdown = 1;
            first++;
        } else {
            fprintf(stderr, "usage: latent_table [--decoder FILE] [--markdown] [--starts N] "
                            "[--iter N] [--lambda X] [--prior-scale B] [--bandwidth H] [--lr X] "
                            "[--max-samples N] [--sets LIST] [--bins] [MATERIAL...]\n");
            return 2;
        }
    }
    o->mats = latent_heldout_materials;
    o->nm = 10;
    if (argc > first) {
        o->mats = (const char *const *)argv + first;
        o->nm = argc - first;
    }
    return 0;
}

/* What every material is fitted with and scored on: the decoder, the
 * sample points of each set (sets[4] is oop's) and the domains. */
struct table_data {
    latent_decoder *dec;
    struct brdf_pair *sets[NSET];
    size_t nset[NSET];
    struct brdf_domain oop, full, inpl;
};

/* 0, or -1 (said on stderr). */
static int load_data(const struct table_opts *o, struct table_data *d)
{
    struct gonio_err err = {0};
    d->dec = latent_decoder_load(o->dpath, &err);
    if (!d->dec) {
        fprintf(stderr, "latent_table: %s\n", err.msg);
        return -1;
    }
    for (int s = 0; s < 4; s++)
        if (bench_plan_pairs(set_names[s], &d->sets[s], &d->nset[s]) < 0)
            return -1;
    if (brdf_domain_oop_random(&d->oop, BRDF_DOMAIN_OOP200K_N, BRDF_DOMAIN_OOP200K_SEED,
                               &err) < 0 ||
        brdf_domain_full(&d->full, &err) < 0 || brdf_domain_inplane(&d->inpl, &err) < 0) {
        fprintf(stderr, "latent_table: %s\n", err.msg);
        return -1;
    }
    d->sets[4] = d->oop.pairs;
    d->nset[4] = d->oop.n;
    return 0;
}

static void free_data(struct table_data *d)
{
    for (int s = 0; s < 4; s++)
        free(d->sets[s]);
    brdf_domain_free(&d->oop);
    brdf_domain_free(&d->full);
    brdf_domain_free(&d->inpl);
    latent_decoder_free(d->dec);
}

static void print_header(const struct table_opts *o, const struct table_data *d)
{
    printf("decoder %s (crc %08x, %zu training materials, nz %d)\n", o->dpath,
           (unsigned)latent_decoder_crc(d->dec), latent_decoder_n_materials(d->dec),
           latent_decoder_nz(d->dec));
    printf("population prior: scale b %g, kernel bandwidth %.4f\n", o->fo.prior_scale,
           o->fo.bandwidth > 0 ? o->fo.bandwidth : latent_decoder_prior_bandwidth(d->dec));
    printf("samples: ds1 %zu, ds2 %zu, ds3 %zu, ds4 %zu, oop200k %zu; full domain %zu, "
           "in-plane domain %zu pairs\n\n",
           d->nset[0], d->nset[1], d->nset[2], d->nset[3], d->nset[4], d->full.n, d->inpl.n);
    if (o->markdown)
        printf("| material | set | n | fit s | full log | full rRMSE | in-plane log | "
               "in-plane rRMSE |\n|---|---|---:|---:|---:|---:|---:|---:|\n");
}

/* The sums over the materials for the closing summary. */
struct table_totals {
    double sum_ratio, sum_ds1, sum_oop, sum_mean;
    double sum_t[NSET];
    int pass;
    double ratio[64];
};

/* Fit z to material mi sampled at set s, score the fit and print its row;
 * its full-domain log error goes to *full_log. 0, or -1 (said on stderr). */
static int fit_set(const struct table_opts *o, const struct table_data *d,
                   const brdf_material *truth, int mi, int s, double *full_log,
                   struct table_totals *tot)
{
    struct gonio_err err = {0};
    size_t n = d->nset[s];
    struct fit_sample *smp = calloc(n, sizeof *smp);
    double *rgb = malloc(3 * n * sizeof *rgb);
    brdf_material_eval(truth, d->sets[s], n, rgb);
    for (size_t k = 0; k < n; k++) {
        smp[k].g = d->sets[s][k];
        memcpy(smp[k].rgb, rgb + 3 * k, sizeof smp[k].rgb);
    }
    double z[LATENT_MAX_NZ];
    struct latent_fit_info info;
    double t0 = bench_now_s();
    int rc = fit_latent(d->dec, smp, n, &o->fo, z, &info, &err);
    double t = bench_now_s() - t0;
    free(smp);
    free(rgb);
    if (rc < 0) {
        fprintf(stderr, "latent_table: %s %s: %s\n", o->mats[mi], set_names[s], err.msg);
        return -1;
    }
    brdf_material *model = latent_material(d->dec, z, "latent");
    struct brdf_errors ef, ei;
    brdf_errors_material(truth, model, &d->full, &ef, NULL);
    brdf_errors_material(truth, model, &d->inpl, &ei, NULL);
    if (o->bins && print_bins(truth, model, &d->full, set_names[s]) < 0)
        return -1;
    brdf_material_free(model);
    *full_log = ef.log;
    tot->sum_t[s] += t;
    if (o->markdown)
        printf("| %s | %s | %zu | %.2f | %.4f | %.4f | %.4f | %.4f |\n", o->mats[mi],
               set_names[s], n, t, ef.log, ef.rel_rmse, ei.log, ei.rel_rmse);
    else
        printf("%-24s %-8s n %6zu  fit %6.2f s  full log %.4f rRMSE %.4f  in-plane "
               "log %.4f rRMSE %.4f  (fit loss %.4f)\n",
               o->mats[mi], set_names[s], n, t, ef.log, ef.rel_rmse, ei.log, ei.rel_rmse,
               info.loss);
    fflush(stdout);
    return 0;
}

/* Material mi: a fit per wanted set, then its acceptance ratio (DS1 fit
 * against oop200k fit) beside the mean latent's error. 0, or -1. */
static int table_material(const struct table_opts *o, const struct table_data *d, int mi,
                          struct table_totals *tot)
{
    struct gonio_err err = {0};
    char spec[128];
    snprintf(spec, sizeof spec, "nbrdf:%s", o->mats[mi]);
    brdf_material *truth = brdf_material_open(spec, &err);
    if (!truth) {
        fprintf(stderr, "latent_table: %s\n", err.msg);
        return -1;
    }
    double full_log[NSET];
    for (int s = 0; s < NSET; s++) {
        full_log[s] = NAN;
        if (!o->want[s])
            continue;
        if (fit_set(o, d, truth, mi, s, &full_log[s], tot) < 0)
            return -1;
    }
    /* the mean latent, for scale */
    brdf_material *mean = latent_material(d->dec, latent_decoder_mean_latent(d->dec), "mean");
    struct brdf_errors em;
    brdf_errors_material(truth, mean, &d->full, &em, NULL);
    brdf_material_free(mean);
    brdf_material_free(truth);
    tot->ratio[mi < 64 ? mi : 63] = full_log[0] / full_log[4];
    tot->sum_ratio += full_log[0] / full_log[4];
    tot->sum_ds1 += full_log[0];
    tot->sum_oop += full_log[4];
    tot->sum_mean += em.log;
    tot->pass += full_log[0] <= 1.25 * full_log[4];
    if (!o->markdown)
        printf("%-24s acceptance: full log DS1 %.4f / oop200k %.4f = %.3f (%s); mean latent "
               "%.4f\n\n",
               o->mats[mi], full_log[0], full_log[4], full_log[0] / full_log[4],
               full_log[0] <= 1.25 * full_log[4] ? "ok" : "FAIL", em.log);
    return 0;
}

static void print_summary(const struct table_opts *o, const struct table_totals *tot)
{
    int nm = o->nm;
    printf("\n%s acceptance (full-domain log error, DS1 fit / oop200k fit, limit 1.25):\n",
           o->markdown ? "\n" : "");
    if (o->markdown)
        printf("| material | ratio |\n|---|---:|\n");
    for (int mi = 0; mi < nm && mi < 64; mi++)
        printf(o->markdown ? "| %s | %.3f |\n" : "  %-24s %.3f\n", o->mats[mi], tot->ratio[mi]);
    printf("\nmean full log error: DS1 fit %.4f, oop200k fit %.4f, mean latent %.4f; "
           "mean ratio %.3f; ratio of means %.3f; %d/%d within 1.25\n",
           tot->sum_ds1 / nm, tot->sum_oop / nm, tot->sum_mean / nm, tot->sum_ratio / nm,
           tot->sum_ds1 / tot->sum_oop, tot->pass, nm);
    printf("mean fit time per plan (s):");
    for (int s = 0; s < NSET; s++)
        printf(" %s %.2f", set_names[s], tot->sum_t[s] / nm);
    printf("\n");
}

int main(int argc, char **argv)
{
    struct table_opts o = {.want = {1, 1, 1, 1, 1}, .fo = latent_fit_default_options()};
    latent_decoder_default_path(o.dpath, sizeof o.dpath);
    if (parse_options(argc, argv, &o) != 0)
        return 2;
    struct table_data d = {0};
    if (load_data(&o, &d) < 0)
        return 1;
    print_header(&o, &d);
    struct table_totals tot = {0};
    for (int mi = 0; mi < o.nm; mi++)
        if (table_material(&o, &d, mi, &tot) < 0)
            return 1;
    print_summary(&o, &tot);
    free_data(&d);
    return 0;
}
