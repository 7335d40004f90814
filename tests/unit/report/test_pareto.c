/* Pareto front: known points give a known front. */
#include "tests/gonio_test.h"

#include "report/pareto.h"

static void known_front(void **state)
{
    (void)state;
    /* rig time, error. Front by hand: 0 (10, 0.5), 2 (20, 0.3), 4 (100, 0.1),
     * 6 (1000, 0.05). Off: 1 (30, 0.4) beaten by 2; 3 (50, 0.3) ties 2's
     * error at more time; 5 (200, 0.2) beaten by 4; 7 (5000, 0.05) ties 6. */
    const double x[] = {10, 30, 20, 50, 100, 200, 1000, 5000};
    const double y[] = {0.5, 0.4, 0.3, 0.3, 0.1, 0.2, 0.05, 0.05};
    size_t idx[8];
    size_t n = report_pareto_front(x, y, 8, idx);
    assert_int_equal(n, 4);
    assert_int_equal(idx[0], 0);
    assert_int_equal(idx[1], 2);
    assert_int_equal(idx[2], 4);
    assert_int_equal(idx[3], 6);
}

static void same_cost_keeps_the_better(void **state)
{
    (void)state;
    const double x[] = {5, 5, 5};
    const double y[] = {0.3, 0.1, 0.2};
    size_t idx[3];
    assert_int_equal(report_pareto_front(x, y, 3, idx), 1);
    assert_int_equal(idx[0], 1);
}

static void duplicates_and_nonfinite(void **state)
{
    (void)state;
    const double x[] = {1, NAN, 1, 2, 3};
    const double y[] = {0.2, 0.01, 0.2, INFINITY, 0.1};
    size_t idx[5];
    size_t n = report_pareto_front(x, y, 5, idx);
    assert_int_equal(n, 2);
    assert_int_equal(idx[0], 0); /* the first of two identical points */
    assert_int_equal(idx[1], 4);
    assert_int_equal(report_pareto_front(x, y, 0, idx), 0);
}

/* Brute force on pseudo-random points: every front point is undominated,
 * every other point is dominated (or a later duplicate). */
static void matches_brute_force(void **state)
{
    (void)state;
    enum { N = 300 };
    double x[N], y[N];
    unsigned s = 12345;
    for (int i = 0; i < N; i++) {
        s = s * 1103515245u + 12345u;
        x[i] = (double)(s >> 16 & 63);
        s = s * 1103515245u + 12345u;
        y[i] = (double)(s >> 16 & 63);
    }
    size_t idx[N];
    size_t n = report_pareto_front(x, y, N, idx);
    int on[N] = {0};
    for (size_t k = 0; k < n; k++) {
        on[idx[k]] = 1;
        if (k)
            assert_true(x[idx[k]] > x[idx[k - 1]] && y[idx[k]] < y[idx[k - 1]]);
    }
    for (int i = 0; i < N; i++) {
        int dominated = 0, earlier_twin = 0;
        for (int j = 0; j < N; j++) {
            if (x[j] <= x[i] && y[j] <= y[i] && (x[j] < x[i] || y[j] < y[i]))
                dominated = 1;
            if (j < i && x[j] == x[i] && y[j] == y[i])
                earlier_twin = 1;
        }
        assert_int_equal(on[i], !dominated && !earlier_twin);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(known_front),
        cmocka_unit_test(same_cost_keeps_the_better),
        cmocka_unit_test(duplicates_and_nonfinite),
        cmocka_unit_test(matches_brute_force),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
