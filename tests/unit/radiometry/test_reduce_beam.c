/* The absolute method (radiometry/reduce.h, struct rad_beam) on hand-made
 * readings: the BRDF is the sample's linearised counts per monitor count
 * over the beam's, the attenuator undone, times cos(theta_r) and the solid
 * angle; the budget drops the standard and gains the solid angle's and
 * the attenuator's systematic terms; a beam without a reading at the
 * sample's gain state is refused. */
#include "tests/gonio_test.h"

#include <math.h>

#include "radiometry/reduce.h"

#define OMEGA 1.2e-4
#define ATTEN 1e-4

struct beam_cal {
    struct rad_dark dark[2];
    struct rad_ref beam;
    struct rad_calibration cal;
};

/* The beam read 16 times at 0.05 s: 30000 counts above a 1000-count dark
 * over 5e5 monitor counts; the sample's integration 0.25 s has its dark. */
static void beam_cal_init(struct beam_cal *b)
{
    memset(b, 0, sizeof *b);
    b->dark[0] = (struct rad_dark){.integration_s = 0.05, .n = 16,
                                   .mean = {1000, 1000, 1000}, .sd = {12, 12, 12}};
    b->dark[1] = (struct rad_dark){.integration_s = 0.25, .n = 16,
                                   .mean = {1100, 1100, 1100}, .sd = {14, 14, 14}};
    b->beam = (struct rad_ref){.theta_i = 0, .theta_r = 180, .integration_s = 0.05, .n = 16,
                               .counts = {31000, 25000, 21000}, .monitor = 5e5};
    b->cal.darks = b->dark, b->cal.n_darks = 2;
    b->cal.refs = &b->beam, b->cal.n_refs = 1;
    b->cal.setup = (struct rad_setup){.adu_per_electron = {0.8, 0.8, 0.8},
                                      .in_position_deg = 0.1, .geometry_rel_u = 0.001,
                                      .spot = RAD_SPOT_UNDERFILLED};
    b->cal.beam = (struct rad_beam){.on = 1, .omega_sr = OMEGA, .omega_rel_u = 0.0014,
                                    .attenuation = ATTEN, .attenuation_rel_u = 0.003};
}

static struct rad_raw sample(double ti, double tr, double g_counts)
{
    struct rad_raw s = {.theta_i = ti, .theta_r = tr, .counts = {11100, g_counts, 6100},
                        .integration_s = 0.25, .monitor = 2.5e6};
    return s;
}

static void test_absolute_equation(void **state)
{
    (void)state;
    struct beam_cal b;
    beam_cal_init(&b);
    const double geo[][2] = {{0, 40}, {30, -60}, {60, 10}};
    for (size_t k = 0; k < 3; k++) {
        struct rad_raw s = sample(geo[k][0], geo[k][1], 9100);
        struct rad_value v;
        struct gonio_err err = {0};
        assert_int_equal(rad_reduce(&b.cal, &s, 1, &v, &err), 0);
        double cos_r = cos(geo[k][1] * 3.14159265358979323846 / 180);
        const double xs[3] = {10000, 8000, 5000}, xb[3] = {30000, 24000, 20000};
        for (int c = 0; c < 3; c++) {
            double f = (xs[c] / 2.5e6) / ((xb[c] / 5e5) / ATTEN * cos_r * OMEGA);
            assert_rel_close(v.brdf[c], f, 1e-12);
        }
    }
}

static void test_budget_of_the_absolute_method(void **state)
{
    (void)state;
    struct beam_cal b;
    beam_cal_init(&b);
    struct rad_raw s = sample(20, 30, 9100);
    struct rad_value v;
    struct gonio_err err = {0};
    assert_int_equal(rad_reduce(&b.cal, &s, 1, &v, &err), 0);
    assert_close(v.rel[RAD_U_REFERENCE][1], 0.0, 0);
    assert_close(v.rel[RAD_U_SOLID_ANGLE][1], 0.0014, 0);
    assert_close(v.rel[RAD_U_ATTENUATOR][1], 0.003, 0);
    /* the beam readings' shot and read noise over their number */
    double xb = 24000;
    assert_rel_close(v.rel[RAD_U_REF_NOISE][1], sqrt((0.8 * xb + 12.0 * 12.0) / 16) / xb, 1e-12);
    assert_true(rad_term_systematic(RAD_U_SOLID_ANGLE) && rad_term_systematic(RAD_U_ATTENUATOR));
    assert_string_equal(rad_term_name(RAD_U_SOLID_ANGLE), "solid_angle");
    double sys[3];
    rad_systematic_rel_u(&b.cal, sys);
    assert_rel_close(sys[1], sqrt(0.001 * 0.001 + 0.0014 * 0.0014 + 0.003 * 0.003), 1e-12);
}

static void test_no_beam_at_the_gain_state_refused(void **state)
{
    (void)state;
    struct beam_cal b;
    beam_cal_init(&b);
    struct rad_raw s = sample(20, 30, 9100);
    s.gain_state = 2;
    b.dark[1].gain_state = 2;
    struct rad_value v;
    struct gonio_err err = {0};
    assert_true(rad_reduce(&b.cal, &s, 1, &v, &err) < 0);
    assert_non_null(strstr(err.msg, "no beam reading at gain state 2"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_absolute_equation),
        cmocka_unit_test(test_budget_of_the_absolute_method),
        cmocka_unit_test(test_no_beam_at_the_gain_state_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
