/* Domain plans: the reference domains of brdf/domain.h turned into plan
 * points, with only the rig's blind-zone nodes left out (and counted). */
#include "tests/gonio_test.h"

#include <string.h>
#include <unistd.h>

#include "brdf/domain.h"
#include "planner/planner.h"

static double separation_deg(const struct brdf_pair *p)
{
    double c = p->wi[0] * p->wo[0] + p->wi[1] * p->wo[1] + p->wi[2] * p->wo[2];
    return acos(fmax(-1, fmin(1, c))) / BRDF_DEG;
}

/* A plan file in a fresh folder; returns its path in path. */
static void write_plan(char *dir, char *path, size_t size, const char *text)
{
    assert_non_null(mkdtemp(dir));
    snprintf(path, size, "%s/plan.yaml", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static void remove_plan(char *dir, char *path)
{
    unlink(path);
    rmdir(dir);
}

/* The shipped inplane-full plan. At the small size (valgrind) the same
 * domain in the written order: the travel order of 9k points costs
 * memcheck minutes, and test_order covers ordering. */
static void test_inplane_full(void **state)
{
    (void)state;
    struct rig_profile rig;
    rig_profile_default(&rig);
    struct plan *p;
    struct gonio_err err = {0};
    char dir[] = "/tmp/gonio-domainXXXXXX", path[64];
    const char *name = "inplane-full";
    if (gonio_test_small()) {
        write_plan(dir, path, sizeof path, "domain: {set: inplane}\norder: as-written\n");
        name = path;
    }
    int n = plan_load(name, &rig, &p, &err);
    if (n < 0)
        print_error("%s\n", err.msg);
    assert_true(n > 0);
    struct brdf_domain dom = {0};
    assert_true(brdf_domain_inplane(&dom, &err) >= 0);
    /* the left-out nodes are exactly those with the arm within 5 deg */
    size_t blind = 0;
    for (size_t i = 0; i < dom.n; i++)
        blind += separation_deg(&dom.pairs[i]) < 5 - 1e-9;
    assert_int_equal(plan_dropped(p), blind);
    assert_int_equal(plan_count(p) + blind, dom.n);
    assert_false(plan_is_out_of_plane(p));
    for (size_t i = 0; i < plan_count(p); i++) {
        const struct plan_point *pt = plan_point(p, i);
        assert_false(pt->out_of_plane);
        assert_true(pt->theta_i >= 0 && pt->theta_i <= 80 + 1e-6);
        assert_true(fabs(pt->theta_r) <= 80 + 1e-6);
        assert_true(fabs(pt->theta_i + pt->theta_r) >= 5 - 1e-9);
        assert_close(pt->ax.a, pt->theta_i + pt->theta_r, 1e-12);
    }
    brdf_domain_free(&dom);
    plan_free(p);
    if (name == path)
        remove_plan(dir, path);
}

static void test_oop_random(void **state)
{
    (void)state;
    char dir[] = "/tmp/gonio-domainXXXXXX", path[64];
    write_plan(dir, path, sizeof path, "domain: {set: oop-random, n: 3000, seed: 7}\n"
                                       "order: as-written\n");
    struct rig_profile rig;
    rig_profile_default(&rig);
    struct plan *p;
    struct gonio_err err = {0};
    assert_true(plan_load(path, &rig, &p, &err) > 0);
    assert_true(plan_is_out_of_plane(p));
    struct brdf_domain dom = {0};
    assert_true(brdf_domain_oop_random(&dom, 3000, 7, &err) >= 0);
    /* kept nodes, in domain order, rebuild the same directions */
    size_t k = 0, blind = 0;
    for (size_t i = 0; i < dom.n; i++) {
        if (separation_deg(&dom.pairs[i]) < 5 - 1e-9) {
            blind++;
            continue;
        }
        const struct plan_point *pt = plan_point(p, k++);
        assert_non_null(pt);
        struct brdf_pair q;
        brdf_pair_spherical(pt->theta_i, pt->phi_i, pt->theta_o, pt->phi_o, &q);
        for (int c = 0; c < 3; c++) {
            assert_close(q.wi[c], dom.pairs[i].wi[c], 1e-9);
            assert_close(q.wo[c], dom.pairs[i].wo[c], 1e-9);
        }
    }
    assert_int_equal(k, plan_count(p));
    assert_int_equal(blind, plan_dropped(p));
    /* a rig without the azimuth axis refuses the plan */
    rig.out_of_plane = 0;
    struct plan *q;
    assert_int_equal(plan_load(path, &rig, &q, &err), -GONIO_EUNREACHABLE);
    assert_non_null(strstr(err.msg, "out-of-plane axis"));
    brdf_domain_free(&dom);
    plan_free(p);
    remove_plan(dir, path);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_inplane_full),
        cmocka_unit_test(test_oop_random),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
