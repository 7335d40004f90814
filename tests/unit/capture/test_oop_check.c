/* The in-plane sufficiency check's library (capture/oop_check.h): it puts
 * its validation pairs on the fitted model's flank, out of the plane of
 * incidence, each with an in-plane counterpart of the same theta_h and
 * theta_d; it says "insufficient" when the material turns out wider or
 * narrower across the plane than the model fitted along it (an anisotropic
 * GGX at 0 and 45 degrees), "sufficient" when the material is the model,
 * within 2% noise on 2,000 seeded checks (an isotropic GGX and a model
 * of its in-plane slice), and "undetermined" with too few
 * readings; it measures each incidence's out-of-plane pairs first. A
 * fitted lobe narrower than the rig's positioning band is "insufficient"
 * from the model alone, and its width is found between the search's steps. */
#include <math.h>
#include <string.h>

#include "brdf/domain.h"
#include "brdf/material.h"
#include "capture/oop_check.h"
#include "tests/gonio_test.h"

/* A model fitted perfectly along the plane: the material's in-plane slice,
 * extended to every pair by its theta_h and theta_d (as an isotropic model
 * is). */
static void predict(void *user, const struct brdf_pair *p, double rgb[3])
{
    struct brdf_pair in;
    brdf_pair_inplane((p->theta_d + p->theta_h) / BRDF_DEG, (p->theta_d - p->theta_h) / BRDF_DEG,
                      &in);
    brdf_material_eval(user, &in, 1, rgb);
}

/* Its mean of R, G, B: what the verdict compares. */
static double predicted(void *user, const struct brdf_pair *p)
{
    double rgb[3];
    predict(user, p, rgb);
    return (rgb[0] + rgb[1] + rgb[2]) / 3.0;
}

/* The material measured: a material with log noise sd per reading. */
struct bench {
    brdf_material *m;
    double sd;
    uint64_t st;
    int order[2 * OOP_CHECK_MAX_PAIRS], n_order;
};

static double gauss(uint64_t *st)
{
    double u = ((double)(brdf_splitmix64(st) >> 11) + 0.5) * 0x1p-53;
    double v = ((double)(brdf_splitmix64(st) >> 11) + 0.5) * 0x1p-53;
    return sqrt(-2 * log(u)) * cos(2 * 3.14159265358979323846 * v);
}

static int measure(void *user, const struct oop_check_pair *p, int in_plane, double rgb[3],
                   struct gonio_err *err)
{
    (void)err;
    struct bench *b = user;
    struct brdf_pair bp;
    if (in_plane)
        brdf_pair_inplane(p->in_theta_i, p->in_theta_r, &bp);
    else
        brdf_pair_spherical(p->theta_i, 0, p->theta_o, p->phi_o, &bp);
    if (b->n_order < 2 * OOP_CHECK_MAX_PAIRS)
        b->order[b->n_order++] = in_plane ? -(int)p->theta_i : (int)p->theta_i;
    double noise = b->sd > 0 ? exp(b->sd * gauss(&b->st)) : 1.0;
    brdf_material_eval(b->m, &bp, 1, rgb);
    for (int c = 0; c < 3; c++)
        rgb[c] *= noise;
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

#define MODEL "analytic:aniso-ggx?ax=0.1&ay=0.1&phi=0"

static void test_pairs_on_the_flank_with_counterparts(void **state)
{
    (void)state;
    brdf_material *model = open_or_die(MODEL);
    struct oop_check_pair p[OOP_CHECK_MAX_PAIRS];
    assert_int_equal(oop_check_choose(predict, model, p), OOP_CHECK_MAX_PAIRS);
    struct brdf_pair mirror;
    for (size_t j = 0; j < OOP_CHECK_MAX_PAIRS; j++) {
        struct brdf_pair bp, in;
        brdf_pair_spherical(p[j].theta_i, 0, p[j].theta_o, p[j].phi_o, &bp);
        brdf_pair_inplane(p[j].in_theta_i, p[j].in_theta_r, &in);
        /* out of the plane, the counterpart in it at the same theta_h, theta_d */
        assert_true(fabs(bp.wo[1]) > 0.05);
        assert_close(in.theta_h, bp.theta_h, 1e-9);
        assert_close(in.theta_d, bp.theta_d, 1e-9);
        assert_close(p[j].predicted, predicted(model, &bp), 1e-12);
        assert_close(p[j].in_predicted, predicted(model, &in), 1e-12);
        /* on the flank: fallen by the drop from the mirror, within a step */
        brdf_pair_inplane(p[j].theta_i, p[j].theta_i, &mirror);
        double drop = log(predicted(model, &mirror)) - log(p[j].predicted);
        assert_true(drop >= OOP_CHECK_DROP && drop < OOP_CHECK_DROP + 0.5);
    }
    assert_close(p[0].theta_i, 25, 0);
    assert_close(p[OOP_CHECK_MAX_PAIRS - 1].theta_i, 45, 0);
    brdf_material_free(model);
}

static void run_check(const char *material, double sd, uint64_t seed,
                      struct oop_check_result *r, struct bench *b)
{
    brdf_material *model = open_or_die(material);
    *b = (struct bench){.m = open_or_die(material), .sd = sd, .st = seed};
    struct gonio_err err = {0};
    assert_int_equal(oop_check_run(predict, model, measure, b, 0.1, r, &err), 0);
    brdf_material_free(b->m);
    brdf_material_free(model);
}

static void test_anisotropic_is_insufficient(void **state)
{
    (void)state;
    /* the model is the material's in-plane slice, the material twice as
     * rough (or half) across the plane; at 45 degrees both directions of
     * the plane see the same mean roughness, the diagonals differ */
    static const char *const aniso[] = {"analytic:aniso-ggx?ax=0.1&ay=0.2&phi=0",
                                        "analytic:aniso-ggx?ax=0.1&ay=0.05&phi=0",
                                        "analytic:aniso-ggx?ax=0.1&ay=0.2&phi=45",
                                        "analytic:aniso-ggx?ax=0.2&ay=0.3&phi=90"};
    for (size_t i = 0; i < sizeof aniso / sizeof *aniso; i++) {
        struct oop_check_result r;
        struct bench b;
        run_check(aniso[i], 0.02, 7, &r, &b);
                assert_string_equal(r.verdict, "insufficient");
        assert_true(r.ratio > OOP_CHECK_RATIO);
        assert_int_equal(r.pairs, OOP_CHECK_MAX_PAIRS);
        assert_int_equal(r.measurements, 2 * OOP_CHECK_MAX_PAIRS);
        assert_true(r.worst_error > r.error_oop - 1e-12);
        assert_non_null(strstr(r.why, "beyond"));
    }
}

static void test_the_model_itself_passes(void **state)
{
    (void)state;
    struct oop_check_result r;
    struct bench b;
    run_check(MODEL, 0, 1, &r, &b);
    /* an isotropic GGX differs from its in-plane extension by its shadowing
     * (theta_i and theta_o apart): a few thousandths */
    assert_string_equal(r.verdict, "sufficient");
    assert_true(r.error_oop < 0.01 && r.error_inplane < 1e-12);
    /* each incidence's out-of-plane pairs, then its counterparts */
    static const int want[] = {25, 25, 25, -25, -25, -25, 45, 45, 45, -45, -45, -45};
    assert_int_equal(b.n_order, 12);
    for (int k = 0; k < 12; k++)
        assert_int_equal(b.order[k], want[k]);
    /* with 2% log noise per reading: false alarms counted over seeded checks */
    int alarms = 0;
    for (uint64_t s = 0; s < 2000; s++) {
        run_check(MODEL, 0.02, 1000 + s, &r, &b);
        alarms += !strcmp(r.verdict, "insufficient");
    }
    print_message("false alarms: %d of 2000\n", alarms);
    assert_true(alarms <= 20); /* at most 1% */
}

static void test_too_few_readings_undetermined(void **state)
{
    (void)state;
    struct oop_check_pair p[4] = {{.theta_i = 25, .predicted = 1, .in_predicted = 1, .lobe_deg = 2},
                                  {.theta_i = 25, .predicted = 1, .in_predicted = 1, .lobe_deg = 2},
                                  {.theta_i = 25, .predicted = 1, .in_predicted = 1, .lobe_deg = 2},
                                  {.theta_i = 25, .predicted = 1, .in_predicted = 1, .lobe_deg = 2}};
    double m[4] = {1, NAN, 3, 1}, in[4] = {1, 1, 1, 0};
    struct oop_check_result r;
    oop_check_decide(p, 4, m, in, 0.1, &r);
    assert_string_equal(r.verdict, "undetermined");
    assert_true(isnan(r.ratio));
    assert_int_equal(r.measurements, 6);
    m[3] = 3;
    in[3] = 1;
    oop_check_decide(p, 4, m, in, 0.1, &r);
    assert_string_equal(r.verdict, "insufficient");
    double e = log1p(3 * cos(25 * BRDF_DEG)) - log1p(cos(25 * BRDF_DEG));
    assert_close(r.error_oop, (e + 0 + e) / 3, 1e-12);
    assert_close(r.ratio, r.error_oop / OOP_CHECK_FLOOR, 1e-12);
}

/* A lobe of width w (degrees of theta_h, Gaussian) over a floor: the
 * model's prediction and, read exactly, the material measured. */
static void spike(void *user, const struct brdf_pair *p, double rgb[3])
{
    double x = p->theta_h / BRDF_DEG / *(const double *)user;
    rgb[0] = rgb[1] = rgb[2] = 0.1 + 1000 * exp(-x * x);
}

static int read_spike(void *user, const struct oop_check_pair *p, int in_plane, double rgb[3],
                      struct gonio_err *err)
{
    (void)err;
    struct brdf_pair bp;
    if (in_plane)
        brdf_pair_inplane(p->in_theta_i, p->in_theta_r, &bp);
    else
        brdf_pair_spherical(p->theta_i, 0, p->theta_o, p->phi_o, &bp);
    spike(user, &bp, rgb);
    return 0;
}

static int read_nothing(void *user, const struct oop_check_pair *p, int in_plane, double rgb[3],
                        struct gonio_err *err)
{
    (void)user, (void)p, (void)in_plane, (void)err;
    rgb[0] = rgb[1] = rgb[2] = NAN;
    return 0;
}

static void test_lobe_narrower_than_the_rig_positions(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    struct oop_check_result r;
    /* the model falls by e^-1.5 at x^2 = 1.5 (the floor is 1e-4 of the
     * peak): 1.2247 w, found between the search's steps */
    double w = 0.005;
    assert_int_equal(oop_check_run(spike, &w, read_spike, &w, 0.1, &r, &err), 0);
    assert_close(r.lobe_deg, sqrt(1.5) * w, 1e-4);
    assert_close(r.resolution_deg, 0.1, 0);
    /* the readings agree with the model everywhere the rig reads, yet no
     * in-plane pair resolved the core: insufficient from the model alone */
    assert_true(r.ratio < 0.1);
    assert_string_equal(r.verdict, "insufficient");
    assert_int_equal(r.unresolved, 1);
    assert_non_null(strstr(r.why, "positioning"));
    /* with no usable reading too (a peak that saturates) */
    assert_int_equal(oop_check_run(spike, &w, read_nothing, &w, 0.1, &r, &err), 0);
    assert_string_equal(r.verdict, "insufficient");
    assert_true(isnan(r.ratio));
    /* a rig that positions finer (or a band of 0: no such test) resolves it */
    assert_int_equal(oop_check_run(spike, &w, read_spike, &w, 0.005, &r, &err), 0);
    assert_string_equal(r.verdict, "sufficient");
    assert_int_equal(oop_check_run(spike, &w, read_spike, &w, 0, &r, &err), 0);
    assert_string_equal(r.verdict, "sufficient");
    /* a lobe of 0.3 degrees on the same rig: resolved, decided by ratio */
    w = 0.3;
    assert_int_equal(oop_check_run(spike, &w, read_spike, &w, 0.1, &r, &err), 0);
    assert_close(r.lobe_deg, sqrt(1.5) * w, 1e-4);
    assert_string_equal(r.verdict, "sufficient");
    assert_int_equal(r.unresolved, 0);
    assert_int_equal(oop_check_run(spike, &w, read_nothing, &w, 0.1, &r, &err), 0);
    assert_string_equal(r.verdict, "undetermined");
    /* a lobe that never falls by e^-1.5 within the search: no width */
    w = 1e3;
    assert_int_equal(oop_check_run(spike, &w, read_spike, &w, 0.1, &r, &err), 0);
    assert_true(isnan(r.lobe_deg));
    assert_string_equal(r.verdict, "sufficient");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pairs_on_the_flank_with_counterparts),
        cmocka_unit_test(test_anisotropic_is_insufficient),
        cmocka_unit_test(test_the_model_itself_passes),
        cmocka_unit_test(test_too_few_readings_undetermined),
        cmocka_unit_test(test_lobe_narrower_than_the_rig_positions),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
