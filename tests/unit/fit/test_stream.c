/* Streaming fit: the stop rule on exact data of a known ABC model, stop: all,
 * min_points and determinism. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fit/stream.h"
#include "tests/gonio_test.h"

static const struct brdf_abc truth = {
    .kd = {0.20, 0.15, 0.10}, .A = {20.0, 15.0, 10.0}, .B = 3000, .C = 0.9, .eta = 1.5};

/* An in-plane grid written out here (theta_i 0..75 step 5, theta_r -80..80
 * step 2 outside the blind zone), shuffled with a fixed LCG so that every
 * prefix is spread like a progressive capture. */
static size_t make_samples(struct fit_sample *out, size_t cap)
{
    size_t n = 0;
    for (int ti = 0; ti <= 75; ti += 5)
        for (int tr = -80; tr <= 80; tr += 2) {
            if (abs(ti + tr) < 5 || n == cap)
                continue;
            brdf_pair_inplane(ti, tr, &out[n].g);
            brdf_abc_eval(&truth, &out[n].g, out[n].rgb);
            n++;
        }
    unsigned long long x = 12345;
    for (size_t i = n; i-- > 1;) {
        x = x * 6364136223846793005ULL + 1442695040888963407ULL;
        size_t j = (size_t)((x >> 33) % (i + 1));
        struct fit_sample t = out[i];
        out[i] = out[j];
        out[j] = t;
    }
    return n;
}

static struct fit_stream_options opts(long min_points)
{
    struct fit_stream_options o = fit_stream_default_options();
    o.every = 20;
    o.rounds = 2;
    o.min_points = min_points;
    return o;
}

/* Feeds samples until the stream converges; returns the samples fed. */
static size_t feed(fit_stream *s, const struct fit_sample *smp, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        int rc = fit_stream_add(s, &smp[i], 0, NULL);
        assert_true(rc >= 0);
        if (rc == 1)
            return i + 1;
    }
    return n;
}

static void test_converges_on_exact_data(void **state)
{
    (void)state;
    static struct fit_sample smp[2000];
    size_t n = make_samples(smp, 2000);
    assert_true(n > 1000);
    fit_stream *s;
    struct fit_stream_options o = opts(100);
    assert_int_equal(fit_stream_new(&o, &s, NULL), 0);
    size_t used = feed(s, smp, n);
    struct fit_stream_status st;
    fit_stream_status(s, &st);
    assert_int_equal(st.converged, 1);
    assert_true(st.converged_at == used);
    /* never before min_points, and a few rounds after it on exact data */
    assert_true(used >= 100);
    assert_true(used <= 100 + 3 * 20);
    assert_true(st.rounds >= 2);
    assert_true(st.change < o.tol);
    /* the model it stopped with is the truth: compare with the ABC
     * evaluation of the true parameters at pairs no sample had */
    const struct brdf_abc *p = fit_stream_params(s);
    assert_non_null(p);
    for (int ti = 2; ti < 80; ti += 11)
        for (int tr = -77; tr < 80; tr += 13) {
            if (abs(ti + tr) < 5)
                continue;
            struct brdf_pair g;
            double a[3], b[3];
            brdf_pair_inplane(ti, tr, &g);
            brdf_abc_eval(&truth, &g, a);
            brdf_abc_eval(p, &g, b);
            for (int c = 0; c < 3; c++)
                assert_rel_close(b[c], a[c], 1e-3);
        }
    /* further samples keep the decision */
    assert_int_equal(fit_stream_add(s, &smp[used], 0, NULL), 1);
    fit_stream_free(s);
}

static void test_min_points_holds(void **state)
{
    (void)state;
    static struct fit_sample smp[2000];
    size_t n = make_samples(smp, 2000);
    fit_stream *s;
    struct fit_stream_options o = opts(500);
    assert_int_equal(fit_stream_new(&o, &s, NULL), 0);
    size_t used = feed(s, smp, n);
    struct fit_stream_status st;
    fit_stream_status(s, &st);
    assert_int_equal(st.converged, 1);
    assert_true(used >= 500);
    /* the rounds were calm long before: only min_points held it back */
    assert_true(st.calm > 2);
    fit_stream_free(s);

    o = opts((long)n + 1);
    assert_int_equal(fit_stream_new(&o, &s, NULL), 0);
    assert_int_equal(feed(s, smp, n), n);
    fit_stream_status(s, &st);
    assert_int_equal(st.converged, 0);
    fit_stream_free(s);
}

static void test_stop_all_never_stops(void **state)
{
    (void)state;
    static struct fit_sample smp[2000];
    size_t n = make_samples(smp, 2000);
    fit_stream *s;
    struct fit_stream_options o = opts(10);
    o.converge = 0;
    assert_int_equal(fit_stream_new(&o, &s, NULL), 0);
    for (size_t i = 0; i < n; i++)
        assert_int_equal(fit_stream_add(s, &smp[i], i % 100 == 99, NULL), 0);
    struct fit_stream_status st;
    fit_stream_status(s, &st);
    assert_int_equal(st.converged, 0);
    assert_int_equal(st.converged_at, 0);
    assert_true(st.rounds >= (int)(n / 20) - 1); /* rounds ran all the same */
    fit_stream_free(s);
}

static void test_deterministic(void **state)
{
    (void)state;
    static struct fit_sample smp[2000];
    size_t n = make_samples(smp, 2000);
    /* a material the model does not hold exactly: add a smooth multiplicative
     * bias so that the rounds do not all sit at the exact optimum */
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            smp[i].rgb[c] *= 1 + 0.2 * sin(3 * smp[i].g.theta_h + c);
    struct fit_stream_status st[2];
    struct brdf_abc par[2];
    size_t used[2];
    for (int k = 0; k < 2; k++) {
        fit_stream *s;
        struct fit_stream_options o = opts(200);
        assert_int_equal(fit_stream_new(&o, &s, NULL), 0);
        used[k] = feed(s, smp, n);
        fit_stream_status(s, &st[k]);
        assert_non_null(fit_stream_params(s));
        par[k] = *fit_stream_params(s);
        fit_stream_free(s);
    }
    assert_int_equal(used[0], used[1]);
    assert_int_equal(st[0].converged, st[1].converged);
    assert_int_equal(st[0].rounds, st[1].rounds);
    assert_memory_equal(&par[0], &par[1], sizeof par[0]);
}

static void test_bad_options(void **state)
{
    (void)state;
    fit_stream *s = (fit_stream *)1;
    struct fit_stream_options o = opts(10);
    o.tol = 0;
    struct gonio_err err = {0};
    assert_int_equal(fit_stream_new(&o, &s, &err), -GONIO_EBADCONFIG);
    assert_null(s);
    assert_non_null(strstr(err.msg, "tol"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_converges_on_exact_data),
        cmocka_unit_test(test_min_points_holds),
        cmocka_unit_test(test_stop_all_never_stops),
        cmocka_unit_test(test_deterministic),
        cmocka_unit_test(test_bad_options),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
