/* The ABC fit weighted by the samples' standard uncertainties
 * (fit_sample.u, fit_options.u_systematic):
 *  - over repeated captures of a glossy material whose per-sample noise
 *    varies twentyfold from sample to sample, plus one relative scale
 *    error per capture and channel (the reference standard's), the
 *    reported parameter sds are the spread of the estimates, within 25 %:
 *    the amplitudes (kd, A) carry the shared error, the lobe's shape (B)
 *    does not;
 *  - the weighted fit's estimates scatter less about the truth than those
 *    of the same data fitted unweighted;
 *  - samples of which one lacks u are fitted exactly as samples without
 *    any (u is used all or nothing);
 *  - the weighted cost, by the reference and the solver's paths, is half
 *    the sum of ((log residual) / (its sd from u))^2, computed here
 *    directly. */
#include <math.h>
#include <string.h>

#include "brdf/abc.h"
#include "brdf/angles.h"
#include "brdf/domain.h"
#include "fit/abc_problem.h"
#include "fit/fit.h"
#include "tests/gonio_test.h"

static const struct brdf_abc glossy = {
    .kd = {0.20, 0.15, 0.10}, .A = {20.0, 15.0, 10.0}, .B = 3000, .C = 0.9, .eta = 1.5};

#define REPEATS 100 /* a spread estimated within about 7 % */
#define U_SYS 0.02 /* the shared relative error's sd, per channel */
#define MAXN 128

/* A standard normal deviate (Box-Muller) from the splitmix64 stream. */
static double gauss(uint64_t *st)
{
    double u1 = ((double)(brdf_splitmix64(st) >> 11) + 0.5) / 9007199254740992.0;
    double u2 = (double)(brdf_splitmix64(st) >> 11) / 9007199254740992.0;
    return sqrt(-2 * log(u1)) * cos(360 * BRDF_DEG * u2);
}

/* In-plane samples of glossy, clean, and each one's relative per-sample
 * noise: 0.5 % and 10 % alternating, so that u varies strongly. */
static size_t clean_samples(struct fit_sample *s, double *rel)
{
    size_t n = 0;
    for (double ti = 0; ti <= 70; ti += 10)
        for (double tr = -75; tr <= 75; tr += 10)
            if (fabs(ti + tr) >= 5 && n < MAXN) {
                memset(&s[n], 0, sizeof s[n]);
                brdf_pair_inplane(ti, tr, &s[n].g);
                brdf_abc_eval(&glossy, &s[n].g, s[n].rgb);
                rel[n] = n % 2 ? 0.10 : 0.005;
                n++;
            }
    return n;
}

/* One capture: each value times (1 + its noise) and the capture's shared
 * (1 + e_c); u as the budget gives it, the root sum of squares of both
 * relative terms times the value read. */
static void capture(const struct fit_sample *clean, const double *rel, size_t n, uint64_t *st,
                    struct fit_sample *s)
{
    double e[3];
    for (int c = 0; c < 3; c++)
        e[c] = U_SYS * gauss(st);
    for (size_t k = 0; k < n; k++) {
        s[k] = clean[k];
        for (int c = 0; c < 3; c++) {
            s[k].rgb[c] = clean[k].rgb[c] * (1 + e[c]) * (1 + rel[k] * gauss(st));
            s[k].u[c] = fabs(s[k].rgb[c]) * sqrt(rel[k] * rel[k] + U_SYS * U_SYS);
        }
    }
}

enum { P_KD, P_A, P_B, P_ETA, NP };
static const char *const pname[NP] = {"log kd[0]", "log A[0]", "log B", "eta"};

static void params(const struct brdf_abc *p, double out[NP])
{
    out[P_KD] = log(p->kd[0]);
    out[P_A] = log(p->A[0]);
    out[P_B] = log(p->B);
    out[P_ETA] = p->eta;
}

static void test_sds_match_spread_and_weights_help(void **state)
{
    (void)state;
    static struct fit_sample clean[MAXN], s[MAXN];
    double rel[MAXN], truth[NP];
    size_t n = clean_samples(clean, rel);
    params(&glossy, truth);
    struct fit_options o = fit_default_options();
    o.heldout = 0;
    for (int c = 0; c < 3; c++)
        o.u_systematic[c] = U_SYS;
    uint64_t st = 20261207;
    double est[NP][REPEATS], sd[NP] = {0}, mse_w[NP] = {0}, mse_u[NP] = {0};
    for (int r = 0; r < REPEATS; r++) {
        capture(clean, rel, n, &st, s);
        struct brdf_abc fit;
        struct fit_info info;
        struct gonio_err err = {0};
        assert_int_equal(fit_abc(s, n, &o, &fit, &info, &err), 0);
        assert_int_equal(info.measurement_weights, 1);
        double p[NP];
        params(&fit, p);
        double rep[NP] = {info.sd.log_kd[0], info.sd.log_A[0], info.sd.log_B, info.sd.eta};
        for (int j = 0; j < NP; j++) {
            est[j][r] = p[j];
            sd[j] += rep[j] / REPEATS;
            mse_w[j] += (p[j] - truth[j]) * (p[j] - truth[j]) / REPEATS;
        }
        /* the same data unweighted */
        for (size_t k = 0; k < n; k++)
            s[k].u[0] = s[k].u[1] = s[k].u[2] = NAN;
        assert_int_equal(fit_abc(s, n, &o, &fit, &info, &err), 0);
        assert_int_equal(info.measurement_weights, 0);
        params(&fit, p);
        for (int j = 0; j < NP; j++)
            mse_u[j] += (p[j] - truth[j]) * (p[j] - truth[j]) / REPEATS;
    }
    double spread[NP];
    for (int j = 0; j < NP; j++) {
        double mean = 0, var = 0;
        for (int r = 0; r < REPEATS; r++)
            mean += est[j][r] / REPEATS;
        for (int r = 0; r < REPEATS; r++)
            var += (est[j][r] - mean) * (est[j][r] - mean) / (REPEATS - 1);
        printf("%-9s: spread %.4f, reported sd %.4f; rms error weighted %.4f, unweighted "
               "%.4f\n",
               pname[j], sqrt(var), sd[j], sqrt(mse_w[j]), sqrt(mse_u[j]));
        spread[j] = sqrt(var);
    }
    for (int j = 0; j < NP; j++)
        assert_true(sd[j] > 0.75 * spread[j] && sd[j] < 1.25 * spread[j]);
    /* the lobe's shape is where the noisy half of the samples hurts */
    assert_true(mse_w[P_B] < 0.5 * mse_u[P_B]);
    assert_true(mse_w[P_ETA] < 0.5 * mse_u[P_ETA]);
    assert_true(mse_w[P_A] < mse_u[P_A]);
}

static void test_u_all_or_nothing(void **state)
{
    (void)state;
    static struct fit_sample clean[MAXN], s[MAXN], none[MAXN];
    double rel[MAXN];
    size_t n = clean_samples(clean, rel);
    uint64_t st = 7;
    capture(clean, rel, n, &st, s);
    memcpy(none, s, n * sizeof *s);
    for (size_t k = 0; k < n; k++)
        none[k].u[0] = none[k].u[1] = none[k].u[2] = 0;
    s[n / 2].u[1] = NAN; /* one value without u */
    struct fit_options o = fit_default_options();
    struct brdf_abc a, b;
    struct fit_info ia, ib;
    struct gonio_err err = {0};
    assert_int_equal(fit_abc(s, n, &o, &a, &ia, &err), 0);
    assert_int_equal(fit_abc(none, n, &o, &b, &ib, &err), 0);
    assert_int_equal(ia.measurement_weights, 0);
    assert_memory_equal(&a, &b, sizeof a);
    assert_memory_equal(&ia.sd, &ib.sd, sizeof ia.sd);
}

static void test_weighted_cost_is_chi_square(void **state)
{
    (void)state;
    static struct fit_sample clean[MAXN], s[MAXN];
    double rel[MAXN], u[3 * MAXN], expect = 0;
    size_t n = clean_samples(clean, rel);
    uint64_t st = 11;
    capture(clean, rel, n, &st, s);
    for (size_t k = 0; k < n; k++) {
        double fh[3], ci = s[k].g.wi[2];
        brdf_abc_eval(&glossy, &s[k].g, fh);
        for (int c = 0; c < 3; c++) {
            u[3 * k + c] = s[k].u[c];
            double r = log1p(fh[c] * ci) - log1p(s[k].rgb[c] * ci);
            double sd = s[k].u[c] * ci / (1 + s[k].rgb[c] * ci);
            expect += 0.5 * (r / sd) * (r / sd);
        }
    }
    struct abc_problem pb = {0};
    struct abc_cache c;
    double th[ABC_NPAR];
    abc_params_to_theta(&glossy, th);
    assert_int_equal(abc_problem_init(&pb, s, NULL, n), 0);
    assert_int_equal(abc_problem_set_sigma(&pb, u, NULL), 0);
    assert_int_equal(abc_cache_init(&c, &pb), 0);
    printf("chi^2 / 2 over %zu values: %.3f\n", 3 * n, expect);
    assert_close(abc_problem_cost(&pb, th), expect, 1e-9 * expect);
    assert_close(abc_problem_resid(&pb, th, NULL, &c), expect, 1e-9 * expect);
    abc_cache_free(&c);
    abc_problem_free(&pb);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sds_match_spread_and_weights_help),
        cmocka_unit_test(test_u_all_or_nothing),
        cmocka_unit_test(test_weighted_cost_is_chi_square),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
