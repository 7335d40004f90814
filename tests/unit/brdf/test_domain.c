/* Reference domains: node counts and membership against the test's own
 * closed-form polar angles of each MERL node, and the seeded subset. */
#include "brdf/domain.h"
#include "tests/gonio_test.h"

#include <string.h>

#define PI 3.14159265358979323846

/* The grid's angles and their cosines and sines, computed here. */
static double th_of(int i)
{
    return (i / 90.0) * (i / 90.0) * PI / 2;
}

struct cs {
    double c, s;
};
static struct cs th_cs[90], td_cs[90], pd_cs[181];
static double cos_limit; /* cos(80 degrees + the rule's 1e-9 degree tolerance) */

static int setup(void **state)
{
    (void)state;
    for (int i = 0; i < 90; i++) {
        th_cs[i] = (struct cs){cos(th_of(i)), sin(th_of(i))};
        td_cs[i] = (struct cs){cos(i / 90.0 * PI / 2), sin(i / 90.0 * PI / 2)};
    }
    for (int k = 0; k <= 180; k++)
        pd_cs[k] = (struct cs){cos(k / 180.0 * PI), sin(k / 180.0 * PI)};
    cos_limit = cos((80 + 1e-9) * PI / 180);
    return 0;
}

/* Whether node (i, j, k) (phi_h = 0) is in the domain, from the rotation by
 * theta_h about y written out by hand:
 *   cos theta_i = cos th cos td - sin th sin td cos pd
 *   cos theta_o = cos th cos td + sin th sin td cos pd
 * both polar angles <= 80 degrees (+1e-9) <=> both cosines >= cos_limit. */
static int node_kept(int i, int j, int k)
{
    double a = th_cs[i].c * td_cs[j].c, b = th_cs[i].s * td_cs[j].s * pd_cs[k].c;
    return a - b >= cos_limit && a + b >= cos_limit;
}

/* Grid indices of a pair, or -1 when it is not on a node. */
static int node_index(const struct brdf_pair *p, int *i, int *j, int *k)
{
    double u = sqrt(p->theta_h / (PI / 2)) * 90, v = p->theta_d / (PI / 2) * 90,
           w = p->phi_d / PI * 180;
    *i = (int)lround(u);
    *j = (int)lround(v);
    *k = (int)lround(w);
    if (fabs(p->theta_h - th_of(*i)) > 1e-12 || fabs(v - *j) > 1e-9 || fabs(w - *k) > 1e-9)
        return -1;
    return 0;
}

/* Every member on a node, in strictly increasing node order (no duplicates);
 * members of the rows theta_h index i with row(i) also kept by the test's
 * rule and with the directions of their node. */
static void check_members(const struct brdf_domain *d, int inplane, int (*row)(int))
{
    long prev = -1;
    for (size_t n = 0; n < d->n; n++) {
        const struct brdf_pair *p = &d->pairs[n];
        int i, j, k;
        assert_int_equal(node_index(p, &i, &j, &k), 0);
        assert_true(i >= 0 && i < 90 && j >= 0 && j < 90);
        if (inplane)
            assert_true(k == 0 || k == 180);
        else
            assert_true(k >= 0 && k < 180);
        /* Strictly increasing node number: no duplicates, documented order. */
        long key = ((long)i * 90 + j) * 181 + k;
        assert_true(key > prev);
        prev = key;
        if (!row(i))
            continue;
        assert_true(node_kept(i, j, k));
        /* The directions are those of the node. */
        double ti = brdf_pair_theta_i_deg(p) * BRDF_DEG;
        assert_close(cos(ti), cos(p->theta_h) * cos(p->theta_d) -
                                  sin(p->theta_h) * sin(p->theta_d) * cos(p->phi_d), 1e-12);
    }
}

static int every_row(int i)
{
    (void)i;
    return 1;
}

/* The small size (valgrind): 13 rows of 90 in full, the first and last
 * among them, and the rest by node order only. */
static int some_rows(int i)
{
    return i % 8 == 0 || i == 89;
}

static void test_full_domain(void **state)
{
    (void)state;
    int (*row)(int) = gonio_test_small() ? some_rows : every_row;
    struct brdf_domain d;
    assert_int_equal(brdf_domain_full(&d, NULL), 0);
    /* Node counts row by row against the test's own rule. */
    size_t expect = 0, n = 0;
    for (int i = 0; i < 90; i++) {
        size_t want = 0, got = 0;
        for (; n < d.n && d.pairs[n].theta_h <= th_of(i) + 1e-12; n++)
            got++;
        if (!row(i))
            continue;
        for (int j = 0; j < 90; j++)
            for (int k = 0; k < 180; k++)
                want += node_kept(i, j, k);
        if (got != want)
            fail_msg("row theta_h index %d: %zu nodes, expected %zu", i, got, want);
        expect += want;
    }
    assert_int_equal(n, d.n);
    print_message("full domain: %zu nodes (independent count %zu over the rows checked)\n",
                  d.n, expect);
    if (row == every_row)
        assert_int_equal(d.n, expect);
    assert_true(d.n > 900000 && d.n < 950000); /* "about 924k" in DESIGN.md */
    check_members(&d, 0, row);
    brdf_domain_free(&d);
    assert_null(d.pairs);
}

static void test_inplane_domain(void **state)
{
    (void)state;
    size_t expect = 0;
    for (int i = 0; i < 90; i++)
        for (int j = 0; j < 90; j++)
            expect += node_kept(i, j, 0) + node_kept(i, j, 180);
    struct brdf_domain d;
    assert_int_equal(brdf_domain_inplane(&d, NULL), 0);
    print_message("in-plane domain: %zu nodes (independent count %zu)\n", d.n, expect);
    assert_int_equal(d.n, expect);
    assert_true(d.n > 9000 && d.n < 9400); /* "about 9.2k" */
    check_members(&d, 1, every_row);
    /* In-plane really is in the plane: theta_i + signed theta_r. */
    for (size_t n = 0; n < d.n; n++) {
        double ti, tr;
        assert_int_equal(brdf_pair_to_inplane(&d.pairs[n], &ti, &tr), 0);
        assert_true(fabs(ti) <= 80 + 1e-9 && fabs(tr) <= 80 + 1e-9);
    }
    brdf_domain_free(&d);
}

static void test_splitmix64(void **state)
{
    (void)state;
    uint64_t s = 0;
    assert_true(brdf_splitmix64(&s) == UINT64_C(0xe220a8397b1dcdaf));
    assert_true(brdf_splitmix64(&s) == UINT64_C(0x6e789e6aa1b965f4));
    assert_true(brdf_splitmix64(&s) == UINT64_C(0x06c45d188009454f));
}

static void test_random_subset(void **state)
{
    (void)state;
    struct brdf_domain a, b, c, full;
    assert_int_equal(brdf_domain_full(&full, NULL), 0);
    assert_int_equal(brdf_domain_oop_random(&a, 5000, 42, NULL), 0);
    assert_int_equal(brdf_domain_oop_random(&b, 5000, 42, NULL), 0);
    assert_int_equal(brdf_domain_oop_random(&c, 5000, 43, NULL), 0);
    assert_int_equal(a.n, 5000);
    assert_memory_equal(a.pairs, b.pairs, a.n * sizeof *a.pairs);
    assert_true(memcmp(a.pairs, c.pairs, a.n * sizeof *a.pairs) != 0);
    check_members(&a, 0, every_row); /* distinct nodes of the full domain, in order */
    brdf_domain_free(&c);

    /* Spread: the subset's mean theta_d matches the full domain's. */
    double ma = 0, mf = 0;
    for (size_t n = 0; n < a.n; n++)
        ma += a.pairs[n].theta_d;
    for (size_t n = 0; n < full.n; n++)
        mf += full.pairs[n].theta_d;
    assert_close(ma / a.n, mf / full.n, 0.02);

    /* All of it: a permutation of the full domain, back in grid order. */
    struct brdf_domain all;
    assert_int_equal(brdf_domain_oop_random(&all, full.n, 7, NULL), 0);
    assert_int_equal(all.n, full.n);
    assert_memory_equal(all.pairs, full.pairs, full.n * sizeof *full.pairs);

    struct gonio_err err = {0};
    assert_int_equal(brdf_domain_oop_random(&c, full.n + 1, 42, &err), -GONIO_EBADCONFIG);
    assert_non_null(strstr(err.msg, "n = "));
    assert_null(c.pairs);
    brdf_domain_free(&c);
    brdf_domain_free(&all);
    brdf_domain_free(&a);
    brdf_domain_free(&b);
    brdf_domain_free(&full);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_full_domain),
        cmocka_unit_test(test_inplane_domain),
        cmocka_unit_test(test_splitmix64),
        cmocka_unit_test(test_random_subset),
    };
    return cmocka_run_group_tests(tests, setup, NULL);
}
