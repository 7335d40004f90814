/* The move-time lower bound: on small random plans it lies between an
 * independently computed minimum spanning tree and the exact optimum of
 * every open path from home (dynamic programming over subsets); on DS1 (DS2
 * at the small size, gonio_test_small) it is at least the spanning tree,
 * below the travel order, and travel is within 3% of it (the planner's
 * target). */
#include "tests/gonio_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "common/paths.h"
#include "planner/planner.h"

static struct rig_profile rig;

static int setup(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    return rig_profile_load("default", &rig, &err);
}

/* Trapezoidal move time written out from the design (default rig). */
static double axis_time(double d, double v, double a)
{
    d = fabs(d);
    return d >= v * v / a ? d / v + v / a : 2 * sqrt(d / a);
}

static double move(const struct rig_axes *p, const struct rig_axes *q)
{
    return fmax(axis_time(q->s - p->s, 20, 40), axis_time(q->a - p->a, 15, 30));
}

#define NMAX 11

/* Exact: cheapest open path from home (node n) through all n points. */
static double optimum(const struct rig_axes *ax, size_t n)
{
    static double dp[1 << NMAX][NMAX];
    struct rig_axes home = {0, 0, 0};
    size_t full = ((size_t)1 << n) - 1;
    for (size_t s = 1; s <= full; s++)
        for (size_t j = 0; j < n; j++)
            dp[s][j] = INFINITY;
    for (size_t j = 0; j < n; j++)
        dp[(size_t)1 << j][j] = move(&home, &ax[j]);
    for (size_t s = 1; s <= full; s++)
        for (size_t j = 0; j < n; j++) {
            if (!(s & ((size_t)1 << j)) || isinf(dp[s][j]))
                continue;
            for (size_t k = 0; k < n; k++) {
                if (s & ((size_t)1 << k))
                    continue;
                double c = dp[s][j] + move(&ax[j], &ax[k]);
                if (c < dp[s | ((size_t)1 << k)][k])
                    dp[s | ((size_t)1 << k)][k] = c;
            }
        }
    double best = INFINITY;
    for (size_t j = 0; j < n; j++)
        best = fmin(best, dp[full][j]);
    return best;
}

/* Prim over home + the points, written independently. */
static double mst(const struct rig_axes *ax, size_t n)
{
    struct rig_axes nodes[2000 + 1] = {{0, 0, 0}};
    memcpy(nodes + 1, ax, n * sizeof *ax);
    size_t m = n + 1;
    double key[2000 + 1], total = 0;
    char in[2000 + 1] = {0};
    for (size_t i = 0; i < m; i++)
        key[i] = i ? INFINITY : 0;
    for (size_t step = 0; step < m; step++) {
        size_t u = 0;
        for (size_t i = 0, f = 0; i < m; i++)
            if (!in[i] && (!f || key[i] < key[u])) {
                u = i;
                f = 1;
            }
        in[u] = 1;
        total += key[u];
        for (size_t i = 0; i < m; i++)
            if (!in[i])
                key[i] = fmin(key[i], move(&nodes[u], &nodes[i]));
    }
    return total;
}

static double path(const struct plan *p)
{
    struct rig_axes at = {0, 0, 0};
    double sum = 0;
    for (size_t i = 0; i < plan_count(p); i++) {
        sum += move(&at, &plan_point(p, i)->ax);
        at = plan_point(p, i)->ax;
    }
    return sum;
}

static void test_small_plans(void **state)
{
    (void)state;
    const char *tmp = getenv("GONIO_TMP");
    if (!tmp)
        tmp = "/tmp";
    assert_int_equal(gonio_mkdir_p(tmp, NULL), 0);
    char file[512];
    snprintf(file, sizeof file, "%s/lower-bound-%d.yaml", tmp, (int)getpid());
    unsigned long long x = 99;
    int checked = 0;
    for (int trial = 0; trial < 8; trial++) {
        size_t n = 6 + (size_t)trial % 6; /* 6..11 points */
        FILE *f = fopen(file, "w");
        assert_non_null(f);
        fprintf(f, "name: lb\npairs:\n");
        for (size_t k = 0; k < n;) {
            x = x * 6364136223846793005ULL + 1442695040888963407ULL;
            int ti = (int)((x >> 33) % 81), tr = (int)((x >> 20) % 161) - 80;
            if (abs(ti + tr) < 6)
                continue;
            fprintf(f, "  - [%d, %d]\n", ti, tr);
            k++;
        }
        fclose(f);
        struct plan *p;
        struct gonio_err err = {0};
        int rc = plan_load(file, &rig, &p, &err);
        if (rc < 0) /* a duplicate pair: draw again */
            continue;
        size_t m = plan_count(p);
        struct rig_axes ax[NMAX];
        for (size_t i = 0; i < m; i++)
            ax[i] = plan_point(p, i)->ax;
        double lb = plan_move_lower_bound(p, &rig);
        double opt = optimum(ax, m), tree = mst(ax, m);
        assert_true(lb >= tree - 1e-9);
        assert_true(lb <= opt + 1e-9);
        assert_int_equal(plan_order(p, PLAN_ORDER_TRAVEL, &rig), 0);
        assert_true(path(p) >= opt - 1e-9);
        plan_free(p);
        checked++;
    }
    unlink(file);
    assert_true(checked >= 5);
}

/* At the small size (valgrind) DS2: DS1's travel order and bound cost
 * memcheck minutes. */
static void test_ds1(void **state)
{
    (void)state;
    struct plan *p;
    struct gonio_err err = {0};
    assert_true(plan_load(gonio_test_small() ? "ds2" : "ds1", &rig, &p, &err) > 0);
    assert_int_equal(plan_order(p, PLAN_ORDER_TRAVEL, &rig), 0);
    size_t n = plan_count(p);
    struct rig_axes *ax = malloc(n * sizeof *ax);
    for (size_t i = 0; i < n; i++)
        ax[i] = plan_point(p, i)->ax;
    double lb = plan_move_lower_bound(p, &rig), tree = mst(ax, n), travel = path(p);
    assert_true(lb >= tree - 1e-6);
    assert_true(lb <= travel);
    assert_true(travel <= 1.03 * lb);
    free(ax);
    plan_free(p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_small_plans),
        cmocka_unit_test(test_ds1),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
