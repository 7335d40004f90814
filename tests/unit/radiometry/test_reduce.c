/* The relative method (radiometry/reduce.h) on a synthetic rig without
 * noise: the nonlinearity undone exactly, the sample's BRDF recovered
 * through dark, drift (monitor), different integrations and a reference
 * interpolated between its geometries; each budget term as its formula
 * says for a hand-made case; clipped readings NAN; and a calibration that
 * lacks the sample's integration, gain state or geometry refused naming
 * it; the angle term from each sample's nearest neighbours. */
#include "tests/gonio_test.h"
#include "tests/unit/radiometry/synth.h"

static void test_linearise_inverts_the_response(void **state)
{
    (void)state;
    const double fs = 65535, k = 0.04;
    for (double x = 0; x < 0.9 * fs; x += 1234.5) {
        double y = x - k * x * x / fs;
        assert_close(rad_linearise(y, k, fs), x, 1e-9 * fs);
    }
    assert_close(rad_linearise(500.0, 0.0, fs), 500.0, 0);
    assert_close(rad_linearise(500.0, k, 0.0), 500.0, 0);
}

/* A calibration of the noiseless rig: darks at both integrations, the
 * reference at every geometry of `geo` at 0.1 s. */
struct cal_store {
    struct rad_dark darks[2];
    struct rad_ref refs[SYN_MAX];
    struct rad_calibration cal;
};

static void calibrate(struct syn_rig *r, const double (*geo)[2], size_t n, struct cal_store *st)
{
    syn_dark(r, 0.1, 8, &st->darks[0]);
    syn_dark(r, 0.4, 8, &st->darks[1]);
    for (size_t k = 0; k < n; k++)
        syn_reference(r, geo[k][0], geo[k][1], 0.1, 2, &st->refs[k]);
    st->cal.standard = r->cert;
    st->cal.darks = st->darks, st->cal.n_darks = 2;
    st->cal.refs = st->refs, st->cal.n_refs = n;
    syn_setup(r, &st->cal.setup);
}

static void test_recovers_the_brdf_exactly(void **state)
{
    (void)state;
    struct syn_rig r;
    syn_rig_init(&r, 1, 0);
    r.dark_e_per_s = 0; /* the nonlinearity is then undone exactly (see below) */
    const double geo[][2] = {{0, -40}, {0, 10}, {30, 30}, {30, 60}, {50, 45}, {50, -20}};
    const size_t n = sizeof geo / sizeof geo[0];
    struct cal_store st;
    calibrate(&r, geo, n, &st);
    r.t_now += 3600; /* the lamp has drifted 7 % since: the monitor says so */
    struct rad_raw raw[6];
    for (size_t k = 0; k < n; k++)
        syn_sample(&r, geo[k][0], geo[k][1], k % 2 ? 0.4 : 0.1, &raw[k]);
    struct rad_value v[6];
    struct gonio_err err = {0};
    assert_int_equal(rad_reduce(&st.cal, raw, n, v, &err), 0);
    for (size_t k = 0; k < n; k++)
        for (int c = 0; c < 3; c++)
            assert_rel_close(v[k].brdf[c], syn_sample_brdf(geo[k][0], geo[k][1], c), 1e-9);
}

static void test_dark_and_nonlinearity_together(void **state)
{
    (void)state;
    /* With a dark signal, the dark frame's counts pass through the same
     * nonlinearity as the sample's; undoing it on the difference leaves
     * 2 k x_dark / full_scale relative (docs/radiometry.md): here 1e-4. */
    struct syn_rig r;
    syn_rig_init(&r, 2, 0);
    const double geo[][2] = {{0, 20}, {40, 40}};
    struct cal_store st;
    calibrate(&r, geo, 2, &st);
    struct rad_raw raw[2];
    for (size_t k = 0; k < 2; k++)
        syn_sample(&r, geo[k][0], geo[k][1], 0.4, &raw[k]);
    struct rad_value v[2];
    assert_int_equal(rad_reduce(&st.cal, raw, 2, v, NULL), 0);
    for (size_t k = 0; k < 2; k++)
        for (int c = 0; c < 3; c++)
            assert_rel_close(v[k].brdf[c], syn_sample_brdf(geo[k][0], geo[k][1], c), 3e-4);
}

static void test_reference_interpolated(void **state)
{
    (void)state;
    struct syn_rig r;
    syn_rig_init(&r, 3, 0);
    r.dark_e_per_s = 0;
    /* A coarse reference grid: incidence 0 and 40, view every 20 deg. */
    double geo[SYN_MAX][2];
    size_t n = 0;
    for (int ti = 0; ti <= 40; ti += 40)
        for (int tr = -60; tr <= 60; tr += 20)
            geo[n][0] = ti, geo[n][1] = tr, n++;
    struct cal_store st;
    calibrate(&r, (const double (*)[2])geo, n, &st);
    const double at[][2] = {{0, 5}, {20, 33}, {35, -47}, {40, 50}};
    struct rad_raw raw[4];
    for (size_t k = 0; k < 4; k++)
        syn_sample(&r, at[k][0], at[k][1], 0.1, &raw[k]);
    struct rad_value v[4];
    struct gonio_err err = {0};
    assert_int_equal(rad_reduce(&st.cal, raw, 4, v, &err), 0);
    /* The response divided by the standard and cos theta_r is what the
     * rig's is: constant, so interpolating it loses nothing. */
    for (size_t k = 0; k < 4; k++)
        for (int c = 0; c < 3; c++)
            assert_rel_close(v[k].brdf[c], syn_sample_brdf(at[k][0], at[k][1], c), 1e-9);
    /* Outside the grid there is nothing to interpolate from. */
    syn_sample(&r, 60, 10, 0.1, &raw[0]);
    assert_int_equal(rad_reduce(&st.cal, raw, 1, v, &err), -GONIO_EBADCONFIG);
    assert_non_null(strstr(err.msg, "incidence 60"));
    syn_sample(&r, 20, 75, 0.1, &raw[0]);
    assert_int_equal(rad_reduce(&st.cal, raw, 1, v, &err), -GONIO_EBADCONFIG);
    assert_non_null(strstr(err.msg, "(20, 75)"));
}

static void test_budget_terms_by_formula(void **state)
{
    (void)state;
    /* One reference, one sample, same geometry, hand-made numbers. */
    struct rad_dark d[2] = {{.integration_s = 0.1, .n = 16},
                            {.integration_s = 0.2, .n = 4}};
    for (int c = 0; c < 3; c++) {
        d[0].mean[c] = 100, d[0].sd[c] = 8;
        d[1].mean[c] = 200, d[1].sd[c] = 10;
    }
    struct rad_ref ref = {.theta_i = 0, .theta_r = 30, .integration_s = 0.1, .n = 4,
                          .monitor = 1000, .counts = {10100, 10100, 10100}};
    struct rad_calibration cal = {.darks = d, .n_darks = 2, .refs = &ref, .n_refs = 1};
    syn_standard(&cal.standard);
    cal.setup = (struct rad_setup){.adu_per_electron = {2, 2, 2}, .monitor_rel_sd = 0.001,
                                   .drift_rel_u = 0.002, .nonlinearity_rel_u = 0.1,
                                   .in_position_deg = 0, .geometry_rel_u = 0.003};
    struct rad_raw s = {.theta_i = 0, .theta_r = 30, .integration_s = 0.2, .monitor = 2000,
                        .full_scale = 65535, .nonlinearity = 0.0,
                        .counts = {5200, 5200, 70000}};
    struct rad_value v;
    assert_int_equal(rad_reduce(&cal, &s, 1, &v, NULL), 0);
    double f[3];
    brdf_standard_brdf(&cal.standard, 0, 30, f);
    /* x_s = 5000, x_r = 10000, monitor ratio 1000 / 2000. */
    assert_rel_close(v.brdf[0], 0.25 * f[0], 1e-12);
    assert_rel_close(v.rel[RAD_U_COUNTING][0], sqrt(2 * 5000.0 + 100) / 5000, 1e-12);
    assert_rel_close(v.rel[RAD_U_DARK][0],
                     sqrt(100.0 / 4 / (5000.0 * 5000) + 64.0 / 16 / (1e4 * 1e4)), 1e-12);
    assert_rel_close(v.rel[RAD_U_REF_NOISE][0], sqrt((2 * 1e4 + 64) / 4) / 1e4, 1e-12);
    assert_rel_close(v.rel[RAD_U_REFERENCE][0],
                     sqrt(0.005 / 0.99 * 0.005 / 0.99 + 0.004 * 0.004), 1e-12);
    assert_rel_close(v.rel[RAD_U_DRIFT][0], sqrt(1e-6 * 1.25 + 4e-6), 1e-12);
    assert_close(v.rel[RAD_U_NONLINEARITY][0], 0.0, 0);
    assert_close(v.rel[RAD_U_GEOMETRY][0], 0.003, 0);
    double sum = 0;
    for (int t = 0; t < RAD_N_TERMS; t++)
        sum += v.rel[t][0] * v.rel[t][0];
    assert_rel_close(v.u[0], v.brdf[0] * sqrt(sum), 1e-12);
    /* The clipped channel has no value. */
    assert_true(isnan(v.brdf[2]) && isnan(v.u[2]));
    /* A stated nonlinearity: its 10 % uncertainty over the two signals. */
    s.nonlinearity = 0.02;
    ref.counts[0] = 10100;
    assert_int_equal(rad_reduce(&cal, &s, 1, &v, NULL), 0);
    double xs = rad_linearise(5000, 0.02, 65535), xr = rad_linearise(10000, 0.02, 65535);
    assert_rel_close(v.rel[RAD_U_NONLINEARITY][0], 0.1 * 0.02 * (xr - xs) / 65535, 1e-12);
    /* The same dark set for both: its error cancels in part. */
    s.integration_s = 0.1, s.nonlinearity = 0;
    assert_int_equal(rad_reduce(&cal, &s, 1, &v, NULL), 0);
    assert_rel_close(v.rel[RAD_U_DARK][0], fabs(1.0 / 5100 - 1.0 / 1e4) * 8 / 4 * 5100 / 5100,
                     1e-12);
    assert_true(rad_term_systematic(RAD_U_REFERENCE) && rad_term_systematic(RAD_U_GEOMETRY));
    assert_false(rad_term_systematic(RAD_U_COUNTING));
    assert_string_equal(rad_term_name(RAD_U_ANGLE), "angle");
}

static void test_uncovered_calibration_refused(void **state)
{
    (void)state;
    struct syn_rig r;
    syn_rig_init(&r, 4, 0);
    const double geo[][2] = {{0, 20}};
    struct cal_store st;
    calibrate(&r, geo, 1, &st);
    struct gonio_err err = {0};
    assert_int_equal(rad_covers(&st.cal, 0.4, 0, &err), 0);
    assert_int_equal(rad_covers(&st.cal, 0.8, 0, &err), -GONIO_EBADCONFIG);
    assert_non_null(strstr(err.msg, "integration 0.8 s"));
    assert_int_equal(rad_covers(&st.cal, 0.1, 1, &err), -GONIO_EBADCONFIG);
    assert_non_null(strstr(err.msg, "gain state 1"));
    struct rad_raw raw;
    syn_sample(&r, 0, 20, 0.8, &raw);
    struct rad_value v;
    assert_int_equal(rad_reduce(&st.cal, &raw, 1, &v, &err), -GONIO_EBADCONFIG);
    assert_non_null(strstr(err.msg, "integration 0.8 s"));
}

/* The slope the angle term takes from sample k's nearest neighbours along
 * one angle with the other equal, found by passing over every sample (the
 * definition; the reduction may find them faster). NAN: none within 12 deg. */
static double slope_by_pass(const struct rad_raw *raw, const struct rad_value *v, size_t n,
                            size_t k, int c, int along_r)
{
    long lo = -1, hi = -1;
    for (size_t j = 0; j < n; j++) {
        double aj = along_r ? raw[j].theta_i : raw[j].theta_r;
        double ak = along_r ? raw[k].theta_i : raw[k].theta_r;
        if (j == k || fabs(aj - ak) > 0.01 || !(v[j].brdf[c] > 0))
            continue;
        double x = along_r ? raw[j].theta_r : raw[j].theta_i;
        double x0 = along_r ? raw[k].theta_r : raw[k].theta_i;
        double xl = lo < 0 ? 0 : along_r ? raw[lo].theta_r : raw[lo].theta_i;
        double xh = hi < 0 ? 0 : along_r ? raw[hi].theta_r : raw[hi].theta_i;
        if (x < x0 - 0.01 && x >= x0 - 12 && (lo < 0 || x > xl))
            lo = (long)j;
        if (x > x0 + 0.01 && x <= x0 + 12 && (hi < 0 || x < xh))
            hi = (long)j;
    }
    long a = lo >= 0 ? lo : (long)k, b = hi >= 0 ? hi : (long)k;
    if (a == b)
        return NAN;
    double xa = along_r ? raw[a].theta_r : raw[a].theta_i;
    double xb = along_r ? raw[b].theta_r : raw[b].theta_i;
    return log(v[b].brdf[c] / v[a].brdf[c]) / (xb - xa);
}

/* The angle term of every sample of a capture given in no particular
 * order: the reference's share (the sample reduced alone, without
 * neighbours) and the sample's own slopes from its nearest neighbours,
 * rows of equal theta_i and columns of equal theta_r, a repeat and a
 * geometry within the tolerance among them, one row too far from the next
 * (15 deg) to give a slope along theta_i. */
static void test_angle_term_from_nearest_neighbours(void **state)
{
    (void)state;
    struct syn_rig r;
    syn_rig_init(&r, 5, 0);
    r.band_deg = 0.1;
    const double rows[] = {20, 0, 35, 10}, cols[] = {30, -40, 5, -25, 45, 0, -20, 10, -30};
    double geo[40][2];
    size_t n = 0;
    for (size_t i = 0; i < 4; i++)
        for (size_t j = 0; j < 9; j++)
            geo[n][0] = rows[i], geo[n][1] = cols[(j * 4 + i) % 9], n++;
    geo[n][0] = 10, geo[n][1] = 5, n++;        /* a repeat */
    geo[n][0] = 20.005, geo[n][1] = -25, n++;  /* the same row, within 0.01 deg */
    struct cal_store st;
    calibrate(&r, (const double(*)[2])geo, n, &st);
    struct rad_raw raw[40];
    for (size_t k = 0; k < n; k++)
        syn_sample(&r, geo[k][0], geo[k][1], 0.1, &raw[k]);
    struct rad_value v[40], alone;
    assert_int_equal(rad_reduce(&st.cal, raw, n, v, NULL), 0);
    const double u2 = 0.1 * 0.1 / 3.0;
    size_t sloped = 0;
    for (size_t k = 0; k < n; k++) {
        assert_int_equal(rad_reduce(&st.cal, &raw[k], 1, &alone, NULL), 0);
        for (int c = 0; c < 3; c++) {
            double dr = slope_by_pass(raw, v, n, k, c, 1), di = slope_by_pass(raw, v, n, k, c, 0);
            dr = isnan(dr) ? 0.0 : dr;
            di = isnan(di) ? -dr : di;
            double ds = di - dr, ref_a = alone.rel[RAD_U_ANGLE][c];
            double want = sqrt(ref_a * ref_a + (ds * ds + dr * dr) * u2);
            assert_rel_close(v[k].rel[RAD_U_ANGLE][c], want, 1e-12);
            sloped += want > 1.01 * ref_a;
        }
    }
    assert_true(sloped > 3 * n / 2); /* most samples sit on a slope */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_linearise_inverts_the_response),
        cmocka_unit_test(test_recovers_the_brdf_exactly),
        cmocka_unit_test(test_dark_and_nonlinearity_together),
        cmocka_unit_test(test_reference_interpolated),
        cmocka_unit_test(test_budget_terms_by_formula),
        cmocka_unit_test(test_uncovered_calibration_refused),
        cmocka_unit_test(test_angle_term_from_nearest_neighbours),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
