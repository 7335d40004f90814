/* fit_abc on synthetic data: recovery of known parameters, the analytic
 * Jacobian against finite differences, six samples, all-diffuse data and
 * unusable samples. */
#include <string.h>

#include "brdf/abc.h"
#include "brdf/angles.h"
#include "fit/abc_problem.h"
#include "fit/fit.h"
#include "tests/gonio_test.h"
#include "tests/unit/fit/abc_synth.h"

/* Mean |log(1 + fhat cos) - log(1 + f cos)| over random out-of-plane pairs
 * up to 80 degrees: what the fit must reproduce beyond its samples. */
static double oop_log_error(const struct brdf_abc *fit, const struct brdf_abc *ref)
{
    srand(7);
    double s = 0;
    int m = 4000;
    for (int t = 0; t < m; t++) {
        struct brdf_pair g;
        brdf_pair_spherical(80.0 * rand() / RAND_MAX, 360.0 * rand() / RAND_MAX,
                            80.0 * rand() / RAND_MAX, 360.0 * rand() / RAND_MAX, &g);
        double a[3], b[3];
        brdf_abc_eval(fit, &g, a);
        brdf_abc_eval(ref, &g, b);
        for (int c = 0; c < 3; c++)
            s += fabs(log1p(a[c] * g.wi[2]) - log1p(b[c] * g.wi[2]));
    }
    return s / (3.0 * m);
}

static void test_recovers_known_parameters(void **state)
{
    (void)state;
    struct brdf_pair g[400];
    size_t n = ds2_grid(g);
    assert_true(n > 100 && n < 400);
    struct fit_sample s[400] = {0};
    synth(&truth, g, n, s);
    struct brdf_abc p;
    struct fit_info info;
    struct gonio_err err = {0};
    struct fit_options opt = fit_default_options();
    assert_int_equal(fit_abc(s, n, &opt, &p, &info, &err), 0);
    printf("fit: kd %g %g %g A %g %g %g B %g C %g eta %g cost %g it %d (%s)\n", p.kd[0],
           p.kd[1], p.kd[2], p.A[0], p.A[1], p.A[2], p.B, p.C, p.eta, info.cost,
           info.iterations, info.reason);
    assert_true(info.starts >= 1);
    assert_int_equal((int)info.dropped, 0);
    assert_true(info.cost < 1e-12);
    assert_true(oop_log_error(&p, &truth) < 1e-4);
    /* noise-free data of the model itself: every parameter is identifiable */
    for (int c = 0; c < 3; c++) {
        assert_rel_close(p.kd[c], truth.kd[c], 1e-3);
        assert_rel_close(p.A[c], truth.A[c], 1e-2);
    }
    assert_rel_close(p.B, truth.B, 2e-2);
    assert_rel_close(p.C, truth.C, 1e-2);
    assert_rel_close(p.eta, truth.eta, 1e-2);
}

static void test_jacobian_matches_finite_differences(void **state)
{
    (void)state;
    struct brdf_pair g[400];
    size_t n = ds2_grid(g);
    struct fit_sample s[400] = {0};
    synth(&truth, g, n, s);
    struct abc_problem pb;
    assert_int_equal(abc_problem_init(&pb, s, NULL, n), 0);
    /* at points away from the data so residuals are not zero */
    const struct brdf_abc at[] = {
        {.kd = {0.1, 0.3, 0.05}, .A = {5, 30, 2}, .B = 500, .C = 1.7, .eta = 2.2},
        {.kd = {0.01, 0.02, 0.03}, .A = {300, 200, 100}, .B = 2e5, .C = 0.3, .eta = 1.08},
        {.kd = {0.5, 0.5, 0.5}, .A = {1, 1, 1}, .B = 20, .C = 5, .eta = 12},
    };
    size_t nr = 3 * n;
    double *r0 = malloc(nr * sizeof *r0), *rp = malloc(nr * sizeof *rp);
    double *rm = malloc(nr * sizeof *rm), *J = malloc(nr * ABC_NPAR * sizeof *J);
    for (size_t a = 0; a < sizeof at / sizeof at[0]; a++) {
        double th[ABC_NPAR];
        abc_params_to_theta(&at[a], th);
        abc_problem_eval(&pb, th, r0, J);
        for (int j = 0; j < ABC_NPAR; j++) {
            double h = 1e-6, t = th[j];
            th[j] = t + h;
            abc_problem_eval(&pb, th, rp, NULL);
            th[j] = t - h;
            abc_problem_eval(&pb, th, rm, NULL);
            th[j] = t;
            double worst = 0;
            for (size_t i = 0; i < nr; i++) {
                double fd = (rp[i] - rm[i]) / (2 * h);
                double d = fabs(J[i * ABC_NPAR + (size_t)j] - fd) / (1e-6 + fabs(fd));
                if (d > worst)
                    worst = d;
            }
            if (worst > 1e-4)
                printf("point %zu parameter %d: worst relative difference %g\n", a, j, worst);
            assert_true(worst <= 1e-4);
        }
    }
    free(r0);
    free(rp);
    free(rm);
    free(J);
    abc_problem_free(&pb);
}

/* The solver's fused path (residuals with a cache, then J^T J, J^T r and
 * J u without forming J) against the dense residuals and Jacobian, for
 * each loss, with and without prior rows and sample weights. */
static void test_fused_path_matches_dense(void **state)
{
    (void)state;
    struct brdf_pair g[400];
    size_t n = ds2_grid(g);
    struct fit_sample s[400] = {0};
    synth(&truth, g, n, s);
    struct abc_prior_term prior = {.mean = {-2, -2, -2, 2, 2, 2, 7, 0, -3}};
    for (int i = 0; i < ABC_NPAR; i++)
        for (int j = 0; j < ABC_NPAR; j++)
            prior.W[i * ABC_NPAR + j] = i == j ? 0.3 + 0.1 * i : (i > j ? 0.05 * (i - j) : 0);
    const struct brdf_abc at[] = {
        {.kd = {0.1, 0.3, 0.05}, .A = {5, 30, 2}, .B = 500, .C = 1.7, .eta = 2.2},
        {.kd = {0.01, 0.02, 0.03}, .A = {300, 200, 100}, .B = 2e5, .C = 0.3, .eta = 1.08},
    };
    const enum fit_loss losses[] = {FIT_LOSS_LOG, FIT_LOSS_RELATIVE, FIT_LOSS_COS_L2};
    double weight[400];
    for (size_t k = 0; k < n; k++)
        weight[k] = k % 7 == 3 ? 0.0 : 0.25 + (double)(k % 5); /* some 0: a sample left out */
    for (int with_prior = 0; with_prior < 4; with_prior++)
        for (size_t l = 0; l < 3; l++) {
            struct abc_problem pb;
            assert_int_equal(abc_problem_init(&pb, s, NULL, n), 0);
            assert_int_equal(abc_problem_set_loss(&pb, losses[l]), 0);
            assert_int_equal(abc_problem_set_weights(&pb, with_prior >= 2 ? weight : NULL, NULL),
                             0);
            pb.prior = with_prior % 2 ? &prior : NULL;
            /* in-plane data repeat their geometry: fewer lobes than samples */
            assert_true(pb.nux < n && pb.nuv < n);
            size_t nr = abc_problem_nres(&pb);
            double *r = malloc(nr * sizeof *r), *rf = malloc(nr * sizeof *rf);
            double *J = malloc(nr * ABC_NPAR * sizeof *J), *Ju = malloc(nr * sizeof *Ju);
            struct abc_cache c;
            assert_int_equal(abc_cache_init(&c, &pb), 0);
            for (size_t a = 0; a < sizeof at / sizeof at[0]; a++) {
                double th[ABC_NPAR], u[ABC_NPAR];
                abc_params_to_theta(&at[a], th);
                abc_problem_eval(&pb, th, r, J);
                if (pb.sw) { /* a weight w scales the sample's residuals by sqrt(w) */
                    struct abc_problem pu = pb;
                    pu.sw = NULL;
                    abc_problem_eval(&pu, th, Ju, NULL);
                    for (size_t k = 0; k < 3 * n; k++)
                        assert_close(r[k], sqrt(weight[k / 3]) * Ju[k], 1e-12 * fabs(Ju[k]));
                }
                double cost = abc_problem_resid(&pb, th, rf, &c), ss = 0;
                for (size_t i = 0; i < nr; i++) {
                    assert_close(rf[i], r[i], 1e-12 * (1 + fabs(r[i])));
                    ss += r[i] * r[i];
                }
                assert_rel_close(cost, 0.5 * ss, 1e-12);
                double JTJ[ABC_NPAR * ABC_NPAR], gr[ABC_NPAR], g0[ABC_NPAR];
                abc_problem_normal(&pb, th, 1, NULL, gr, JTJ, &c);
                for (int i = 0; i < ABC_NPAR; i++) {
                    g0[i] = 0;
                    for (size_t k = 0; k < nr; k++)
                        g0[i] += J[k * ABC_NPAR + (size_t)i] * r[k];
                    u[i] = 0.1 * (i + 1);
                }
                for (int i = 0; i < ABC_NPAR; i++) {
                    double scale = 1e-300;
                    for (int j = 0; j < ABC_NPAR; j++) {
                        double d = 0;
                        for (size_t k = 0; k < nr; k++)
                            d += J[k * ABC_NPAR + (size_t)i] * J[k * ABC_NPAR + (size_t)j];
                        double si = 0, sj = 0;
                        for (size_t k = 0; k < nr; k++) {
                            si += J[k * ABC_NPAR + (size_t)i] * J[k * ABC_NPAR + (size_t)i];
                            sj += J[k * ABC_NPAR + (size_t)j] * J[k * ABC_NPAR + (size_t)j];
                        }
                        /* relative to the diagonal: the off-diagonal sums cancel */
                        assert_close(JTJ[i * ABC_NPAR + j], d, 1e-10 * sqrt(si * sj) + 1e-300);
                        if (i == j)
                            scale = sqrt(si * ss) + 1e-300;
                    }
                    assert_close(gr[i], g0[i], 1e-10 * scale);
                }
                /* J u from a fresh cache (computed at th on demand) */
                struct abc_cache c2;
                assert_int_equal(abc_cache_init(&c2, &pb), 0);
                abc_problem_normal(&pb, th, 0, u, Ju, NULL, &c2);
                for (size_t k = 0; k < nr; k++) {
                    double d = 0, mag = 0;
                    for (int j = 0; j < ABC_NPAR; j++) {
                        d += J[k * ABC_NPAR + (size_t)j] * u[j];
                        mag += fabs(J[k * ABC_NPAR + (size_t)j] * u[j]);
                    }
                    assert_close(Ju[k], d, 1e-12 * mag + 1e-300);
                }
                abc_cache_free(&c2);
            }
            abc_cache_free(&c);
            free(r);
            free(rf);
            free(J);
            free(Ju);
            abc_problem_free(&pb);
        }
}

/* The start search's linear score (kd and A solved per lobe) is the true
 * log loss at the kd and A it returns, weighted as the residuals are. */
static void test_linear_score_weighted(void **state)
{
    (void)state;
    struct brdf_pair g[400];
    size_t n = ds2_grid(g);
    struct fit_sample s[400] = {0};
    synth(&truth, g, n, s);
    double weight[400], spec[400], plain = 0;
    for (size_t k = 0; k < n; k++)
        weight[k] = k % 3 ? 0.1 : 3.0;
    for (int weighted = 0; weighted < 2; weighted++) {
        struct abc_problem pb;
        assert_int_equal(abc_problem_init(&pb, s, NULL, n), 0);
        assert_int_equal(abc_problem_set_weights(&pb, weighted ? weight : NULL, NULL), 0);
        struct brdf_abc p = {.B = 200, .C = 1.3, .eta = 3};
        double score = abc_linear_score(&pb, p.B, p.C, p.eta, p.kd, p.A, spec);
        for (int c = 0; c < 3; c++) {
            p.kd[c] = fmax(p.kd[c], 1e-300);
            p.A[c] = fmax(p.A[c], 1e-300);
        }
        double th[ABC_NPAR];
        abc_params_to_theta(&p, th);
        assert_rel_close(score, 2 * abc_problem_cost(&pb, th), 1e-9);
        if (weighted)
            assert_true(fabs(score - plain) > 1e-3 * plain); /* the weights count */
        plain = score;
        abc_problem_free(&pb);
    }
}

static void assert_same_doubles(const double *x, const double *y, size_t n)
{
    for (size_t i = 0; i < n; i++)
        assert_memory_equal(&x[i], &y[i], sizeof x[i]);
}

/* A subset of a problem (the held-out folds') is the problem built from
 * those samples, bit for bit: the per-sample terms, the distinct x and v.h
 * in their order of first appearance, and each sample's index into them. */
static void test_subset_equals_init(void **state)
{
    (void)state;
    struct brdf_pair g[400];
    size_t n = ds2_grid(g);
    struct fit_sample s[400] = {0};
    synth(&truth, g, n, s);
    struct abc_problem all, sub, ref;
    assert_int_equal(abc_problem_init(&all, s, NULL, n), 0);
    size_t rows[400], m = 0;
    for (size_t k = n; k-- > 0;) /* backwards, skipping some: a new order of first appearance */
        if (k % 5 != 2)
            rows[m++] = k;
    assert_int_equal(abc_problem_subset(&sub, &all, rows, m), 0);
    assert_int_equal(abc_problem_init(&ref, s, rows, m), 0);
    assert_int_equal(sub.n, m);
    assert_same_doubles(sub.x, ref.x, m);
    assert_same_doubles(sub.vh, ref.vh, m);
    assert_same_doubles(sub.gterm, ref.gterm, m);
    assert_same_doubles(sub.cosi, ref.cosi, m);
    assert_same_doubles(sub.f, ref.f, 3 * m);
    assert_same_doubles(sub.y, ref.y, 3 * m);
    assert_same_doubles(sub.iy, ref.iy, 3 * m);
    assert_int_equal(sub.nux, ref.nux);
    assert_int_equal(sub.nuv, ref.nuv);
    assert_true(sub.nux < m && sub.nuv < m); /* repeated geometry: the distinct values matter */
    assert_same_doubles(sub.ux, ref.ux, ref.nux);
    assert_same_doubles(sub.uvh, ref.uvh, ref.nuv);
    assert_memory_equal(sub.xi, ref.xi, m * sizeof *ref.xi);
    assert_memory_equal(sub.vi, ref.vi, m * sizeof *ref.vi);
    abc_problem_free(&all);
    abc_problem_free(&sub);
    abc_problem_free(&ref);
}

/* fit_data_scale steps by 10^6 at a median |f cos| of 10^1.5 (fit/fit.h):
 * with 21 distinct values of 7 samples, lows of them below that step and
 * the rest above, in scrambled orders, the scale follows the 11th smallest
 * exactly. */
static void test_data_scale_median(void **state)
{
    (void)state;
    for (size_t mul = 1; mul < 21; mul++) {
        if (mul % 3 == 0 || mul % 7 == 0)
            continue; /* j -> mul j mod 21 a permutation of 0..20 */
        for (int lows = 10; lows <= 11; lows++) {
            struct fit_sample s[7] = {0};
            for (size_t k = 0; k < 7; k++) {
                brdf_pair_inplane(0, 30, &s[k].g); /* cos theta_i = 1 */
                for (int c = 0; c < 3; c++) {
                    int v = (int)((mul * (3 * k + (size_t)c)) % 21);
                    /* rank v: below the step (1.3 .. 1.49) or above it (1.51 ..) */
                    double e = v < lows ? 1.49 - 0.01 * (lows - 1 - v) : 1.51 + 0.01 * (v - lows);
                    s[k].rgb[c] = pow(10.0, e);
                }
            }
            assert_true(fit_data_scale(s, NULL, 7) == (lows == 10 ? 1e6 : 1.0));
        }
    }
}

static void test_parametrisation_round_trip(void **state)
{
    (void)state;
    double th[ABC_NPAR];
    struct brdf_abc back;
    abc_params_to_theta(&truth, th);
    abc_theta_to_params(th, &back);
    for (int c = 0; c < 3; c++) {
        assert_rel_close(back.kd[c], truth.kd[c], 1e-12);
        assert_rel_close(back.A[c], truth.A[c], 1e-12);
    }
    assert_rel_close(back.B, truth.B, 1e-12);
    assert_rel_close(back.C, truth.C, 1e-12);
    assert_rel_close(back.eta, truth.eta, 1e-12);
    /* extreme parameters land on finite values with eta > 1 */
    const double ext[ABC_NPAR] = {-1e300, 1e300, NAN, 1e300, -1e300, 0, 1e300, 1e300, -1e300};
    abc_theta_to_params(ext, &back);
    for (int c = 0; c < 3; c++)
        assert_true(isfinite(back.kd[c]) && back.kd[c] > 0 && isfinite(back.A[c]) &&
                    back.A[c] > 0);
    assert_true(isfinite(back.B) && isfinite(back.C) && back.eta > 1 && isfinite(back.eta));
}

static void assert_finite_params(const struct brdf_abc *p)
{
    for (int c = 0; c < 3; c++) {
        assert_true(isfinite(p->kd[c]) && p->kd[c] > 0);
        assert_true(isfinite(p->A[c]) && p->A[c] > 0);
    }
    assert_true(isfinite(p->B) && p->B > 0);
    assert_true(isfinite(p->C) && p->C > 0);
    assert_true(isfinite(p->eta) && p->eta > 1);
}

static void test_six_samples_finite(void **state)
{
    (void)state;
    const double tr[6] = {-60, -20, 20, 28, 36, 60};
    const struct brdf_abc mats[] = {
        truth,
        {.kd = {0.003, 0.003, 0.004}, .A = {800, 600, 600}, .B = 9e4, .C = 1.7, .eta = 30},
        {.kd = {0.01, 0.03, 0.1}, .A = {1200, 1100, 1080}, .B = 2.5e5, .C = 1.08, .eta = 1.47},
    };
    for (size_t m = 0; m < 3; m++) {
        struct fit_sample s[6] = {0};
        for (int k = 0; k < 6; k++) {
            brdf_pair_inplane(30, tr[k], &s[k].g);
            brdf_abc_eval(&mats[m], &s[k].g, s[k].rgb);
        }
        struct brdf_abc p;
        struct fit_info info;
        struct gonio_err err = {0};
        assert_int_equal(fit_abc(s, 6, NULL, &p, &info, &err), 0);
        assert_finite_params(&p);
        assert_true(isfinite(info.cost));
        /* 18 residuals, 9 parameters: the six samples themselves are matched */
        assert_true(info.cost < 1e-3);
    }
}

static void test_all_diffuse_data(void **state)
{
    (void)state;
    struct brdf_abc lamb = {.kd = {0.5, 0.4, 0.3}, .A = {0, 0, 0}, .B = 1, .C = 1, .eta = 1.5};
    struct brdf_pair g[400];
    size_t n = ds2_grid(g);
    struct fit_sample s[400] = {0};
    synth(&lamb, g, n, s);
    struct brdf_abc p;
    struct fit_info info;
    struct gonio_err err = {0};
    assert_int_equal(fit_abc(s, n, NULL, &p, &info, &err), 0);
    assert_finite_params(&p);
    for (int c = 0; c < 3; c++)
        assert_rel_close(p.kd[c], lamb.kd[c], 1e-3);
    assert_true(oop_log_error(&p, &lamb) < 1e-3);
}

static void test_unusable_samples_dropped(void **state)
{
    (void)state;
    struct brdf_pair g[400];
    size_t n = ds2_grid(g);
    struct fit_sample s[400] = {0};
    synth(&truth, g, n, s);
    s[3].rgb[1] = NAN;
    s[10].rgb[0] = INFINITY;
    s[20].g.wi[2] = NAN;
    brdf_pair_spherical(95, 0, 30, 0, &s[30].g); /* below the horizon */
    s[40].rgb[2] = -1e6;                        /* 1 + f cos <= 0 */
    struct brdf_abc p;
    struct fit_info info;
    struct gonio_err err = {0};
    assert_int_equal(fit_abc(s, n, NULL, &p, &info, &err), 0);
    assert_int_equal((int)info.dropped, 5);
    assert_finite_params(&p);
    assert_true(oop_log_error(&p, &truth) < 1e-4);

    /* nothing usable: an error that says why */
    for (int k = 0; k < 6; k++)
        s[k].rgb[0] = NAN;
    assert_int_equal(fit_abc(s, 6, NULL, &p, &info, &err), -GONIO_EFIT);
    assert_int_equal(err.code, GONIO_EFIT);
    assert_non_null(strstr(err.msg, "0 usable samples of 6"));
}

static void test_warm_start_refines(void **state)
{
    (void)state;
    struct brdf_pair g[400];
    size_t n = ds2_grid(g);
    struct fit_sample s[400] = {0};
    synth(&truth, g, n, s);
    struct brdf_abc near = truth;
    near.B *= 1.3;
    near.C *= 0.9;
    near.kd[0] *= 1.2;
    struct fit_options opt = fit_default_options();
    opt.warm_start = &near;
    struct brdf_abc p;
    struct fit_info info;
    assert_int_equal(fit_abc(s, n, &opt, &p, &info, NULL), 0);
    assert_int_equal(info.starts, 1);
    assert_true(info.cost < 1e-12);
    assert_rel_close(p.B, truth.B, 2e-2);
}

/* Above 8000 samples the starts are searched on a seeded subset and the
 * winner refined on everything: that path must recover the truth too. */
static void test_large_input_subset_path(void **state)
{
    (void)state;
    size_t n = 30000;
    struct fit_sample *s = calloc(n, sizeof *s);
    unsigned seed = 99;
    printf("seed %u\n", seed);
    srand(seed);
    for (size_t k = 0; k < n; k++) {
        brdf_pair_spherical(80.0 * rand() / RAND_MAX, 360.0 * rand() / RAND_MAX,
                            80.0 * rand() / RAND_MAX, 360.0 * rand() / RAND_MAX, &s[k].g);
        brdf_abc_eval(&truth, &s[k].g, s[k].rgb);
    }
    s[5].rgb[0] = NAN;
    struct brdf_abc p;
    struct fit_info info;
    struct gonio_err err = {0};
    assert_int_equal(fit_abc(s, n, NULL, &p, &info, &err), 0);
    assert_int_equal((int)info.dropped, 1);
    assert_true(info.cost < 1e-10);
    assert_rel_close(p.B, truth.B, 2e-2);
    assert_rel_close(p.eta, truth.eta, 1e-2);
    assert_true(oop_log_error(&p, &truth) < 1e-4);
    free(s);
}

static void test_bad_options(void **state)
{
    (void)state;
    struct fit_sample s[3] = {0}; /* read (sorted) before the options are checked */
    struct brdf_abc p;
    struct fit_options opt = fit_default_options();
    opt.n_starts = 0;
    struct gonio_err err = {0};
    assert_true(fit_abc(s, 3, &opt, &p, NULL, &err) < 0);
    assert_non_null(strstr(err.msg, "n_starts"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_recovers_known_parameters),
        cmocka_unit_test(test_jacobian_matches_finite_differences),
        cmocka_unit_test(test_fused_path_matches_dense),
        cmocka_unit_test(test_linear_score_weighted),
        cmocka_unit_test(test_subset_equals_init),
        cmocka_unit_test(test_data_scale_median),
        cmocka_unit_test(test_parametrisation_round_trip),
        cmocka_unit_test(test_six_samples_finite),
        cmocka_unit_test(test_all_diffuse_data),
        cmocka_unit_test(test_unusable_samples_dropped),
        cmocka_unit_test(test_warm_start_refines),
        cmocka_unit_test(test_large_input_subset_path),
        cmocka_unit_test(test_bad_options),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
