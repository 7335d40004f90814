/* The ABC fit options beyond the default: the population prior
 * (abc-prior), the linear losses, the differential-evolution start and the
 * parameter uncertainties. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>

#include "brdf/abc.h"
#include "brdf/angles.h"
#include "brdf/domain.h"
#include "brdf/material.h"
#include "fit/abc_prior.h"
#include "fit/abc_prior_private.h"
#include "fit/abc_problem.h"
#include "fit/fit.h"
#include "tests/gonio_test.h"
#include "tests/unit/fit/abc_synth.h"

/* Leave-one-out: the named material's row is left out, and the means of
 * the full and reduced priors differ by exactly its contribution. */
static void test_prior_leaves_the_material_out(void **state)
{
    (void)state;
    struct fit_abc_prior all, loo, other;
    struct gonio_err err = {0};
    assert_int_equal(fit_abc_prior_build(NULL, &all, &err), 0);
    assert_int_equal(fit_abc_prior_build("nbrdf:brass", &loo, &err), 0);
    assert_int_equal(fit_abc_prior_build("nbrdf:no-such-material", &other, &err), 0);
    assert_int_equal((int)all.n_materials, (int)abc_prior_n_rows);
    assert_int_equal((int)loo.n_materials, (int)abc_prior_n_rows - 1);
    assert_string_equal(loo.excluded, "brass");
    assert_string_equal(other.excluded, "");
    const struct abc_prior_row *row = NULL;
    for (size_t i = 0; i < abc_prior_n_rows; i++)
        if (!strcmp(abc_prior_rows[i].name, "brass"))
            row = &abc_prior_rows[i];
    assert_non_null(row);
    struct brdf_abc p = {{row->v[0], row->v[1], row->v[2]},
                         {row->v[3], row->v[4], row->v[5]}, row->v[6], row->v[7], row->v[8]};
    for (int c = 0; c < 3; c++) {
        p.kd[c] = fmax(p.kd[c], FIT_PRIOR_FLOOR);
        p.A[c] = fmax(p.A[c], FIT_PRIOR_FLOOR);
    }
    double th[ABC_NPAR];
    abc_params_to_theta(&p, th);
    double na = (double)all.n_materials, nl = (double)loo.n_materials;
    for (int j = 0; j < ABC_NPAR; j++) {
        assert_close(all.mean[j] * na - loo.mean[j] * nl, th[j], 1e-9 * na);
        assert_close(all.mean[j], other.mean[j], 0);
        assert_true(all.cov[j * ABC_NPAR + j] > 0);
    }
}

/* Prior rows and the linear losses: analytic Jacobian against central
 * differences. */
static void test_jacobian_with_prior_and_losses(void **state)
{
    (void)state;
    struct brdf_pair g[400];
    struct fit_sample s[400] = {0};
    size_t n = ds2_grid(g);
    synth(&truth, g, n, s);
    struct abc_prior_term pt = {0};
    for (int i = 0; i < ABC_NPAR; i++) {
        pt.mean[i] = 0.3 * i - 1;
        for (int j = 0; j <= i; j++)
            pt.W[i * ABC_NPAR + j] = 0.01 * (1 + i + 2 * j) / (1 + i);
    }
    const enum fit_loss losses[] = {FIT_LOSS_LOG, FIT_LOSS_RELATIVE, FIT_LOSS_COS_L2};
    const struct brdf_abc at = {{0.1, 0.3, 0.05}, {5, 30, 2}, 500, 1.7, 2.2};
    for (int l = 0; l < 3; l++) {
        struct abc_problem pb;
        assert_int_equal(abc_problem_init(&pb, s, NULL, n), 0);
        assert_int_equal(abc_problem_set_loss(&pb, losses[l]), 0);
        pb.prior = &pt;
        size_t nr = abc_problem_nres(&pb);
        assert_int_equal((int)nr, (int)(3 * n + ABC_NPAR));
        double *r0 = malloc(nr * sizeof *r0), *rp = malloc(nr * sizeof *rp);
        double *rm = malloc(nr * sizeof *rm), *J = malloc(nr * ABC_NPAR * sizeof *J);
        double th[ABC_NPAR];
        abc_params_to_theta(&at, th);
        abc_problem_eval(&pb, th, r0, J);
        for (int j = 0; j < ABC_NPAR; j++) {
            double h = 1e-6, t = th[j];
            th[j] = t + h;
            abc_problem_eval(&pb, th, rp, NULL);
            th[j] = t - h;
            abc_problem_eval(&pb, th, rm, NULL);
            th[j] = t;
            double worst = 0, scale = 0;
            for (size_t i = 0; i < nr; i++)
                scale = fmax(scale, fabs(J[i * ABC_NPAR + (size_t)j]));
            for (size_t i = 0; i < nr; i++) {
                double fd = (rp[i] - rm[i]) / (2 * h);
                worst = fmax(worst, fabs(J[i * ABC_NPAR + (size_t)j] - fd) / (1e-6 * scale + fabs(fd)));
            }
            if (worst > 1e-4)
                printf("loss %d parameter %d: worst relative difference %g\n", l, j, worst);
            assert_true(worst <= 1e-4);
        }
        /* the prior rows are W (theta - mean) */
        for (int i = 0; i < ABC_NPAR; i++) {
            double v = 0;
            for (int j = 0; j < ABC_NPAR; j++)
                v += pt.W[i * ABC_NPAR + j] * (th[j] - pt.mean[j]);
            assert_close(r0[3 * n + (size_t)i], v, 1e-12);
        }
        free(r0);
        free(rp);
        free(rm);
        free(J);
        abc_problem_free(&pb);
    }
}

/* Exact data: every loss and both start searches recover the truth; the
 * DE start is deterministic for a seed. */
static void test_losses_and_de_recover_truth(void **state)
{
    (void)state;
    struct brdf_pair g[400];
    struct fit_sample s[400] = {0};
    size_t n = ds2_grid(g);
    synth(&truth, g, n, s);
    const enum fit_loss losses[] = {FIT_LOSS_LOG, FIT_LOSS_RELATIVE, FIT_LOSS_COS_L2};
    for (int l = 0; l < 3; l++)
        for (int gl = 0; gl < 2; gl++) {
            struct fit_options o = fit_default_options();
            o.loss = losses[l];
            o.global = gl ? FIT_GLOBAL_DE : FIT_GLOBAL_GRID;
            struct brdf_abc p;
            struct fit_info info;
            struct gonio_err err = {0};
            assert_int_equal(fit_abc(s, n, &o, &p, &info, &err), 0);
            printf("loss %d, %s: B %g C %g eta %g cost %g\n", l, gl ? "DE" : "grid", p.B, p.C,
                   p.eta, info.cost);
            assert_rel_close(p.B, truth.B, 2e-2);
            assert_rel_close(p.C, truth.C, 1e-2);
            assert_rel_close(p.eta, truth.eta, 1e-2);
            for (int c = 0; c < 3; c++)
                assert_rel_close(p.kd[c], truth.kd[c], 1e-3);
        }
    struct fit_options o = fit_default_options();
    o.global = FIT_GLOBAL_DE;
    o.seed = 7;
    struct brdf_abc a, b;
    assert_int_equal(fit_abc(s, n, &o, &a, NULL, NULL), 0);
    assert_int_equal(fit_abc(s, n, &o, &b, NULL, NULL), 0);
    assert_memory_equal(&a, &b, sizeof a);
    o.loss = (enum fit_loss)9;
    assert_int_equal(fit_abc(s, n, &o, &a, NULL, NULL), -GONIO_EUSAGE);
}

/* The reported standard deviations match the spread of fits to noisy
 * replicates: noise of sd 0.01 added to log(1 + f cos), 40 replicates. */
static void test_uncertainty_matches_replicate_spread(void **state)
{
    (void)state;
    struct brdf_pair g[400];
    struct fit_sample s0[400] = {0}, s[400] = {0};
    size_t n = ds2_grid(g);
    synth(&truth, g, n, s0);
    gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
    gsl_rng_set(rng, 3);
    const int R = 40;
    double sum[3] = {0}, sum2[3] = {0}, sd_mean[3] = {0};
    for (int r = 0; r < R; r++) {
        for (size_t k = 0; k < n; k++) {
            s[k] = s0[k];
            double ci = g[k].wi[2];
            for (int c = 0; c < 3; c++)
                s[k].rgb[c] = expm1(log1p(s0[k].rgb[c] * ci) + gsl_ran_gaussian(rng, 0.01)) / ci;
        }
        struct brdf_abc p;
        struct fit_info info;
        assert_int_equal(fit_abc(s, n, NULL, &p, &info, NULL), 0);
        double v[3] = {log(p.B), log(p.A[0]), p.eta};
        double sd[3] = {info.sd.log_B, info.sd.log_A[0], info.sd.eta};
        for (int i = 0; i < 3; i++) {
            assert_true(isfinite(sd[i]) && sd[i] > 0);
            sum[i] += v[i];
            sum2[i] += v[i] * v[i];
            sd_mean[i] += sd[i] / R;
        }
    }
    gsl_rng_free(rng);
    const char *names[3] = {"log B", "log A_r", "eta"};
    for (int i = 0; i < 3; i++) {
        double m = sum[i] / R, emp = sqrt((sum2[i] - R * m * m) / (R - 1));
        printf("%s: replicate sd %.4g, mean reported sd %.4g\n", names[i], emp, sd_mean[i]);
        /* 40 replicates estimate a sd to about +-11%: allow 35% */
        assert_true(fabs(sd_mean[i] / emp - 1) < 0.35);
    }
}

/* Many samples: the prior's pull vanishes (the DS2 fit moves by < 1e-3 in
 * every log parameter); six samples: it keeps the fit finite. */
static void test_prior_fades_with_samples(void **state)
{
    (void)state;
    struct brdf_pair g[400];
    struct fit_sample s[400] = {0};
    size_t n = ds2_grid(g);
    synth(&truth, g, n, s);
    struct fit_abc_prior prior;
    assert_int_equal(fit_abc_prior_build(NULL, &prior, NULL), 0);
    struct brdf_abc a, b;
    struct fit_info ia, ib;
    assert_int_equal(fit_abc(s, n, NULL, &a, &ia, NULL), 0);
    assert_int_equal(fit_abc_map(s, n, NULL, &prior, &b, &ib, NULL), 0);
    assert_close(log(a.B), log(b.B), 1e-3);
    assert_close(log(a.C), log(b.C), 1e-3);
    assert_close(a.eta, b.eta, 1e-3);
    for (int c = 0; c < 3; c++) {
        assert_close(log(a.kd[c]), log(b.kd[c]), 1e-3);
        assert_close(log(a.A[c]), log(b.A[c]), 1e-3);
    }
    char warn[256];
    assert_int_equal(fit_abc_prior_warning(&ib, n, warn, sizeof warn), 0);
    assert_string_equal(warn, "");
}

/* The target of abc-prior: DS4 (six in-plane pairs at theta_i 30) of the
 * shiny NBRDF materials where plain least squares explodes. Error: the
 * design's log error against the network on every 8th node of the full
 * reference domain (brdf/domain.h, 115k of 923,870 nodes, so the lobe is
 * weighted as in the acceptance figures). Bound 0.12 (the acceptance
 * target), and below plain ABC's. The too-few-samples warning fires on
 * each DS4 fit and not on tungsten-carbide's DS2-sized fit. */
static void test_ds4_shiny_materials(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    const char *names[] = {"tungsten-carbide", "specular-black-phenolic", "brass"};
    const double tr[6] = {-60, -20, 20, 28, 36, 60};
    struct brdf_pair g[6], big[400];
    for (int k = 0; k < 6; k++)
        brdf_pair_inplane(30, tr[k], &g[k]);
    size_t nbig = ds2_grid(big);
    struct brdf_domain full;
    struct gonio_err err = {0};
    assert_true(brdf_domain_full(&full, &err) >= 0);
    size_t nr = full.n / 8;
    struct brdf_pair *r = malloc(nr * sizeof *r);
    double *ref = malloc(3 * nr * sizeof *ref), *f = malloc(3 * nr * sizeof *f);
    for (size_t k = 0; k < nr; k++)
        r[k] = full.pairs[8 * k];
    brdf_domain_free(&full);
    for (size_t i = 0; i < 3; i++) {
        char spec[128];
        snprintf(spec, sizeof spec, "nbrdf:%s", names[i]);
        brdf_material *mat = brdf_material_open(spec, &err);
        assert_non_null(mat);
        struct fit_sample s[6] = {0}, sb[400] = {0};
        double v[18];
        static double vb[1200];
        brdf_material_eval(mat, g, 6, v);
        brdf_material_eval(mat, big, nbig, vb);
        brdf_material_eval(mat, r, nr, ref);
        brdf_material_free(mat);
        for (int k = 0; k < 6; k++) {
            s[k].g = g[k];
            memcpy(s[k].rgb, v + 3 * k, sizeof s[k].rgb);
        }
        for (size_t k = 0; k < nbig; k++) {
            sb[k].g = big[k];
            memcpy(sb[k].rgb, vb + 3 * k, sizeof sb[k].rgb);
        }
        struct fit_abc_prior prior;
        assert_int_equal(fit_abc_prior_build(spec, &prior, &err), 0);
        assert_string_equal(prior.excluded, names[i]);
        struct brdf_abc pp, pl;
        struct fit_info ip, il;
        assert_int_equal(fit_abc_map(s, 6, NULL, &prior, &pp, &ip, &err), 0);
        assert_int_equal(fit_abc(s, 6, NULL, &pl, &il, &err), 0);
        double e[2];
        for (int m = 0; m < 2; m++) {
            const struct brdf_abc *p = m ? &pl : &pp;
            double sum = 0;
            for (size_t k = 0; k < nr; k++) {
                brdf_abc_eval(p, &r[k], f + 3 * k);
                for (int c = 0; c < 3; c++)
                    sum += fabs(log1p(f[3 * k + c] * r[k].wi[2]) -
                                log1p(ref[3 * k + c] * r[k].wi[2]));
            }
            e[m] = sum / (3.0 * (double)nr);
        }
        char warn[256];
        int w = fit_abc_prior_warning(&ip, 6, warn, sizeof warn);
        printf("%s DS4: abc-prior %.4f, abc %.4f, predicted sd %.3f, warning %d\n", names[i],
               e[0], e[1], ip.sd.pred_log, w);
        assert_true(e[0] <= 0.12);
        assert_true(e[0] < e[1]);
        assert_int_equal(w, 1);
        if (i == 0) {
            struct fit_info ib;
            struct brdf_abc pb;
            assert_int_equal(fit_abc_map(sb, nbig, NULL, &prior, &pb, &ib, &err), 0);
            assert_int_equal(fit_abc_prior_warning(&ib, nbig, warn, sizeof warn), 0);
        }
    }
    free(r);
    free(ref);
    free(f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_prior_leaves_the_material_out),
        cmocka_unit_test(test_jacobian_with_prior_and_losses),
        cmocka_unit_test(test_losses_and_de_recover_truth),
        cmocka_unit_test(test_uncertainty_matches_replicate_spread),
        cmocka_unit_test(test_prior_fades_with_samples),
        cmocka_unit_test(test_ds4_shiny_materials),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
