/* The budget is honest (radiometry/reduce.h): over 200 seeded repeats of a
 * calibration and a capture on the synthetic rig (tests/unit/radiometry/
 * synth.h), each repeat with the plaque's true reflectance and shape drawn
 * from its certificate, the nonlinearity and the sample's placement drawn
 * from their stated uncertainties, shot, read and monitor noise, lamp
 * drift, and axes resting anywhere in their band, the per-sample z-scores
 * (measured - true) / u have a standard deviation in 0.85-1.15 and the
 * k = 2 intervals cover 92-98 % of the true values. The shared terms are
 * checked on their own: the spread of a repeat's mean error is what the
 * systematic terms claim. */
#include "tests/gonio_test.h"
#include "tests/unit/radiometry/synth.h"

#define REPEATS 200

struct stats {
    double z_sum, z2_sum;
    long n, covered;
    double sys_z2; /* repeat means of the relative error over the systematic u */
    int repeats;
    double term_sum[RAD_N_TERMS], total_sum; /* relative u, summed for the mean */
};

static size_t plan(double (*geo)[2], int step)
{
    size_t n = 0;
    for (int ti = 0; ti <= 50; ti += 25)
        for (int tr = -60; tr <= 70; tr += step)
            geo[n][0] = ti, geo[n][1] = tr, n++;
    return n;
}

/* band_deg 0: the rig as synth.h makes it; else axes that rest anywhere in
 * a wide band, read on a finer grid: the angle term dominates. */
static void one_repeat(uint64_t seed, double band_deg, struct stats *st)
{
    struct syn_rig r;
    syn_rig_init(&r, seed, 1);
    r.responsivity = 6e5;
    if (band_deg > 0)
        r.band_deg = band_deg;
    double geo[SYN_MAX][2];
    size_t n = plan(geo, band_deg > 0 ? 5 : 10);
    struct rad_dark darks[2];
    static struct rad_ref refs[SYN_MAX];
    syn_dark(&r, 0.1, 16, &darks[0]);
    syn_dark(&r, 0.2, 16, &darks[1]);
    for (size_t k = 0; k < n; k++)
        syn_reference(&r, geo[k][0], geo[k][1], 0.1, 4, &refs[k]);
    struct rad_calibration cal = {.standard = r.cert, .darks = darks, .n_darks = 2,
                                  .refs = refs, .n_refs = n};
    syn_setup(&r, &cal.setup);
    static struct rad_raw raw[SYN_MAX];
    for (size_t k = 0; k < n; k++) {
        int dim = syn_sample_brdf(geo[k][0], geo[k][1], 0) < 0.15;
        syn_sample(&r, geo[k][0], geo[k][1], dim ? 0.2 : 0.1, &raw[k]);
    }
    static struct rad_value v[SYN_MAX];
    struct gonio_err err = {0};
    if (rad_reduce(&cal, raw, n, v, &err) < 0) {
        print_error("%s\n", err.msg);
        fail();
    }
    double mean_rel[3] = {0}, sys_rel[3] = {0};
    for (size_t k = 0; k < n; k++)
        for (int c = 0; c < 3; c++) {
            assert_true(isfinite(v[k].brdf[c]) && v[k].u[c] > 0);
            double truth = syn_sample_brdf(geo[k][0], geo[k][1], c);
            double z = (v[k].brdf[c] - truth) / v[k].u[c];
            st->z_sum += z, st->z2_sum += z * z, st->n++;
            st->covered += fabs(z) <= 2.0;
            mean_rel[c] += (v[k].brdf[c] / truth - 1) / (double)n;
            double s2 = 0;
            for (int t = 0; t < RAD_N_TERMS; t++)
                if (rad_term_systematic((enum rad_term)t))
                    s2 += v[k].rel[t][c] * v[k].rel[t][c];
            sys_rel[c] += sqrt(s2) / (double)n;
            for (int t = 0; t < RAD_N_TERMS; t++)
                st->term_sum[t] += v[k].rel[t][c];
            st->total_sum += v[k].u[c] / v[k].brdf[c];
        }
    /* A repeat's mean error in a channel is mostly the shared error: the
     * random terms average down over its 42 values. */
    for (int c = 0; c < 3; c++)
        st->sys_z2 += (mean_rel[c] / sys_rel[c]) * (mean_rel[c] / sys_rel[c]) / 3;
    st->repeats++;
}

static void test_z_scores_and_coverage(void **state)
{
    (void)state;
    struct stats st = {0};
    for (uint64_t seed = 1; seed <= REPEATS; seed++)
        one_repeat(seed, 0.0, &st);
    double mean = st.z_sum / (double)st.n;
    double sd = sqrt(st.z2_sum / (double)st.n - mean * mean);
    double cover = (double)st.covered / (double)st.n;
    double sys_sd = sqrt(st.sys_z2 / st.repeats);
    fprintf(stderr, "z: n %ld, mean %.3f, sd %.3f; k=2 coverage %.1f %%; shared: sd of repeat "
            "mean error / systematic u %.3f over %d repeats\n", st.n, mean, sd, 100 * cover,
            sys_sd, st.repeats);
    /* The table of docs/radiometry.md (scripts/radiometry_table.sh). */
    if (getenv("GONIO_RADIOMETRY_TABLE")) {
        printf("| term | kind | mean relative u (k = 1) |\n|---|---|---|\n");
        for (int t = 0; t < RAD_N_TERMS; t++)
            printf("| %s | %s | %.3f %% |\n", rad_term_name((enum rad_term)t),
                   rad_term_systematic((enum rad_term)t) ? "systematic" : "per sample",
                   100 * st.term_sum[t] / (double)st.n);
        printf("| combined | | %.3f %% |\n\n", 100 * st.total_sum / (double)st.n);
        printf("z-scores over %d repeats (%ld values): mean %.3f, sd %.3f; k = 2 coverage "
               "%.1f %%; a repeat's mean error over its systematic u: sd %.3f\n", st.repeats,
               st.n, mean, sd, 100 * cover, sys_sd);
    }
    assert_true(sd >= 0.85 && sd <= 1.15);
    assert_true(cover >= 0.92 && cover <= 0.98);
    assert_true(fabs(mean) < 0.15);
    /* The mean error of a repeat scatters as the systematic terms say (a
     * little more: the random terms' share of 126 values adds to it). */
    assert_true(sys_sd >= 0.8 && sys_sd <= 1.25);
}

static void test_angle_term_honest(void **state)
{
    (void)state;
    struct stats st = {0};
    for (uint64_t seed = 1; seed <= REPEATS; seed++)
        one_repeat(1000 + seed, 0.4, &st);
    double mean = st.z_sum / (double)st.n;
    double sd = sqrt(st.z2_sum / (double)st.n - mean * mean);
    double cover = (double)st.covered / (double)st.n;
    fprintf(stderr, "0.4 deg band: z sd %.3f, k=2 coverage %.1f %%, angle term %.3f %% of "
            "%.3f %% combined\n", sd, 100 * cover, 100 * st.term_sum[RAD_U_ANGLE] / (double)st.n,
            100 * st.total_sum / (double)st.n);
    assert_true(sd >= 0.85 && sd <= 1.15);
    assert_true(cover >= 0.92 && cover <= 0.98);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_z_scores_and_coverage),
        cmocka_unit_test(test_angle_term_honest),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
