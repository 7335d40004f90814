/* Hard cases for the ABC fits (fit_abc and the abc-prior MAP fit): grazing
 * geometry, v.h -> 0, eta at both ends, very sharp and very bright lobes,
 * all-diffuse data, six samples, NaN and duplicated samples, and real
 * materials at the edges of the model (chrome, a fabric, white diffuse).
 *
 * Every case asks for finite parameters, a fit that returns, and an error
 * no worse than the bound stated next to it: 1e-9 for exact model data
 * (the fits reach 1e-11 or better), bounds derived from the noise for
 * noisy data, the measured figure plus 10 % for real materials. Synthetic truths are ABC
 * parameter sets evaluated with brdf_abc_eval (independent of the fitter's
 * residual code); errors are mean |log(1 + fhat cos) - log(1 + f cos)|
 * over the channels of pairs the fit did not see unless said otherwise. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/abc.h"
#include "brdf/angles.h"
#include "brdf/domain.h"
#include "brdf/material.h"
#include "fit/abc_prior.h"
#include "fit/fit.h"
#include "tests/gonio_test.h"

#define MAXS 2000
#define PI 3.14159265358979323846

/* In-plane grid in the style of the design's DS3 (theta_i step 30, diffuse
 * step 20, glossy step 3 within 15 degrees of the mirror), extended to the
 * given largest angle; written out here, not taken from the planner. */
static size_t grid(double tmax, struct brdf_pair *out)
{
    size_t n = 0;
    for (double ti = 0; ti <= tmax + 1e-9; ti += tmax / 3) {
        for (double tr = -tmax; tr <= tmax + 1e-9; tr += tmax / 4)
            if (fabs(tr - ti) > 15)
                brdf_pair_inplane(ti, tr, &out[n++]);
        for (double k = -15; k <= 15; k += 3)
            if (fabs(ti + k) <= tmax)
                brdf_pair_inplane(ti, ti + k, &out[n++]);
    }
    return n;
}

static size_t synth(const struct brdf_abc *p, const struct brdf_pair *g, size_t n,
                    struct fit_sample *s)
{
    for (size_t k = 0; k < n; k++) {
        s[k].g = g[k];
        brdf_abc_eval(p, &g[k], s[k].rgb);
    }
    return n;
}

static void assert_finite_params(const struct brdf_abc *p)
{
    for (int c = 0; c < 3; c++) {
        assert_true(isfinite(p->kd[c]) && p->kd[c] >= 0);
        assert_true(isfinite(p->A[c]) && p->A[c] >= 0);
    }
    assert_true(isfinite(p->B) && p->B > 0);
    assert_true(isfinite(p->C) && p->C > 0);
    assert_true(isfinite(p->eta) && p->eta > 1 && p->eta <= 40);
}

/* Largest relative difference between the nine parameters of p and q. */
static double param_rel(const struct brdf_abc *p, const struct brdf_abc *q)
{
    double x[9] = {p->kd[0], p->kd[1], p->kd[2], p->A[0], p->A[1], p->A[2], p->B, p->C, p->eta};
    double y[9] = {q->kd[0], q->kd[1], q->kd[2], q->A[0], q->A[1], q->A[2], q->B, q->C, q->eta};
    double m = 0;
    for (int k = 0; k < 9; k++)
        m = fmax(m, fabs(x[k] - y[k]) / fabs(y[k]));
    return m;
}

/* Error of the model p against rgb values ref at pairs g (3n values). */
static double log_err(const struct brdf_abc *p, const struct brdf_pair *g, const double *ref,
                      size_t n)
{
    double s = 0;
    for (size_t k = 0; k < n; k++) {
        double f[3];
        brdf_abc_eval(p, &g[k], f);
        for (int c = 0; c < 3; c++) {
            assert_true(isfinite(f[c]));
            s += fabs(log1p(f[c] * g[k].wi[2]) - log1p(ref[3 * k + c] * g[k].wi[2]));
        }
    }
    return s / (3.0 * (double)n);
}

/* Random pairs over the hemisphere up to tmax degrees (seeded). */
static size_t random_pairs(double tmax, unsigned seed, size_t n, struct brdf_pair *g)
{
    srand(seed);
    for (size_t k = 0; k < n; k++)
        brdf_pair_spherical(tmax * rand() / RAND_MAX, 360.0 * rand() / RAND_MAX,
                            tmax * rand() / RAND_MAX, 360.0 * rand() / RAND_MAX, &g[k]);
    return n;
}

/* Fit synthetic data of truth at the pairs g, then the error against the
 * truth at random pairs up to tmax. */
static double fit_synth(const struct brdf_abc *truth, const struct brdf_pair *g, size_t n,
                        double tmax, struct brdf_abc *p, struct fit_info *info)
{
    static struct fit_sample s[MAXS];
    static struct brdf_pair r[MAXS];
    static double ref[3 * MAXS];
    synth(truth, g, n, s);
    struct gonio_err err = {0};
    int rc = fit_abc(s, n, NULL, p, info, &err);
    if (rc)
        printf("fit_abc: %s\n", err.msg);
    assert_int_equal(rc, 0);
    assert_finite_params(p);
    assert_true(isfinite(info->cost));
    size_t m = random_pairs(tmax, 11, 1500, r);
    for (size_t k = 0; k < m; k++)
        brdf_abc_eval(truth, &r[k], ref + 3 * k);
    return log_err(p, r, ref, m);
}

/* Grazing: samples up to 89.9 degrees (n.l, n.v -> 0) and pairs with
 * l ~ -v at grazing (v.h -> 0). Bound: exact model data, so the fit must
 * give the truth's parameters to 1e-9 relative (measured 7e-16) and its
 * BRDF to 1e-9 out of plane up to 89 degrees (measured 2e-17). */
static void test_grazing_and_vh_to_zero(void **state)
{
    (void)state;
    static struct brdf_pair g[MAXS];
    size_t n = grid(89.9, g);
    const double az[] = {170, 175, 179.9, 180};
    for (int i = 0; i < 4; i++) {
        brdf_pair_spherical(89.9, 0, 89.9, az[i], &g[n++]);
        brdf_pair_spherical(89.0, 0, 89.5, az[i], &g[n++]);
    }
    const struct brdf_abc truth = {{0.2, 0.15, 0.1}, {5, 4, 3}, 800, 0.9, 1.6};
    struct brdf_abc p;
    struct fit_info info;
    double e = fit_synth(&truth, g, n, 89.0, &p, &info);
    printf("grazing: %zu samples, oop log error %.2e, parameters off by %.2e\n", n, e,
           param_rel(&p, &truth));
    assert_true(e <= 1e-9);
    assert_true(param_rel(&p, &truth) <= 1e-9);
}

/* eta -> 1 (Fresnel -> 0: the lobe vanishes) and eta near the upper bound
 * (F flat, metal-like), exact model data. Bounds: the BRDF to 1e-9 out of
 * plane (measured 1e-17) and the parameters to 1e-9 relative (measured
 * 1.5e-11 at eta 1.001, where A and eta nearly trade off, 8e-14 at 39). */
static void test_eta_extremes(void **state)
{
    (void)state;
    static struct brdf_pair g[MAXS];
    size_t n = grid(80, g);
    const struct brdf_abc t1 = {{0.3, 0.2, 0.1}, {50, 40, 30}, 2000, 1.0, 1.001};
    const struct brdf_abc t2 = {{0.001, 0.001, 0.001}, {30, 25, 20}, 5e4, 1.1, 39.0};
    struct brdf_abc p;
    struct fit_info info;
    double e1 = fit_synth(&t1, g, n, 80, &p, &info);
    printf("eta 1.001: oop log error %.2e, fitted eta %g, parameters off by %.2e\n", e1, p.eta,
           param_rel(&p, &t1));
    assert_true(e1 <= 1e-9);
    assert_true(param_rel(&p, &t1) <= 1e-9);
    double e2 = fit_synth(&t2, g, n, 80, &p, &info);
    printf("eta 39: oop log error %.2e, fitted eta %g, parameters off by %.2e\n", e2, p.eta,
           param_rel(&p, &t2));
    assert_true(e2 <= 1e-9);
    assert_true(param_rel(&p, &t2) <= 1e-9);
    /* beyond the bound (the published tungsten-carbide fit has ior 100):
     * the fit keeps eta inside (1, 40] and still fits, to 1e-3 (measured
     * 3.0e-4: not model data any more); F is so flat there that eta itself
     * is not determined (a fit lands near 5 with A lower) */
    const struct brdf_abc t3 = {{0.003, 0.003, 0.004}, {60, 50, 45}, 9e4, 1.7, 100.0};
    double e3 = fit_synth(&t3, g, n, 80, &p, &info);
    printf("eta 100: oop log error %.2e, fitted eta %g\n", e3, p.eta);
    assert_true(e3 <= 1e-3);
}

/* B = 1e7 with a peak 1e4 times the diffuse level: the lobe is 0.03 degrees
 * wide, so only the mirror samples see it. Exact model data: the fit
 * matches its samples to 1e-9 (measured 4e-17), the peak value at the
 * mirror to 1e-9 in log(1 + f cos), and the parameters to 1e-9 relative
 * (measured 6e-16). */
static void test_very_sharp_bright_lobe(void **state)
{
    (void)state;
    static struct brdf_pair g[MAXS];
    static struct fit_sample s[MAXS];
    static double ref[3 * MAXS];
    size_t n = grid(80, g);
    struct brdf_abc truth = {{0.1, 0.1, 0.1}, {1, 1, 1}, 1e7, 1.0, 1.5};
    /* scale A so that the mirror value at theta_i 30 is 1e4 x kd/pi */
    struct brdf_pair m;
    brdf_pair_inplane(30, 30, &m);
    double f0[3];
    brdf_abc_eval(&truth, &m, f0);
    double spec = f0[0] - truth.kd[0] / PI;
    for (int c = 0; c < 3; c++)
        truth.A[c] = 1e4 * truth.kd[c] / PI / spec;
    synth(&truth, g, n, s);
    for (size_t k = 0; k < n; k++)
        memcpy(ref + 3 * k, s[k].rgb, sizeof s[k].rgb);
    struct brdf_abc p;
    struct fit_info info;
    assert_int_equal(fit_abc(s, n, NULL, &p, &info, NULL), 0);
    assert_finite_params(&p);
    double e = log_err(&p, g, ref, n);
    double fm[3], ft[3];
    brdf_abc_eval(&p, &m, fm);
    brdf_abc_eval(&truth, &m, ft);
    double peak = fabs(log1p(fm[0] * m.wi[2]) / log1p(ft[0] * m.wi[2]) - 1);
    printf("B 1e7: parameters off by %.2e\n", param_rel(&p, &truth));
    printf("B 1e7: sample log error %.2e, mirror value %g vs %g, fitted B %g\n", e, fm[0],
           ft[0], p.B);
    assert_true(e <= 1e-9);
    assert_true(peak <= 1e-9);
    assert_true(param_rel(&p, &truth) <= 1e-9);
}

/* All diffuse (A = 0): the lobe parameters have no influence. Bound: 1e-9
 * out of plane (measured 9e-16), the lobe's share at the mirror below 1e-9
 * of the diffuse level, and the uncertainty of log B reported as
 * undetermined or large. */
static void test_all_diffuse(void **state)
{
    (void)state;
    static struct brdf_pair g[MAXS];
    size_t n = grid(80, g);
    const struct brdf_abc truth = {{0.5, 0.4, 0.3}, {0, 0, 0}, 100, 1, 1.5};
    struct brdf_abc p;
    struct fit_info info;
    double e = fit_synth(&truth, g, n, 80, &p, &info);
    struct brdf_pair m;
    brdf_pair_inplane(30, 30, &m);
    double f[3];
    brdf_abc_eval(&p, &m, f);
    printf("all diffuse: oop log error %.2e, mirror %g vs kd/pi %g, sd log B %g\n", e, f[0],
           p.kd[0] / PI, info.sd.log_B);
    assert_true(e <= 1e-9);
    assert_true(f[0] - p.kd[0] / PI <= 1e-9 * p.kd[0] / PI);
    assert_true(!(info.sd.log_B < 1.0)); /* INFINITY, NaN or large: not determined */
    /* and the status says so: B, C, eta shape a lobe that is not there */
    assert_int_equal(fit_status_code(&info.status), FIT_STATUS_UNDERDETERMINED);
}

/* Six samples (DS4's pairs) of exact model data: fit_abc gives the truth's
 * parameters to 1e-9 relative (measured 1.6e-14) and its samples to 1e-9
 * (18 residuals, 9 parameters); the prior fit, pulled towards the
 * population, stays within 1e-3 of them (measured 2.2e-4). */
static void test_six_samples(void **state)
{
    (void)state;
    struct brdf_pair g[6];
    const double tr[6] = {-60, -20, 20, 28, 36, 60};
    for (int k = 0; k < 6; k++)
        brdf_pair_inplane(30, tr[k], &g[k]);
    const struct brdf_abc truth = {{0.2, 0.15, 0.1}, {20, 15, 10}, 3000, 0.9, 1.5};
    struct fit_sample s[6] = {0};
    double ref[18];
    synth(&truth, g, 6, s);
    for (int k = 0; k < 6; k++)
        memcpy(ref + 3 * k, s[k].rgb, sizeof s[k].rgb);
    struct brdf_abc p, q;
    struct fit_info i1, i2;
    struct gonio_err err = {0};
    assert_int_equal(fit_abc(s, 6, NULL, &p, &i1, &err), 0);
    assert_finite_params(&p);
    struct fit_abc_prior prior;
    assert_int_equal(fit_abc_prior_build(NULL, &prior, &err), 0);
    assert_int_equal(fit_abc_map(s, 6, NULL, &prior, &q, &i2, &err), 0);
    assert_finite_params(&q);
    double e1 = log_err(&p, g, ref, 6), e2 = log_err(&q, g, ref, 6);
    printf("six samples: parameters off by %.2e\n", param_rel(&p, &truth));
    printf("six samples: sample log error %.2e (abc), %.2e (abc-prior), sd log B %g\n", e1, e2,
           i2.sd.log_B);
    assert_true(e1 <= 1e-9);
    assert_true(param_rel(&p, &truth) <= 1e-9);
    assert_true(e2 <= 1e-3);
    assert_true(isfinite(i2.sd.log_B));
}

/* NaN samples (MERL's no-data cells), below-horizon and exact duplicates
 * are dropped and counted; the fit equals the fit of the clean samples. */
static void test_nan_and_duplicates_dropped(void **state)
{
    (void)state;
    static struct brdf_pair g[MAXS];
    static struct fit_sample s[MAXS], clean[MAXS];
    size_t n = grid(80, g);
    const struct brdf_abc truth = {{0.2, 0.15, 0.1}, {20, 15, 10}, 3000, 0.9, 1.5};
    synth(&truth, g, n, clean);
    size_t m = 0, bad = 0;
    for (size_t k = 0; k < n; k++) {
        s[m++] = clean[k];
        if (k % 7 == 0) { /* a no-data cell: NaN value */
            s[m] = clean[k];
            s[m].rgb[1] = NAN;
            m++;
            bad++;
        }
        if (k % 5 == 0) { /* an exact duplicate */
            s[m++] = clean[k];
            bad++;
        }
    }
    s[m] = clean[0]; /* NaN geometry */
    s[m].g.wi[0] = NAN;
    m++;
    bad++;
    struct brdf_abc p, q;
    struct fit_info ip, iq;
    assert_int_equal(fit_abc(s, m, NULL, &p, &ip, NULL), 0);
    assert_int_equal(fit_abc(clean, n, NULL, &q, &iq, NULL), 0);
    printf("dropped %zu of %zu (expected %zu)\n", ip.dropped, m, bad);
    assert_int_equal((int)ip.dropped, (int)bad);
    assert_int_equal((int)iq.dropped, 0);
    assert_finite_params(&p);
    for (int c = 0; c < 3; c++)
        assert_rel_close(p.kd[c], q.kd[c], 1e-9);
    assert_rel_close(p.B, q.B, 1e-9);
    /* a distinct second measurement at the same geometry is data: kept */
    clean[n] = clean[0];
    clean[n].rgb[0] *= 1.01;
    assert_int_equal(fit_abc(clean, n + 1, NULL, &q, &iq, NULL), 0);
    assert_int_equal((int)iq.dropped, 0);
}

/* Real materials at the model's edges, DS3-sized grids of their NBRDF
 * networks: a metal (chrome), a fabric with back-scatter (beige-fabric) and
 * white diffuse. Bounds (full-hemisphere random pairs up to 80 degrees,
 * mostly away from the mirror): the measured errors (0.0037, 0.0029,
 * 0.0041) plus 10 %. */
static void test_real_edge_materials(void **state)
{
    (void)state;
    gonio_test_shared_or_skip();
    static struct brdf_pair g[MAXS], r[MAXS];
    static struct fit_sample s[MAXS];
    static double ref[3 * MAXS], rs[3 * MAXS];
    size_t n = grid(80, g);
    size_t m = random_pairs(80, 5, 1500, r);
    const struct {
        const char *spec;
        double bound;
    } mats[] = {{"nbrdf:chrome", 0.0041}, {"nbrdf:beige-fabric", 0.0032},
                {"nbrdf:white-diffuse-bball", 0.0045}};
    for (size_t i = 0; i < sizeof mats / sizeof mats[0]; i++) {
        struct gonio_err err = {0};
        brdf_material *mat = brdf_material_open(mats[i].spec, &err);
        if (!mat)
            printf("%s\n", err.msg);
        assert_non_null(mat);
        brdf_material_eval(mat, g, n, rs);
        brdf_material_eval(mat, r, m, ref);
        brdf_material_free(mat);
        for (size_t k = 0; k < n; k++) {
            s[k].g = g[k];
            memcpy(s[k].rgb, rs + 3 * k, sizeof s[k].rgb);
        }
        struct brdf_abc p;
        struct fit_info info;
        assert_int_equal(fit_abc(s, n, NULL, &p, &info, &err), 0);
        assert_finite_params(&p);
        double e = log_err(&p, r, ref, m);
        printf("%s: %zu samples, oop log error %.5f (bound %.4f), eta %g, B %g, %d iterations\n",
               mats[i].spec, n, e, mats[i].bound, p.eta, p.B, info.iterations);
        assert_true(e <= mats[i].bound);
    }
}


/* ---- scale, degenerate inputs, identifiability, noise ---- */

/* A standard normal deviate from a splitmix64 state (Box-Muller). */
static double gauss(uint64_t *st)
{
    double u1 = ((double)(brdf_splitmix64(st) >> 11) + 0.5) / 9007199254740992.0;
    double u2 = (double)(brdf_splitmix64(st) >> 11) / 9007199254740992.0;
    return sqrt(-2.0 * log(u1)) * cos(2.0 * PI * u2);
}

/* Samples of truth at g with Gaussian noise of sd sigma on log(1 + f cos
 * theta_i): the noise the log loss is the maximum-likelihood fit for. */
static void synth_noisy(const struct brdf_abc *truth, const struct brdf_pair *g, size_t n,
                        double sigma, uint64_t seed, struct fit_sample *s)
{
    uint64_t st = seed;
    synth(truth, g, n, s);
    for (size_t k = 0; k < n; k++) {
        double c = g[k].wi[2];
        for (int ch = 0; ch < 3; ch++)
            s[k].rgb[ch] = expm1(log1p(s[k].rgb[ch] * c) + sigma * gauss(&st)) / c;
    }
}

static const struct brdf_abc noisy_truth = {{0.2, 0.15, 0.1}, {20, 15, 10}, 3000, 0.9, 1.5};

/* Noisy data (5 %: exact model data would give the truth at any scale)
 * fitted from the data multiplied by k: the shape (B, C, eta) is the fit
 * of the data as they are to 1e-6 relative, kd and A are k times theirs
 * (fit_data_scale). x1e30 once returned eta on its bound. */
static void test_scale_invariance(void **state)
{
    (void)state;
    static struct brdf_pair g[MAXS];
    static struct fit_sample s[MAXS], t[MAXS];
    size_t n = grid(80, g);
    /* a shape the log loss weighs differently at other scales (brass-like) */
    const struct brdf_abc truth = {{0.02, 0.015, 0.01}, {300, 250, 200}, 2e5, 1.1, 2.7};
    synth_noisy(&truth, g, n, 0.05, 42, s);
    struct brdf_abc p1, pk;
    struct fit_info i1, ik;
    assert_int_equal(fit_abc(s, n, NULL, &p1, &i1, NULL), 0);
    assert_int_equal((int)i1.scale, 1); /* calibrated data are fitted as they are */
    const double ks[] = {1e12, 1e-12, 1e30, 1e-30};
    for (size_t i = 0; i < sizeof ks / sizeof ks[0]; i++) {
        for (size_t k = 0; k < n; k++) {
            t[k] = s[k];
            for (int c = 0; c < 3; c++)
                t[k].rgb[c] *= ks[i];
        }
        struct gonio_err err = {0};
        assert_int_equal(fit_abc(t, n, NULL, &pk, &ik, &err), 0);
        printf("x%g: B %.10g (%.10g), C %.10g, eta %.10g (%.10g), A_r/k %.10g, status %s; "
               "%d iterations (%d), %s (%s), cost %.10g (%.10g), scale %g\n",
               ks[i], pk.B, p1.B, pk.C, pk.eta, p1.eta, pk.A[0] / ks[i],
               fit_status_name(fit_status_code(&ik.status)), ik.iterations, i1.iterations,
               ik.reason, i1.reason, ik.cost, i1.cost, ik.scale);
        assert_rel_close(pk.B, p1.B, 1e-6);
        assert_rel_close(pk.C, p1.C, 1e-6);
        assert_rel_close(pk.eta, p1.eta, 1e-6);
        for (int c = 0; c < 3; c++) {
            assert_rel_close(pk.A[c] / ks[i], p1.A[c], 1e-6);
            assert_close(pk.kd[c] / ks[i], p1.kd[c], 1e-6 * p1.kd[c] + 1e-12);
        }
        assert_int_equal(fit_status_code(&ik.status), fit_status_code(&i1.status));
        assert_true(ik.status.at_bound[0] == '\0');
    }
    /* and the MAP fit: its prior (in 1/sr) moves with the data */
    struct fit_abc_prior prior;
    assert_int_equal(fit_abc_prior_build(NULL, &prior, NULL), 0);
    assert_int_equal(fit_abc_map(s, n, NULL, &prior, &p1, &i1, NULL), 0);
    for (size_t k = 0; k < n; k++)
        for (int c = 0; c < 3; c++)
            t[k].rgb[c] = s[k].rgb[c] * 1e12;
    assert_int_equal(fit_abc_map(t, n, NULL, &prior, &pk, &ik, NULL), 0);
    assert_rel_close(pk.B, p1.B, 1e-6);
    assert_rel_close(pk.eta, p1.eta, 1e-6);
    assert_rel_close(pk.A[0] / 1e12, p1.A[0], 1e-6);
}

/* All-zero data (a detector that never saw light): a finite fit of a black
 * material, and a status that says the lobe's shape is not determined. */
static void test_all_zero(void **state)
{
    (void)state;
    static struct brdf_pair g[MAXS];
    static struct fit_sample s[MAXS];
    size_t n = grid(80, g);
    const struct brdf_abc black = {{0, 0, 0}, {0, 0, 0}, 100, 1, 1.5};
    synth(&black, g, n, s);
    struct brdf_abc p;
    struct fit_info info;
    assert_int_equal(fit_abc(s, n, NULL, &p, &info, NULL), 0);
    assert_finite_params(&p);
    char line[400];
    fit_status_line(&info.status, line, sizeof line);
    printf("all zero: kd_r %g A_r %g; %s\n", p.kd[0], p.A[0], line);
    for (int c = 0; c < 3; c++) {
        assert_true(p.kd[c] < 1e-9);
        assert_true(p.A[c] < 1e-9);
    }
    assert_true(info.status.findings & (1u << FIT_STATUS_UNDERDETERMINED));
    assert_int_equal(fit_status_code(&info.status), FIT_STATUS_UNDERDETERMINED);
}

/* Values that are not numbers: a fit of nothing but NaN or infinities is
 * refused with one error naming them; NaN among good samples is dropped. */
static void test_nan_inf_refused(void **state)
{
    (void)state;
    static struct brdf_pair g[MAXS];
    static struct fit_sample s[MAXS];
    size_t n = grid(80, g);
    const struct brdf_abc truth = {{0.2, 0.15, 0.1}, {20, 15, 10}, 3000, 0.9, 1.5};
    const double bad[] = {NAN, INFINITY, -INFINITY};
    for (int b = 0; b < 3; b++) {
        synth(&truth, g, n, s);
        for (size_t k = 0; k < n; k++)
            s[k].rgb[k % 3] = bad[b];
        struct brdf_abc p;
        struct gonio_err err = {0};
        int rc = fit_abc(s, n, NULL, &p, NULL, &err);
        printf("%g: rc %d, %s\n", bad[b], rc, err.msg);
        assert_int_equal(rc, -GONIO_EFIT);
        assert_non_null(strstr(err.msg, "0 usable samples"));
        assert_non_null(strstr(err.msg, "NaN/inf"));
    }
}

/* Three samples at one geometry (distinct readings, so not duplicates):
 * nine parameters from one geometry. Once "converged". */
static void test_one_geometry_underdetermined(void **state)
{
    (void)state;
    const struct brdf_abc truth = {{0.2, 0.15, 0.1}, {20, 15, 10}, 3000, 0.9, 1.5};
    struct fit_sample s[3] = {0};
    for (int k = 0; k < 3; k++) {
        brdf_pair_inplane(30, 25, &s[k].g);
        brdf_abc_eval(&truth, &s[k].g, s[k].rgb);
        s[k].rgb[0] *= 1.0 + 0.01 * k;
    }
    struct brdf_abc p;
    struct fit_info info;
    assert_int_equal(fit_abc(s, 3, NULL, &p, &info, NULL), 0);
    char line[400];
    fit_status_line(&info.status, line, sizeof line);
    printf("one geometry: %s\n", line);
    assert_int_equal((int)info.status.geometries, 1);
    assert_int_equal(fit_status_code(&info.status), FIT_STATUS_UNDERDETERMINED);
    assert_true(info.status.rank < info.status.params);
    assert_true(info.status.findings & (1u << FIT_STATUS_ILL_CONDITIONED));
}

/* Every sample at theta_h = 0 (the mirror, at many theta_d): the lobe
 * D(theta_h) is seen at one value, so B and C have no influence. The
 * geometries count 15 (theta_d differ); the Jacobian's rank says it. */
static void test_one_theta_h_underdetermined(void **state)
{
    (void)state;
    const struct brdf_abc truth = {{0.2, 0.15, 0.1}, {20, 15, 10}, 3000, 0.9, 1.5};
    struct fit_sample s[15] = {0};
    for (int k = 0; k < 15; k++) {
        brdf_pair_inplane(5.0 * k + 2, 5.0 * k + 2, &s[k].g);
        brdf_abc_eval(&truth, &s[k].g, s[k].rgb);
    }
    struct brdf_abc p;
    struct fit_info info;
    assert_int_equal(fit_abc(s, 15, NULL, &p, &info, NULL), 0);
    assert_finite_params(&p);
    char line[400];
    fit_status_line(&info.status, line, sizeof line);
    printf("one theta_h: %s\n", line);
    assert_int_equal((int)info.status.geometries, 15);
    assert_true(info.status.rank >= 0 && info.status.rank < info.status.params);
    assert_int_equal(fit_status_code(&info.status), FIT_STATUS_UNDERDETERMINED);
}

/* Saturated readings: values above 1.0 clipped there (the peak of every
 * specular sample) and flagged (fit_options.lower_bound). Taken one-sided (censored), the
 * fit recovers the truth from the rest and the bounds: parameters to 1e-6
 * relative. Taken at their clipped value, as before, the lobe's amplitude
 * falls far below the truth's (A_r 0.46 for 20 once). */
static void test_clipped_censored(void **state)
{
    (void)state;
    static struct brdf_pair g[MAXS];
    static struct fit_sample s[MAXS];
    static unsigned char lower[MAXS];
    size_t n = grid(80, g);
    synth(&noisy_truth, g, n, s);
    size_t clipped = 0;
    for (size_t k = 0; k < n; k++) {
        lower[k] = 0;
        for (int c = 0; c < 3; c++)
            if (s[k].rgb[c] > 1.0) {
                s[k].rgb[c] = 1.0;
                lower[k] = 1;
            }
        clipped += lower[k];
    }
    struct brdf_abc p, q;
    struct fit_info info;
    struct fit_options o = fit_default_options();
    o.lower_bound = lower;
    assert_int_equal(fit_abc(s, n, &o, &p, &info, NULL), 0);
    assert_int_equal(fit_abc(s, n, NULL, &q, NULL, NULL), 0);
    printf("clipped at 1.0 (%zu of %zu samples): censored A_r %.9g B %.9g (parameters off by "
           "%.2e, %s); at the clipped value A_r %.3g B %.3g\n",
           clipped, n, p.A[0], p.B, param_rel(&p, &noisy_truth),
           fit_status_name(fit_status_code(&info.status)), q.A[0], q.B);
    assert_true(clipped >= 5);
    assert_true(param_rel(&p, &noisy_truth) <= 1e-6);
    assert_true(q.A[0] < 0.5 * noisy_truth.A[0]);
    /* the status's residuals (abc_problem_eval's path) are one-sided too:
     * the truth is above its clipped values, so nothing is left */
    assert_true(info.status.insample < 1e-9);
    /* and the peak, more than 10 times its clip, is the shoulders'
     * extrapolation, right here because the data are the model's own: no
     * reading bounds it, and the status says so */
    assert_int_equal(info.status.findings, 1u << FIT_STATUS_PEAK_UNBOUNDED);

    /* A bound 100 times below the model away from the peak, the peak read:
     * nothing unbounded. */
    synth(&noisy_truth, g, n, s);
    size_t low = 0;
    for (size_t k = 0; k < n; k++) {
        lower[k] = 0;
        low = s[k].rgb[0] < s[low].rgb[0] ? k : low;
    }
    lower[low] = 1;
    for (int c = 0; c < 3; c++)
        s[low].rgb[c] /= 100;
    assert_int_equal(fit_abc(s, n, &o, &p, &info, NULL), 0);
    assert_true(param_rel(&p, &noisy_truth) <= 1e-6);
    assert_int_equal(info.status.findings, 0);
}

/* Noise at three SNRs: the fit's in-sample RMS residual is the noise's,
 * sigma sqrt((m - 9) / m) for m residuals, within 4 of its standard
 * deviations (sigma / sqrt(2 m)); the held-out residual is at least 1 %
 * above it and below 1.5 sigma; log B lies within 4 reported sds of the truth; and the
 * status is converged (noise 1 % to 10 % is what the model is for). */
static void test_noisy_snr(void **state)
{
    (void)state;
    static struct brdf_pair g[MAXS];
    static struct fit_sample s[MAXS];
    size_t n = grid(80, g);
    const double sigmas[] = {0.003, 0.01, 0.03};
    for (int i = 0; i < 3; i++) {
        double sg = sigmas[i], m = 3.0 * (double)n;
        synth_noisy(&noisy_truth, g, n, sg, 1000 + (uint64_t)i, s);
        struct brdf_abc p;
        struct fit_info info;
        assert_int_equal(fit_abc(s, n, NULL, &p, &info, NULL), 0);
        double want = sg * sqrt((m - 9) / m), tol = 4 * sg / sqrt(2 * m);
        double zb = (log(p.B) - log(noisy_truth.B)) / info.sd.log_B;
        printf("sigma %g: in-sample %.5f (expect %.5f +- %.5f), held-out %.5f, log B off by "
               "%.2f sd, %s\n",
               sg, info.status.insample, want, tol, info.status.heldout, zb,
               fit_status_name(fit_status_code(&info.status)));
        assert_close(info.status.insample, want, tol);
        /* held out, each sample is predicted by a fit that did not see it:
         * about (1 + 9 / m) times the in-sample residual (measured 1.045 to
         * 1.059); the fit of all samples scores 1 */
        assert_true(info.status.heldout >= 1.01 * info.status.insample);
        assert_true(info.status.heldout <= 1.5 * sg);
        assert_true(fabs(zb) <= 4);
        assert_int_equal(fit_status_code(&info.status), FIT_STATUS_CONVERGED);
    }
}

/* The reported sds are calibrated: over 200 seeded repeats at 1 % noise,
 * the share of fits whose truth lies within 1 reported sd is 0.68 for a
 * Gaussian estimate; it must lie in [0.6, 0.76] (200 repeats: the share's
 * own sd is 0.033) for log B, log C, eta and log A_r. The small size keeps
 * the 200 repeats on a coarser grid. */
static void test_uncertainty_calibrated(void **state)
{
    (void)state;
    static struct brdf_pair g[MAXS];
    static struct fit_sample s[MAXS];
    size_t n = grid(gonio_test_small() ? 60 : 80, g);
    const int reps = 200;
    int in[4] = {0};
    for (int r = 0; r < reps; r++) {
        synth_noisy(&noisy_truth, g, n, 0.01, 7000 + (uint64_t)r, s);
        struct brdf_abc p;
        struct fit_info info;
        assert_int_equal(fit_abc(s, n, NULL, &p, &info, NULL), 0);
        in[0] += fabs(log(p.B / noisy_truth.B)) <= info.sd.log_B;
        in[1] += fabs(log(p.C / noisy_truth.C)) <= info.sd.log_C;
        in[2] += fabs(p.eta - noisy_truth.eta) <= info.sd.eta;
        in[3] += fabs(log(p.A[0] / noisy_truth.A[0])) <= info.sd.log_A[0];
    }
    const char *name[4] = {"log B", "log C", "eta", "log A_r"};
    for (int j = 0; j < 4; j++) {
        double share = (double)in[j] / reps;
        printf("%s: %.3f of %d truths within 1 sd\n", name[j], share, reps);
        assert_true(share >= 0.6 && share <= 0.76);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_grazing_and_vh_to_zero),
        cmocka_unit_test(test_eta_extremes),
        cmocka_unit_test(test_very_sharp_bright_lobe),
        cmocka_unit_test(test_all_diffuse),
        cmocka_unit_test(test_six_samples),
        cmocka_unit_test(test_nan_and_duplicates_dropped),
        cmocka_unit_test(test_real_edge_materials),
        cmocka_unit_test(test_scale_invariance),
        cmocka_unit_test(test_all_zero),
        cmocka_unit_test(test_nan_inf_refused),
        cmocka_unit_test(test_one_geometry_underdetermined),
        cmocka_unit_test(test_one_theta_h_underdetermined),
        cmocka_unit_test(test_clipped_censored),
        cmocka_unit_test(test_noisy_snr),
        cmocka_unit_test(test_uncertainty_calibrated),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
