/* sim_rig's additions for gonio-sim: a move at a given speed and
 * acceleration follows that trapezoid (checked against the closed form
 * written out here), the profile's limits still apply, and sampling the
 * detector neither advances the clock nor differs from a measurement; the
 * rotation axis turns the sample about its normal: an anisotropic
 * material reads as its tangent turned by as much, an isotropic one reads
 * the same to the bit (exact mirror included), and a profile without the
 * axis refuses to turn it. */
#include <math.h>

#include "brdf/angles.h"
#include "brdf/material.h"
#include "sim/sim.h"
#include "tests/gonio_test.h"

/* Position t seconds into a rest-to-rest move of dist at v and a. */
static double closed_form(double dist, double v, double a, double t)
{
    if (dist < v * v / a)
        v = sqrt(dist * a);
    double ta = v / a, total = dist / v + ta;
    if (t >= total)
        return dist;
    if (t < ta)
        return 0.5 * a * t * t;
    if (t < total - ta)
        return 0.5 * a * ta * ta + v * (t - ta);
    return dist - 0.5 * a * (total - t) * (total - t);
}

static void test_move_at_speed(void **state)
{
    (void)state;
    struct rig_profile rig;
    rig_profile_default(&rig);
    struct gonio_err err = {0};
    brdf_material *m = brdf_material_open(brdf_material_default_spec(), &err);
    assert_non_null(m);
    sim_rig *r = sim_rig_new(&rig, m, &err);
    assert_non_null(r);
    /* Not the profile's 15 deg/s and 30 deg/s^2. */
    const double v = 7.0, a = 11.0;
    assert_int_equal(sim_rig_start_move_at(r, SIM_AXIS_ARM, 40.0, v, a, &err), 0);
    assert_close(sim_rig_move_end(r, SIM_AXIS_ARM), 40.0 / v + v / a, 1e-12);
    for (int i = 1; i <= 70; i++) {
        sim_rig_advance(r, 0.1);
        assert_close(sim_rig_position(r, SIM_AXIS_ARM), closed_form(40.0, v, a, 0.1 * i), 1e-9);
    }
    /* Triangular: too short to reach the speed. */
    assert_int_equal(sim_rig_start_move_at(r, SIM_AXIS_ARM, 41.0, v, a, &err), 0);
    sim_rig_advance(r, 0.2);
    assert_close(sim_rig_position(r, SIM_AXIS_ARM), 40.0 + closed_form(1.0, v, a, 0.2), 1e-9);
    /* The profile's limits hold; bad rates are refused. */
    assert_int_equal(sim_rig_start_move_at(r, SIM_AXIS_SAMPLE, 95, v, a, &err),
                     -GONIO_EUNREACHABLE);
    assert_true(sim_rig_start_move_at(r, SIM_AXIS_SAMPLE, 10, 0, a, &err) < 0);
    /* The plain call still runs at the profile's rates. */
    double t0 = sim_rig_now(r);
    assert_int_equal(sim_rig_start_move(r, SIM_AXIS_SAMPLE, 30.0, &err), 0);
    assert_close(sim_rig_move_end(r, SIM_AXIS_SAMPLE) - t0,
                 30.0 / rig.sample.speed + rig.sample.speed / rig.sample.accel, 1e-12);
    sim_rig_free(r);
    brdf_material_free(m);
}

static void test_sample_does_not_advance(void **state)
{
    (void)state;
    struct rig_profile rig;
    rig_profile_default(&rig);
    struct gonio_err err = {0};
    brdf_material *m = brdf_material_open(brdf_material_default_spec(), &err);
    sim_rig *r = sim_rig_new(&rig, m, &err);
    assert_non_null(r);
    sim_rig_start_move(r, SIM_AXIS_SAMPLE, 30.0, &err);
    sim_rig_start_move(r, SIM_AXIS_ARM, 30.0 + 25.0, &err);
    sim_rig_advance(r, 10.0);
    double t = sim_rig_now(r), got[3], measured[3], want[3];
    assert_int_equal(sim_rig_sample(r, got), 0);
    assert_close(sim_rig_now(r), t, 0);
    struct brdf_pair p;
    brdf_pair_inplane(30.0, 25.0, &p);
    brdf_material_eval(m, &p, 1, want);
    assert_int_equal(sim_rig_measure(r, 0.05, measured, &err), 0);
    assert_close(sim_rig_now(r), t + 0.05, 1e-12);
    for (int k = 0; k < 3; k++) {
        assert_rel_close(got[k], want[k], 1e-12);
        assert_close(measured[k], got[k], 0);
    }
    sim_rig_free(r);
    brdf_material_free(m);
}

/* The detector's reading at s, a with the sample turned rot degrees. */
static void read_at(sim_rig *r, double s, double a, double rot, double rgb[3])
{
    struct gonio_err err = {0};
    assert_int_equal(sim_rig_start_move(r, SIM_AXIS_SAMPLE, s, &err), 0);
    assert_int_equal(sim_rig_start_move(r, SIM_AXIS_ARM, a, &err), 0);
    assert_int_equal(sim_rig_start_move(r, SIM_AXIS_ROTATION, rot, &err), 0);
    sim_rig_advance(r, 30.0);
    assert_int_equal(sim_rig_sample(r, rgb), 0);
}

static void test_rotation_turns_the_sample(void **state)
{
    (void)state;
    struct rig_profile rig, plain;
    struct gonio_err err = {0};
    assert_int_equal(rig_profile_load("rotating", &rig, &err), 0);
    assert_true(rig.has_rotation);
    rig_profile_default(&plain);
    assert_false(plain.has_rotation);
    brdf_material *an = brdf_material_open("analytic:aniso-ggx?ax=0.08&ay=0.3&phi=20", &err);
    brdf_material *turned = brdf_material_open("analytic:aniso-ggx?ax=0.08&ay=0.3&phi=110", &err);
    brdf_material *iso = brdf_material_open(brdf_material_default_spec(), &err);
    assert_non_null(an);
    assert_non_null(turned);
    assert_non_null(iso);
    sim_rig *r = sim_rig_new(&rig, an, &err), *i = sim_rig_new(&rig, iso, &err);
    sim_rig *p = sim_rig_new(&plain, an, &err);
    assert_non_null(r);
    assert_non_null(i);
    assert_non_null(p);
    double at0[3], at90[3], want[3];
    read_at(r, 30, 80, 0, at0);
    read_at(r, 30, 80, 90, at90);
    struct brdf_pair pair;
    brdf_pair_inplane(30, 50, &pair);
    brdf_material_eval(turned, &pair, 1, want);
    for (int c = 0; c < 3; c++)
        assert_rel_close(at90[c], want[c], 1e-12);
    assert_true(fabs(at90[1] - at0[1]) > 0.2 * at0[1]);
    for (double a = 40; a <= 80; a += 10) { /* a = 60: the exact mirror */
        read_at(i, 30, a, 0, at0);
        read_at(i, 30, a, 135, at90);
        for (int c = 0; c < 3; c++)
            assert_close(at90[c], at0[c], 0);
    }
    assert_int_equal(sim_rig_start_move(p, SIM_AXIS_ROTATION, 45, &err), -GONIO_EUNREACHABLE);
    sim_rig_free(r);
    sim_rig_free(i);
    sim_rig_free(p);
    brdf_material_free(an);
    brdf_material_free(turned);
    brdf_material_free(iso);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_move_at_speed),
        cmocka_unit_test(test_sample_does_not_advance),
        cmocka_unit_test(test_rotation_turns_the_sample),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
