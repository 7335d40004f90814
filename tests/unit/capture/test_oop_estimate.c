/* The full-domain error's estimate (capture/oop_estimate.h): from ten
 * nodes drawn in proportion to the model's brightness it comes within 25%
 * of the full-domain log error (brdf/metrics.h, per channel) over 20,000
 * nodes of the full domain drawn at random, with that error inside its
 * interval (to the reference's own 2%), for a model whose lobe is too
 * narrow (the error on the lobe), one 20% too bright everywhere (the
 * error spread over the domain), one too wide and one of the wrong colour
 * (red too bright, blue too dark: the mean of the channels nearly right,
 * each of them wrong); a model equal to the material is estimated exact;
 * the nodes are nodes of the domain, measured in travel order; the
 * interval is Student's t of the strata's spread. */
#include <math.h>
#include <string.h>

#include "brdf/domain.h"
#include "brdf/material.h"
#include "brdf/metrics.h"
#include "capture/oop_check.h"
#include "tests/gonio_test.h"

/* A model: a material, its channels scaled. */
struct model {
    brdf_material *m;
    double scale[3];
};

static void predict(void *user, const struct brdf_pair *p, double rgb[3])
{
    const struct model *md = user;
    brdf_material_eval(md->m, p, 1, rgb);
    for (int c = 0; c < 3; c++)
        rgb[c] *= md->scale[c];
}

/* The material measured, the pairs' theta_i in the order read. */
struct bench {
    brdf_material *m;
    double theta_i[OOP_ESTIMATE_PAIRS];
    size_t n;
};

static int measure(void *user, const struct oop_check_pair *p, int in_plane, double rgb[3],
                   struct gonio_err *err)
{
    (void)err;
    struct bench *b = user;
    assert_int_equal(in_plane, 0);
    struct brdf_pair bp;
    brdf_pair_spherical(p->theta_i, 0, p->theta_o, p->phi_o, &bp);
    if (b->n < OOP_ESTIMATE_PAIRS)
        b->theta_i[b->n++] = p->theta_i;
    brdf_material_eval(b->m, &bp, 1, rgb);
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

/* The error the estimate stands for: the full-domain log error
 * (brdf/metrics.h) over 20,000 nodes of the full domain drawn at random
 * (the full domain's to about 2%). */
static double domain_error(struct model *md, brdf_material *truth)
{
    struct brdf_domain d;
    struct gonio_err err = {0};
    assert_int_equal(brdf_domain_oop_random(&d, 20000, 11, &err), 0);
    double *t = malloc(3 * d.n * sizeof *t), *g = malloc(3 * d.n * sizeof *g);
    assert_non_null(t);
    assert_non_null(g);
    brdf_material_eval(truth, d.pairs, d.n, t);
    for (size_t k = 0; k < d.n; k++)
        predict(md, &d.pairs[k], g + 3 * k);
    struct brdf_errors e;
    brdf_errors_compute(d.pairs, t, g, d.n, &e);
    free(t);
    free(g);
    brdf_domain_free(&d);
    return e.log;
}

static void estimate(const char *model, const double scale[3], struct oop_estimate *e,
                     struct bench *b, double *truth_error)
{
    struct model md = {open_or_die(model), {scale[0], scale[1], scale[2]}};
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
        double scale[3];
    } cases[] = {{"analytic:aniso-ggx?ax=0.07&ay=0.07&phi=0", {1, 1, 1}},
                 {TRUTH, {1.2, 1.2, 1.2}},
                 {"analytic:aniso-ggx?ax=0.15&ay=0.15&phi=0", {0.9, 0.9, 0.9}},
                 {TRUTH, {1.25, 1, 0.75}}};
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        struct oop_estimate e;
        struct bench b;
        double truth;
        estimate(cases[i].model, cases[i].scale, &e, &b, &truth);
        print_message("%s x%.2f/%.2f/%.2f: estimate %.4f [%.4f, %.4f], domain %.4f\n",
                      cases[i].model, cases[i].scale[0], cases[i].scale[1], cases[i].scale[2],
                      e.error, e.low, e.high, truth);
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
    estimate(TRUTH, (const double[3]){1, 1, 1}, &e, &b, &truth);
    assert_true(truth == 0 && e.error == 0 && e.low == 0 && e.high == 0);
}

static void test_nodes_of_the_domain_in_travel_order(void **state)
{
    (void)state;
    struct model md = {open_or_die(TRUTH), {1, 1, 1}};
    struct oop_estimate_node p[OOP_ESTIMATE_PAIRS];
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
        double rgb[3];
        predict(&md, &bp, rgb);
        for (int c = 0; c < 3; c++)
            assert_close(p[j].predicted[c], rgb[c], 1e-9);
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
    estimate(TRUTH, (const double[3]){1.1, 1.1, 1.1}, &e, &b, &truth);
    assert_int_equal(b.n, OOP_ESTIMATE_PAIRS);
    for (size_t j = 1; j < b.n; j++)
        assert_true((int)(b.theta_i[j] / 15) >= (int)(b.theta_i[j - 1] / 15));
}

static void test_too_few_readings_no_estimate(void **state)
{
    (void)state;
    struct oop_estimate_node p[OOP_ESTIMATE_PAIRS];
    double m[OOP_ESTIMATE_PAIRS][3];
    for (size_t j = 0; j < OOP_ESTIMATE_PAIRS; j++) {
        p[j] = (struct oop_estimate_node){.theta_i = 30, .predicted = {1, 1, 1}, .density = 0.5};
        for (int c = 0; c < 3; c++)
            m[j][c] = j < OOP_ESTIMATE_MIN_USED - 1 ? 1.1 : NAN;
    }
    /* one channel unusable: the node left out */
    m[OOP_ESTIMATE_MIN_USED - 1][0] = m[OOP_ESTIMATE_MIN_USED - 1][1] = 1.1;
    struct oop_estimate e;
    oop_estimate_decide(p, OOP_ESTIMATE_PAIRS, (const double (*)[3])m, 0.5, &e);
    assert_int_equal(e.used, OOP_ESTIMATE_MIN_USED - 1);
    assert_true(isnan(e.error) && isnan(e.low) && isnan(e.high));
    /* one more: the weighted mean, e_j / density_j times the mean density */
    m[OOP_ESTIMATE_MIN_USED - 1][2] = 1.1;
    oop_estimate_decide(p, OOP_ESTIMATE_PAIRS, (const double (*)[3])m, 0.5, &e);
    double one = oop_check_error(1.1, 1, 30);
    assert_close(e.error, one, 1e-12);
    assert_close(e.low, e.error, 1e-12); /* no spread between strata */
    /* a spread: the strata (0, 1) and (2, 3) differ by d, 2 pairs, a
     * standard error of d / sqrt(2 x 4) and Student's t of 2 degrees */
    m[1][0] = m[1][1] = m[1][2] = m[3][0] = m[3][1] = m[3][2] = 1.3;
    oop_estimate_decide(p, OOP_ESTIMATE_PAIRS, (const double (*)[3])m, 0.5, &e);
    double two = oop_check_error(1.3, 1, 30), d = (two - one) / 0.5;
    assert_close(e.error, (one + two) / 2, 1e-12);
    assert_close(e.high - e.error, 0.5 * 4.303 * d / sqrt(8.0), 1e-9);
}

/* A node's term is the metric's, per channel: a reading of the right mean
 * and the wrong colour errs; a dark channel read below zero counts as 0. */
static void test_the_term_is_per_channel(void **state)
{
    (void)state;
    const double pred[3] = {1, 1, 1}, tint[3] = {1.5, 1, 0.5}, dark[3] = {-0.01, 0, 0};
    double w = cos(30 * BRDF_DEG);
    double want = (fabs(log1p(1.5 * w) - log1p(w)) + fabs(log1p(0.5 * w) - log1p(w))) / 3;
    assert_close(oop_estimate_error(tint, pred, 30), want, 1e-12);
    assert_close(oop_check_error((1.5 + 1 + 0.5) / 3, 1, 30), 0, 1e-12); /* the mean's: none */
    assert_true(isnan(oop_estimate_error(dark, pred, 30))); /* no light read */
    const double dim[3] = {-0.01, 0.5, 1};
    assert_close(oop_estimate_error(dim, pred, 30),
                 (log1p(w) + log1p(w) - log1p(0.5 * w)) / 3, 1e-12);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_estimates_the_domain_error),
        cmocka_unit_test(test_the_material_itself_is_exact),
        cmocka_unit_test(test_nodes_of_the_domain_in_travel_order),
        cmocka_unit_test(test_too_few_readings_no_estimate),
        cmocka_unit_test(test_the_term_is_per_channel),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
