/* The full-domain error's estimate (capture/oop_estimate.h): from ten
 * nodes drawn in proportion to the model's brightness it comes within 25%
 * of the mean over 20,000 nodes of the full domain drawn at random, with
 * that mean inside its interval (to the mean's own 2%), for a model whose lobe is too narrow (the
 * error on the lobe) and for one 20% too bright everywhere (the error
 * spread over the domain); a model equal to the material is estimated
 * exact; the nodes are nodes of the domain, measured in travel order. */
#include <math.h>
#include <string.h>

#include "brdf/domain.h"
#include "brdf/material.h"
#include "capture/oop_check.h"
#include "tests/gonio_test.h"

static double mean_of(const brdf_material *m, const struct brdf_pair *p)
{
    double rgb[3];
    brdf_material_eval(m, p, 1, rgb);
    return (rgb[0] + rgb[1] + rgb[2]) / 3.0;
}

/* A model: a material, its values scaled. */
struct model {
    brdf_material *m;
    double scale;
};

static double predict(void *user, const struct brdf_pair *p)
{
    const struct model *md = user;
    return md->scale * mean_of(md->m, p);
}

/* The material measured, the pairs' theta_i in the order read. */
struct bench {
    brdf_material *m;
    double theta_i[OOP_ESTIMATE_PAIRS];
    size_t n;
};

static int measure(void *user, const struct oop_check_pair *p, int in_plane, double *value,
                   struct gonio_err *err)
{
    (void)err;
    struct bench *b = user;
    assert_int_equal(in_plane, 0);
    struct brdf_pair bp;
    brdf_pair_spherical(p->theta_i, 0, p->theta_o, p->phi_o, &bp);
    if (b->n < OOP_ESTIMATE_PAIRS)
        b->theta_i[b->n++] = p->theta_i;
    *value = mean_of(b->m, &bp);
    return 0;
}

static brdf_material *open_or_die(const char *spec)
{
    struct gonio_err err = {0};
    brdf_material *m = brdf_material_open(spec, &err);
    if (!m)
        fail_msg("%s: %s", spec, err.msg);
    return m;
}

#define TRUTH "analytic:aniso-ggx?ax=0.1&ay=0.1&phi=0"

/* The error the estimate stands for: the mean of the error term over
 * 20,000 nodes of the full domain drawn at random (the full domain's mean
 * to about 2%). */
static double domain_error(struct model *md, brdf_material *truth)
{
    struct brdf_domain d;
    struct gonio_err err = {0};
    assert_int_equal(brdf_domain_oop_random(&d, 20000, 11, &err), 0);
    double sum = 0;
    for (size_t k = 0; k < d.n; k++)
        sum += oop_check_error(mean_of(truth, &d.pairs[k]), predict(md, &d.pairs[k]),
                               brdf_pair_theta_i_deg(&d.pairs[k]));
    size_t n = d.n;
    brdf_domain_free(&d);
    return sum / (double)n;
}

static void estimate(const char *model, double scale, struct oop_estimate *e, struct bench *b,
                     double *truth_error)
{
    struct model md = {open_or_die(model), scale};
    *b = (struct bench){.m = open_or_die(TRUTH)};
    struct gonio_err err = {0};
    assert_int_equal(oop_estimate_run(predict, &md, measure, b, e, &err), 0);
    *truth_error = domain_error(&md, b->m);
    brdf_material_free(b->m);
    brdf_material_free(md.m);
}

static void test_estimates_the_domain_error(void **state)
{
    (void)state;
    static const struct {
        const char *model;
        double scale;
    } cases[] = {{"analytic:aniso-ggx?ax=0.07&ay=0.07&phi=0", 1.0},
                 {TRUTH, 1.2},
                 {"analytic:aniso-ggx?ax=0.15&ay=0.15&phi=0", 0.9}};
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        struct oop_estimate e;
        struct bench b;
        double truth;
        estimate(cases[i].model, cases[i].scale, &e, &b, &truth);
        print_message("%s x%.1f: estimate %.4f [%.4f, %.4f], domain %.4f\n", cases[i].model,
                      cases[i].scale, e.error, e.low, e.high, truth);
        assert_int_equal(e.pairs, OOP_ESTIMATE_PAIRS);
        assert_int_equal(e.used, OOP_ESTIMATE_PAIRS);
        assert_true(fabs(e.error / truth - 1) < 0.25);
        /* inside the interval, to the reference's own 2% */
        assert_true(e.low <= 1.03 * truth && 0.97 * truth <= e.high);
        assert_true(e.low <= e.error && e.error <= e.high);
    }
}

static void test_the_material_itself_is_exact(void **state)
{
    (void)state;
    struct oop_estimate e;
    struct bench b;
    double truth;
    estimate(TRUTH, 1.0, &e, &b, &truth);
    assert_true(truth == 0 && e.error == 0 && e.low == 0 && e.high == 0);
}

static void test_nodes_of_the_domain_in_travel_order(void **state)
{
    (void)state;
    struct model md = {open_or_die(TRUTH), 1.0};
    struct oop_check_pair p[OOP_ESTIMATE_PAIRS];
    double mean_density = 0;
    assert_int_equal(oop_estimate_choose(predict, &md, p, &mean_density), OOP_ESTIMATE_PAIRS);
    assert_true(mean_density > OOP_ESTIMATE_FLOOR && mean_density < 1 + OOP_ESTIMATE_FLOOR);
    size_t near_mirror = 0;
    for (size_t j = 0; j < OOP_ESTIMATE_PAIRS; j++) {
        struct brdf_pair bp;
        brdf_pair_spherical(p[j].theta_i, 0, p[j].theta_o, p[j].phi_o, &bp);
        assert_true(brdf_domain_keeps(&bp));
        /* theta_h on the grid: (i / 90)^2 90 degrees */
        double i = sqrt(bp.theta_h / (90 * BRDF_DEG)) * 90;
        assert_close(i, round(i), 1e-6);
        assert_close(p[j].predicted, predict(&md, &bp), 1e-9);
        near_mirror += bp.theta_h < 5 * BRDF_DEG;
    }
    /* drawn as the model's brightness weighs: the lobe (theta_h < 5 deg,
     * 24% of the nodes) holds most of them */
    assert_true(near_mirror >= OOP_ESTIMATE_PAIRS / 2);
    brdf_material_free(md.m);
    /* read by theta_i in 15 degree bands, rising */
    struct oop_estimate e;
    struct bench b;
    double truth;
    estimate(TRUTH, 1.1, &e, &b, &truth);
    assert_int_equal(b.n, OOP_ESTIMATE_PAIRS);
    for (size_t j = 1; j < b.n; j++)
        assert_true((int)(b.theta_i[j] / 15) >= (int)(b.theta_i[j - 1] / 15));
}

static void test_too_few_readings_no_estimate(void **state)
{
    (void)state;
    struct oop_check_pair p[OOP_ESTIMATE_PAIRS] = {{0}};
    double m[OOP_ESTIMATE_PAIRS];
    for (size_t j = 0; j < OOP_ESTIMATE_PAIRS; j++) {
        p[j] = (struct oop_check_pair){.theta_i = 30, .predicted = 1, .in_predicted = 0.5};
        m[j] = j < OOP_ESTIMATE_MIN_USED - 1 ? 1.1 : NAN;
    }
    struct oop_estimate e;
    oop_estimate_decide(p, OOP_ESTIMATE_PAIRS, m, 0.5, &e);
    assert_int_equal(e.used, OOP_ESTIMATE_MIN_USED - 1);
    assert_true(isnan(e.error) && isnan(e.low) && isnan(e.high));
    /* one more: the weighted mean, e_j / density_j times the mean density */
    m[OOP_ESTIMATE_MIN_USED - 1] = 1.1;
    oop_estimate_decide(p, OOP_ESTIMATE_PAIRS, m, 0.5, &e);
    double one = oop_check_error(1.1, 1, 30);
    assert_close(e.error, one, 1e-12);
    assert_close(e.low, e.error, 1e-12); /* no spread between strata */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_estimates_the_domain_error),
        cmocka_unit_test(test_the_material_itself_is_exact),
        cmocka_unit_test(test_nodes_of_the_domain_in_travel_order),
        cmocka_unit_test(test_too_few_readings_no_estimate),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
