/* adaptive_sim: the adaptive policy (adaptive/adaptive.h) run in a loop
 * without the capture engine, against the true material, to tune it and
 * to check its claims (docs/adaptive.md).
 *
 *   adaptive_sim [--pool PLAN] [--model abc|latent|auto] [--budget-frac F | --budget S]
 *                [--target X] [--converge] [--gain-tol G] [--reference PLAN] [--nodes N]
 *                [--seed S] [--trace K] [--calibrate] [MATERIAL...]
 *
 * For each material (default: the 10 held-out study materials) nbrdf:NAME
 * (or a material spec with a colon, brdf/material.h) is the truth: a
 * sample is its noise-free value at the pool pair, and the rig clock adds
 * each point's move (with backlash), settle and the rig's fixed
 * integration, as plan_estimate does. The reference is the full DS1
 * plan: its rig time (plan_estimate) and the full-domain log error of the
 * model fitted to all of its samples. The adaptive run starts at home and
 * stops when the policy says (default budget: a quarter of DS1's rig
 * time; --reference takes another plan than DS1 as the reference); its
 * samples are fitted with the same model (auto: the one the policy
 * followed; its reference is the better of abc and latent) and scored on
 * the same seeded full-domain subset (--nodes, default 20000). Printed per
 * material: samples, rig time and its share of DS1's, errors and their
 * ratio, the policy's predicted error against the true one, the decision
 * time per point (mean and max) against the settle, and why it stopped.
 * --trace K also prints every K samples a line "trace MATERIAL samples
 * rig-time fit-error cv-error spread mapped predicted true
 * model-in-sample" (adaptive_private.h):
 * the evidence of the prediction and the true error of the model fitted
 * then. --calibrate runs every sixth material of the decoder's training
 * set (never a held-out one) instead of the held-out ones: the
 * prediction's calibration set (docs/adaptive.md). Needs the shared data (GONIO_SHARED or
 * ../shared). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "adaptive/adaptive.h"
#include "adaptive/adaptive_private.h"
#include "bench/bench_util.h"
#include "brdf/domain.h"
#include "brdf/material.h"
#include "brdf/metrics.h"
#include "fit/latent.h"
#include "fit/model_run.h"
#include "planner/planner.h"
#include "rig/motion.h"

struct cfg {
    const char *pool, *model, *reference;
    double budget_frac, budget_s, target, gain_tol;
    int converge, calibrate;
    size_t nodes, trace;
    uint64_t seed;
};

/* The model fitted to n samples, as a material; NULL with a message.
 * chosen: an adaptive policy chose the samples, so the fit weighs them by
 * their domain share, as a capture's final fit does (fit/models.h fit_data). */
static brdf_material *fit_model(const char *model, const latent_decoder *dec,
                                const struct fit_sample *s, size_t n, int chosen)
{
    struct gonio_err err = {0};
    if (strcmp(model, "latent") == 0) {
        double z[LATENT_MAX_NZ];
        struct latent_fit_info info;
        struct latent_fit_options lo = latent_fit_default_options();
        lo.domain_weights = chosen;
        if (fit_latent(dec, s, n, &lo, z, &info, &err) < 0) {
            fprintf(stderr, "adaptive_sim: latent fit of %zu samples: %s\n", n, err.msg);
            return NULL;
        }
        return latent_material_scaled(dec, z, info.scale, "latent");
    }
    struct brdf_abc p;
    struct fit_options fo = fit_default_options();
    fo.domain_weights = chosen;
    if (fit_abc(s, n, &fo, &p, NULL, &err) < 0) {
        fprintf(stderr, "adaptive_sim: abc fit of %zu samples: %s\n", n, err.msg);
        return NULL;
    }
    return brdf_abc_material(&p, "abc");
}

static double model_error(const char *model, const latent_decoder *dec,
                          const brdf_material *truth, const struct brdf_domain *dom,
                          const struct fit_sample *s, size_t n, int chosen, double *in_sample)
{
    brdf_material *m = fit_model(model, dec, s, n, chosen);
    if (!m)
        return NAN;
    struct brdf_errors e;
    if (in_sample)
        *in_sample = fit_sample_errors(m, s, n, &e, NULL) == 0 ? e.log : NAN;
    brdf_errors_material(truth, m, dom, &e, NULL);
    brdf_material_free(m);
    return e.log;
}

static void point_pair(const struct plan_point *pt, struct brdf_pair *p)
{
    if (pt->out_of_plane)
        brdf_pair_spherical(pt->theta_i, pt->phi_i, pt->theta_o, pt->phi_o, p);
    else
        brdf_pair_inplane(pt->theta_i, pt->theta_r, p);
}

/* The plan's samples of the truth, in plan order. */
static struct fit_sample *sample_plan(const struct plan *p, const brdf_material *truth)
{
    size_t n = plan_count(p);
    struct fit_sample *s = calloc(n, sizeof *s);
    if (!s)
        return NULL;
    for (size_t i = 0; i < n; i++) {
        point_pair(plan_point(p, i), &s[i].g);
        brdf_material_eval(truth, &s[i].g, 1, s[i].rgb);
    }
    return s;
}

static int run_material(const struct cfg *c, const char *name, const struct rig_profile *rig,
                        const struct plan *pool, const struct plan *ref,
                        const latent_decoder *dec, const struct brdf_domain *dom)
{
    struct gonio_err err = {0};
    char spec[256];
    snprintf(spec, sizeof spec, strchr(name, ':') ? "%s" : "nbrdf:%s", name);
    brdf_material *truth = brdf_material_open(spec, &err);
    if (!truth) {
        fprintf(stderr, "adaptive_sim: %s\n", err.msg);
        return -1;
    }
    struct plan_estimate est;
    plan_estimate(ref, rig, &est);
    struct fit_sample *ref_s = sample_plan(ref, truth), *pool_s = sample_plan(pool, truth);
    size_t n_pool = plan_count(pool);
    struct fit_sample *got = calloc(n_pool, sizeof *got);
    if (!ref_s || !pool_s || !got) {
        fprintf(stderr, "adaptive_sim: out of memory\n");
        return -1;
    }
    /* auto: the better of abc and latent on the reference */
    int is_auto = strcmp(c->model, "auto") == 0;
    double ref_err = model_error(is_auto ? "latent" : c->model, dec, truth, dom, ref_s,
                                 plan_count(ref), 0, NULL);
    if (is_auto)
        ref_err =
            fmin(ref_err, model_error("abc", dec, truth, dom, ref_s, plan_count(ref), 0, NULL));

    struct adaptive_options o = adaptive_default_options();
    o.model = c->model;
    o.budget_s = c->budget_s > 0 ? c->budget_s : c->budget_frac * est.total_s;
    o.target = c->target;
    o.converge = c->converge;
    if (c->gain_tol > 0)
        o.gain_tol = c->gain_tol;
    o.seed = c->seed;
    adaptive *a = adaptive_new(pool, rig, NULL, &o, &err);
    if (!a) {
        fprintf(stderr, "adaptive_sim: %s\n", err.msg);
        return -1;
    }
    struct rig_axes at = {0, 0, 0};
    struct adaptive_status st = {0};
    double clock = 0, dec_sum = 0, dec_max = 0;
    size_t n = 0;
    for (;;) {
        long i = adaptive_next(a, &at, clock, -1, &st, &err);
        if (i < -1) {
            fprintf(stderr, "adaptive_sim: %s: %s\n", name, err.msg);
            break;
        }
        dec_sum += st.decision_s;
        dec_max = fmax(dec_max, st.decision_s);
        if (c->trace && n >= 6 && n % c->trace == 0) {
            struct adaptive_evidence ev;
            adaptive_evidence(a, &ev);
            double in_sample = NAN;
            double te = model_error(is_auto ? st.model : c->model, dec, truth, dom, got, n, 1,
                                    &in_sample);
            printf("trace %s %zu %.1f %.5f %.5f %.5f %.5f %.5f %.5f %.5f\n", name, n, clock,
                   ev.fit_error, ev.cv_error, ev.spread, ev.mapped, st.predicted_error, te,
                   in_sample);
        }
        if (i < 0)
            break;
        const struct plan_point *pt = plan_point(pool, (size_t)i);
        double took =
            rig_move_time_backlash(rig, &at, &pt->ax) + rig->settle_s + rig->integration_s;
        clock += took;
        at = pt->ax;
        got[n++] = pool_s[i];
        /* as the engine does with each journalled sample: the point and
         * what it took (the rig's pace, for the budget's margin) */
        if (adaptive_add(a, (size_t)i, &pool_s[i], 0, &err) < 0 ||
            adaptive_observe(a, (size_t)i, rig->integration_s, took, &err) < 0) {
            fprintf(stderr, "adaptive_sim: %s: %s\n", name, err.msg);
            break;
        }
    }
    double e = model_error(is_auto ? st.model : c->model, dec, truth, dom, got, n, 1, NULL);
    printf("| %s | %zu | %.0f s | %.0f%% | %.4f | %.4f | %.2f | %.4f | %.2f | %.1f / %.1f ms "
           "| %s |\n", name, n, clock, 100 * clock / est.total_s, e, ref_err, e / ref_err,
           st.predicted_error, st.predicted_error / e, 1e3 * dec_sum / (double)(n + 1),
           1e3 * dec_max, st.stop);
    if (is_auto)
        printf("  auto: the policy followed %s; the final fit is that model's\n", st.model);
    fflush(stdout);
    adaptive_free(a);
    free(ref_s);
    free(pool_s);
    free(got);
    brdf_material_free(truth);
    return 0;
}

static int usage(void)
{
    fprintf(stderr, "usage: adaptive_sim [--pool PLAN] [--model abc|latent|auto] "
                    "[--budget-frac F | --budget S] [--target X] [--converge] [--gain-tol G] "
                    "[--nodes N] [--reference PLAN] [--seed S] [--trace K] [--calibrate] "
                    "[MATERIAL...]\n");
    return 2;
}

int main(int argc, char **argv)
{
    struct cfg c = {.pool = "ds1", .model = "abc", .reference = "ds1", .budget_frac = 0.25,
                    .nodes = 20000, .seed = 1};
    int k = 1;
    for (; k < argc && strncmp(argv[k], "--", 2) == 0; k++) {
        const char *opt = argv[k];
        if (strcmp(opt, "--converge") == 0 || strcmp(opt, "--calibrate") == 0) {
            *(opt[2] == 'c' && opt[3] == 'o' ? &c.converge : &c.calibrate) = 1;
            continue;
        }
        if (k + 1 >= argc)
            return usage();
        const char *v = argv[++k];
        if (strcmp(opt, "--pool") == 0)
            c.pool = v;
        else if (strcmp(opt, "--reference") == 0)
            c.reference = v;
        else if (strcmp(opt, "--model") == 0)
            c.model = v;
        else if (strcmp(opt, "--budget-frac") == 0)
            c.budget_frac = atof(v);
        else if (strcmp(opt, "--budget") == 0)
            c.budget_s = atof(v);
        else if (strcmp(opt, "--target") == 0)
            c.target = atof(v);
        else if (strcmp(opt, "--gain-tol") == 0)
            c.gain_tol = atof(v);
        else if (strcmp(opt, "--nodes") == 0)
            c.nodes = (size_t)atol(v);
        else if (strcmp(opt, "--seed") == 0)
            c.seed = (uint64_t)atoll(v);
        else if (strcmp(opt, "--trace") == 0)
            c.trace = (size_t)atol(v);
        else
            return usage();
    }
    struct gonio_err err = {0};
    struct rig_profile rig;
    struct plan *pool = NULL, *ref = NULL;
    struct brdf_domain dom = {0};
    if (rig_profile_load("default", &rig, &err) < 0 || plan_load(c.pool, &rig, &pool, &err) < 0 ||
        plan_load(c.reference, &rig, &ref, &err) < 0 ||
        brdf_domain_oop_random(&dom, c.nodes, 20030727, &err) < 0) {
        fprintf(stderr, "adaptive_sim: %s\n", err.msg);
        return 2;
    }
    latent_decoder *dec = NULL;
    if (strcmp(c.model, "latent") == 0 || strcmp(c.model, "auto") == 0) {
        char path[4096];
        latent_decoder_default_path(path, sizeof path);
        if (!(dec = latent_decoder_load(path, &err))) {
            fprintf(stderr, "adaptive_sim: %s\n", err.msg);
            return 2;
        }
    }
    printf("adaptive_sim: pool %s (%zu points), model %s, reference %s, %zu full-domain nodes, "
           "settle %.2f s\n", c.pool, plan_count(pool), c.model, c.reference, dom.n, rig.settle_s);
    printf("| material | samples | rig time | of ref | error | ref error | ratio | predicted | "
           "pred/true | decision mean / max | stop |\n|---|---:|---:|---:|---:|---:|---:|---:|"
           "---:|---:|---|\n");
    int rc = 0;
    if (c.calibrate) {
        char **names;
        size_t n_names;
        if (latent_default_training_set(&names, &n_names, &err) < 0) {
            fprintf(stderr, "adaptive_sim: %s\n", err.msg);
            return 2;
        }
        for (size_t m = 0; m < n_names; m += 6)
            rc |= run_material(&c, names[m], &rig, pool, ref, dec, &dom);
        latent_names_free(names, n_names);
    } else if (k == argc)
        for (size_t m = 0; m < BENCH_N_STUDY; m++)
            rc |= run_material(&c, bench_study_materials[m], &rig, pool, ref, dec, &dom);
    for (; k < argc; k++)
        rc |= run_material(&c, argv[k], &rig, pool, ref, dec, &dom);
    latent_decoder_free(dec);
    brdf_domain_free(&dom);
    plan_free(pool);
    plan_free(ref);
    return rc ? 1 : 0;
}
