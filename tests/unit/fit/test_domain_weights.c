/* Sample weights by domain share (fit/domain_weights.h) and the weighted
 * ABC fit (fit_options.domain_weights):
 *  - the weights sum to the number of samples, and samples spread evenly
 *    over (sqrt theta_h, theta_d) weigh what their cells of the domain hold;
 *  - a crowd of samples near one point shares that point's weight, and the
 *    other samples keep theirs;
 *  - samples at one point split it equally; a permutation of the samples
 *    permutes the weights;
 *  - samples denser than the MERL grid's cells still each get a share;
 *  - a fit of spread samples plus a crowd from another material: weighted,
 *    the crowd counts as the bit of domain it covers and the fit follows
 *    the spread samples; unweighted, it bends towards the crowd. The model
 *    file says the fit was weighted;
 *  - fewer than seven samples (DS4's six) are fitted unweighted;
 *  - a weighted fit's parameter sds are the spread its estimates have over
 *    repeated noisy captures (the sandwich covariance), not the far smaller
 *    figure that treating the weights as precisions gives. */
#include <math.h>
#include <string.h>

#include "brdf/abc.h"
#include "brdf/angles.h"
#include "brdf/domain.h"
#include "fit/abc_model.h"
#include "fit/domain_weights.h"
#include "fit/fit.h"
#include "fit/model_file.h"
#include "fit/models.h"
#include "tests/gonio_test.h"

#define GRID 6
#define CROWD 40

/* A sample at (theta_h, theta_d) in the coordinates the weights use:
 * u = sqrt(theta_h / 90 deg), v = theta_d / 90 deg. */
static void sample_at(double u, double v, struct fit_sample *s)
{
    brdf_pair_from_hd(u * u * 90 * BRDF_DEG, v * 90 * BRDF_DEG, 90 * BRDF_DEG, &s->g);
    s->rgb[0] = s->rgb[1] = s->rgb[2] = 0.1;
}

/* The middle of block b of 15 MERL cells (90 / GRID): node 15 b + 7, off
 * the blocks' borders by 7 and 8 nodes, so that no node is as near two. */
static double centre(int b)
{
    return (15.0 * b + 7) / BRDF_DOMAIN_N_HD;
}

/* GRID x GRID samples, one in the middle of each block of nodes. */
static size_t grid_samples(struct fit_sample *s)
{
    size_t n = 0;
    for (int i = 0; i < GRID; i++)
        for (int j = 0; j < GRID; j++)
            sample_at(centre(i), centre(j), &s[n++]);
    return n;
}

static double sum(const double *w, size_t n)
{
    double t = 0;
    for (size_t k = 0; k < n; k++)
        t += w[k];
    return t;
}

static void test_even_grid(void **state)
{
    (void)state;
    struct fit_sample s[GRID * GRID] = {0};
    double w[GRID * GRID];
    size_t n = grid_samples(s);
    assert_int_equal(fit_domain_weights(s, NULL, n, w), 0);
    assert_close(sum(w, n), (double)n, 1e-9);
    /* the full domain's nodes per (theta_h, theta_d) cell, summed over
     * each sample's block of cells: what its weight must be */
    static unsigned short counts[BRDF_DOMAIN_N_HD * BRDF_DOMAIN_N_HD];
    brdf_domain_hd_counts(counts);
    double total = 0, block[GRID * GRID] = {0};
    for (int i = 0; i < BRDF_DOMAIN_N_HD; i++)
        for (int j = 0; j < BRDF_DOMAIN_N_HD; j++) {
            int c = counts[i * BRDF_DOMAIN_N_HD + j];
            assert_true(c <= 180);
            total += c;
            block[(i / 15) * GRID + j / 15] += c;
        }
    /* 923,870 nodes in the full domain (brdf/domain.h) */
    assert_close(total, 923870, 0.5);
    for (size_t k = 0; k < n; k++)
        assert_close(w[k], block[k] / total * (double)n, 1e-9);
    /* grazing theta_d holds fewer nodes (the 80-degree rule): the weights differ */
    assert_true(w[0] > 2 * w[GRID - 1]);
}

static void test_crowd_shares_its_point(void **state)
{
    (void)state;
    struct fit_sample s[GRID * GRID + CROWD] = {0};
    double alone[GRID * GRID], w[GRID * GRID + CROWD];
    size_t n = grid_samples(s);
    assert_int_equal(fit_domain_weights(s, NULL, n, alone), 0);
    size_t p = 2 * GRID + 3; /* the crowd gathers round this sample */
    double u = centre(2), v = centre(3);
    for (int c = 0; c < CROWD; c++)
        sample_at(u + 0.002 * (c % 5), v + 0.002 * (c / 5), &s[n + (size_t)c]);
    size_t m = n + CROWD;
    assert_int_equal(fit_domain_weights(s, NULL, m, w), 0);
    assert_close(sum(w, m), (double)m, 1e-9);
    /* in units of the domain (weights x total / n) the crowd and its point
     * hold what the point held alone, and the others keep theirs */
    double crowd = w[p];
    for (size_t k = n; k < m; k++)
        crowd += w[k];
    assert_rel_close(crowd / (double)m, alone[p] / (double)n, 0.1);
    for (size_t k = 0; k < n; k++)
        if (k != p)
            assert_rel_close(w[k] / (double)m, alone[k] / (double)n, 0.1);
}

static void test_ties_and_order(void **state)
{
    (void)state;
    struct fit_sample s[GRID * GRID + 1] = {0}, r[GRID * GRID + 1] = {0};
    double w[GRID * GRID + 1], wr[GRID * GRID + 1], alone[GRID * GRID];
    size_t n = grid_samples(s);
    assert_int_equal(fit_domain_weights(s, NULL, n, alone), 0);
    s[n] = s[7]; /* a repeat of sample 7: the two split its share */
    s[n].rgb[0] = 0.2;
    assert_int_equal(fit_domain_weights(s, NULL, n + 1, w), 0);
    assert_close(w[7], w[n], 1e-12);
    assert_rel_close((w[7] + w[n]) / (double)(n + 1), alone[7] / (double)n, 1e-9);
    for (size_t k = 0; k <= n; k++)
        r[k] = s[n - k];
    assert_int_equal(fit_domain_weights(r, NULL, n + 1, wr), 0);
    for (size_t k = 0; k <= n; k++)
        assert_true(wr[k] == w[n - k]);
    /* idx selects and orders the samples */
    size_t idx[3] = {9, 2, 30};
    double wi[3];
    struct fit_sample three[3] = {s[9], s[2], s[30]};
    double w3[3];
    assert_int_equal(fit_domain_weights(s, idx, 3, wi), 0);
    assert_int_equal(fit_domain_weights(three, NULL, 3, w3), 0);
    for (int k = 0; k < 3; k++)
        assert_true(wi[k] == w3[k]);
}

/* A capture denser than the MERL grid's 8,100 cells (a 1-degree pool
 * measured to the end): every sample still stands for its bit of the
 * domain, and a region's samples weigh what its nodes hold. */
static void test_dense_capture(void **state)
{
    (void)state;
    enum { SIDE = 100, N = SIDE * SIDE };
    static struct fit_sample s[N];
    static double w[N];
    for (int i = 0; i < SIDE; i++)
        for (int j = 0; j < SIDE; j++)
            sample_at((i + 0.5) / SIDE, (j + 0.5) / SIDE, &s[i * SIDE + j]);
    assert_int_equal(fit_domain_weights(s, NULL, N, w), 0);
    assert_close(sum(w, N), (double)N, 1e-6);
    static unsigned short counts[BRDF_DOMAIN_N_HD * BRDF_DOMAIN_N_HD];
    brdf_domain_hd_counts(counts);
    /* a sample where the domain has nodes (its nearest grid cell holds
     * some; beyond the 80-degree rule none) must weigh something */
    size_t zero = 0;
    double low = 0; /* theta_d below 45 degrees: the samples' share */
    for (int i = 0; i < SIDE; i++)
        for (int j = 0; j < SIDE; j++) {
            size_t k = (size_t)(i * SIDE + j);
            int ci = (int)lround((i + 0.5) / SIDE * BRDF_DOMAIN_N_HD);
            int cj = (int)lround((j + 0.5) / SIDE * BRDF_DOMAIN_N_HD);
            int c = ci < BRDF_DOMAIN_N_HD && cj < BRDF_DOMAIN_N_HD
                        ? counts[ci * BRDF_DOMAIN_N_HD + cj]
                        : 0;
            zero += c > 0 && !(w[k] > 0);
            if (j < SIDE / 2)
                low += w[k] / N;
        }
    double total = 0, below = 0; /* and the nodes' */
    for (int i = 0; i < BRDF_DOMAIN_N_HD; i++)
        for (int j = 0; j < BRDF_DOMAIN_N_HD; j++) {
            total += counts[i * BRDF_DOMAIN_N_HD + j];
            below += j < 45 ? counts[i * BRDF_DOMAIN_N_HD + j] : 0;
        }
    printf("%d samples: %zu of weight 0 where the domain has nodes; below theta_d 45 deg they "
           "weigh %.4f of the total, "
           "the nodes there %.4f\n",
           N, zero, low, below / total);
    assert_int_equal(zero, 0);
    assert_close(low, below / total, 0.01);
}

/* The fits' material: a glossy lobe on a coloured base. */
static const struct brdf_abc glossy = {
    .kd = {0.20, 0.15, 0.10}, .A = {20.0, 15.0, 10.0}, .B = 3000, .C = 0.9, .eta = 1.5};

/* Mean |log(1 + fhat cos) - log(1 + f cos)| over random pairs up to 80
 * degrees. */
static double oop_log_error(const struct brdf_abc *fit, const struct brdf_abc *ref)
{
    uint64_t st = 11;
    double e = 0;
    int m = 4000;
    for (int t = 0; t < m; t++) {
        double x[4];
        for (int q = 0; q < 4; q++)
            x[q] = (double)(brdf_splitmix64(&st) >> 11) / 9007199254740992.0;
        struct brdf_pair g;
        brdf_pair_spherical(80 * x[0], 360 * x[1], 80 * x[2], 360 * x[3], &g);
        double a[3], b[3];
        brdf_abc_eval(fit, &g, a);
        brdf_abc_eval(ref, &g, b);
        for (int c = 0; c < 3; c++)
            e += fabs(log1p(a[c] * g.wi[2]) - log1p(b[c] * g.wi[2]));
    }
    return e / (3.0 * m);
}

static void test_weighted_fit_ignores_crowd(void **state)
{
    (void)state;
    const struct brdf_abc spread_mat = glossy;
    /* the crowd's material: four times as bright a diffuse part, as if a
     * grazing corner showed what the spread samples do not */
    struct brdf_abc crowd_mat = spread_mat;
    for (int c = 0; c < 3; c++)
        crowd_mat.kd[c] *= 4;
    struct fit_sample s[400] = {0};
    size_t n = 0;
    for (double ti = 0; ti <= 75; ti += 15)
        for (double tr = -75; tr <= 75; tr += 6)
            if (fabs(ti + tr) >= 5) {
                brdf_pair_inplane(ti, tr, &s[n].g);
                brdf_abc_eval(&spread_mat, &s[n].g, s[n].rgb);
                n++;
            }
    size_t spread = n;
    for (int c = 0; c < 120; c++) { /* a 1-degree pool's crowd in one grazing corner */
        brdf_pair_inplane(70 + 0.1 * (c % 10), -(60 + 0.1 * (c / 10)), &s[n].g);
        brdf_abc_eval(&crowd_mat, &s[n].g, s[n].rgb);
        n++;
    }
    assert_true(n > spread + 100 && n <= 400);
    struct fit_options o = fit_default_options();
    struct brdf_abc plain, weighted;
    struct fit_info pi, wi;
    struct gonio_err err = {0};
    assert_int_equal(fit_abc(s, n, &o, &plain, &pi, &err), 0);
    o.domain_weights = 1;
    assert_int_equal(fit_abc(s, n, &o, &weighted, &wi, &err), 0);
    double ep = oop_log_error(&plain, &spread_mat), ew = oop_log_error(&weighted, &spread_mat);
    printf("error against the spread samples' material: unweighted %.4f, weighted %.4f\n", ep,
           ew);
    assert_int_equal(pi.domain_weights, 0);
    assert_int_equal(wi.domain_weights, 1);
    assert_true(ew < 0.5 * ep);

    /* through the registry: the model file says how it was fitted */
    struct fit_data data = {.rgb = s, .n_rgb = n, .domain_weights = 1};
    struct fit_model_file *f = NULL;
    assert_int_equal(fit_abc_model_fit(&data, NULL, &f, NULL, &err), 0);
    assert_non_null(fit_model_file_get(f, "weights"));
    fit_model_file_free(f);
    data.domain_weights = 0;
    assert_int_equal(fit_abc_model_fit(&data, NULL, &f, NULL, &err), 0);
    assert_null(fit_model_file_get(f, "weights"));
    fit_model_file_free(f);
}

/* DS4's six pairs are fitted unweighted whatever the options say: the
 * same parameters as an unweighted fit, and no weights in the info; a
 * seventh sample and the fit weighs them. */
static void test_no_weights_below_seven(void **state)
{
    (void)state;
    static const double tr[7] = {-60, -20, 20, 28, 36, 60, 45};
    struct fit_sample s[7] = {0};
    for (int k = 0; k < 7; k++) {
        brdf_pair_inplane(30, tr[k], &s[k].g);
        brdf_abc_eval(&glossy, &s[k].g, s[k].rgb);
        s[k].rgb[1] *= 1.3; /* not exactly an ABC material: the weights move the fit */
    }
    for (size_t n = 6; n <= 7; n++) {
        struct fit_options o = fit_default_options();
        struct brdf_abc plain, weighted;
        struct fit_info pi, wi;
        struct gonio_err err = {0};
        assert_int_equal(fit_abc(s, n, &o, &plain, &pi, &err), 0);
        o.domain_weights = 1;
        assert_int_equal(fit_abc(s, n, &o, &weighted, &wi, &err), 0);
        int below = n == 6;
        assert_int_equal(wi.domain_weights, !below);
        assert_int_equal(memcmp(&plain, &weighted, sizeof plain) == 0, below);
    }
}

/* A standard normal deviate (Box-Muller) from the splitmix64 stream. */
static double gauss(uint64_t *st)
{
    double u1 = ((double)(brdf_splitmix64(st) >> 11) + 0.5) / 9007199254740992.0;
    double u2 = (double)(brdf_splitmix64(st) >> 11) / 9007199254740992.0;
    return sqrt(-2 * log(u1)) * cos(360 * BRDF_DEG * u2);
}

#define REPEATS 30
#define NOISE 0.02 /* sd of the noise added to log(1 + f cos theta_i) */

static void test_weighted_sds_match_their_spread(void **state)
{
    (void)state;
    /* 40 spread samples and a crowd of 200 in one grazing corner: the crowd
     * stands for little of the domain, so the spread samples carry nearly
     * all the weight */
    struct fit_sample clean[300] = {0}, s[300] = {0};
    size_t n = 0;
    for (double ti = 0; ti <= 75; ti += 15)
        for (double tr = -75; tr <= 75; tr += 22)
            if (fabs(ti + tr) >= 5) {
                brdf_pair_inplane(ti, tr, &clean[n].g);
                brdf_abc_eval(&glossy, &clean[n].g, clean[n].rgb);
                n++;
            }
    for (int c = 0; c < 200; c++) {
        brdf_pair_inplane(70 + 0.05 * (c % 20), -(60 + 0.1 * (c / 20)), &clean[n].g);
        brdf_abc_eval(&glossy, &clean[n].g, clean[n].rgb);
        n++;
    }
    double w[300], w2 = 0;
    assert_int_equal(fit_domain_weights(clean, NULL, n, w), 0);
    for (size_t k = 0; k < n; k++)
        w2 += w[k] * w[k] / (double)n;
    /* Kish's design effect: the precision-weighted sds would be about
     * sqrt(w2) times too small; the test must tell the two apart */
    printf("%zu samples, mean w^2 %.2f\n", n, w2);
    assert_true(w2 > 6);

    struct fit_options o = fit_default_options();
    o.domain_weights = 1;
    o.heldout = 0;
    uint64_t st = 2026;
    double est[3][REPEATS], sd[3] = {0};
    for (int r = 0; r < REPEATS; r++) {
        for (size_t k = 0; k < n; k++) {
            s[k] = clean[k];
            double ci = s[k].g.wi[2];
            for (int c = 0; c < 3; c++)
                s[k].rgb[c] = expm1(log1p(clean[k].rgb[c] * ci) + NOISE * gauss(&st)) / ci;
        }
        struct brdf_abc fit;
        struct fit_info info;
        struct gonio_err err = {0};
        assert_int_equal(fit_abc(s, n, &o, &fit, &info, &err), 0);
        est[0][r] = log(fit.kd[0]);
        est[1][r] = log(fit.A[0]);
        est[2][r] = log(fit.B);
        sd[0] += info.sd.log_kd[0] / REPEATS;
        sd[1] += info.sd.log_A[0] / REPEATS;
        sd[2] += info.sd.log_B / REPEATS;
    }
    static const char *const name[3] = {"log kd[0]", "log A[0]", "log B"};
    for (int p = 0; p < 3; p++) {
        double mean = 0, var = 0;
        for (int r = 0; r < REPEATS; r++)
            mean += est[p][r] / REPEATS;
        for (int r = 0; r < REPEATS; r++)
            var += (est[p][r] - mean) * (est[p][r] - mean) / (REPEATS - 1);
        printf("%-9s: spread over %d captures %.4f, reported sd %.4f\n", name[p], REPEATS,
               sqrt(var), sd[p]);
        /* 30 captures estimate a spread within about 13 % */
        assert_true(sd[p] > 0.65 * sqrt(var) && sd[p] < 1.5 * sqrt(var));
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_even_grid),
        cmocka_unit_test(test_crowd_shares_its_point),
        cmocka_unit_test(test_ties_and_order),
        cmocka_unit_test(test_dense_capture),
        cmocka_unit_test(test_weighted_fit_ignores_crowd),
        cmocka_unit_test(test_no_weights_below_seven),
        cmocka_unit_test(test_weighted_sds_match_their_spread),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
