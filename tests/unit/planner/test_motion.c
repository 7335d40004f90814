/* Trapezoidal move times against closed forms and against a direct
 * simulation of the velocity profile. */
#include "tests/gonio_test.h"

#include "rig/motion.h"

/* Step a rest-to-rest move through time: the profile is symmetric (brake
 * as hard as you accelerate), so the move lasts twice the time to cover the
 * first half while accelerating at acc, capped at vmax. */
static double simulate(double dist, double vmax, double acc)
{
    const double dt = 1e-6;
    double x = 0, v = 0, t = 0;
    while (x < dist / 2) {
        double v1 = fmin(vmax, v + acc * dt);
        x += 0.5 * (v + v1) * dt;
        v = v1;
        t += dt;
    }
    return 2 * t;
}

static void test_closed_forms(void **state)
{
    (void)state;
    /* short move, arm 15 deg/s, 30 deg/s^2: never reaches speed (needs
     * 7.5 deg), half the distance in sqrt(d/a) each way */
    double d = 2, v = 15, a = 30;
    double half_t = sqrt(2 * (d / 2) / a);
    assert_close(rig_axis_time(d, v, a), 2 * half_t, 1e-12);
    /* long move: v/a to accelerate, v/a to brake, the rest at speed */
    d = 60;
    double t_acc = v / a, d_acc = 0.5 * a * t_acc * t_acc;
    assert_close(rig_axis_time(d, v, a), 2 * t_acc + (d - 2 * d_acc) / v, 1e-12);
    assert_close(rig_axis_time(-60, v, a), rig_axis_time(60, v, a), 0);
    assert_close(rig_axis_time(0, v, a), 0, 0);
    /* the two branches meet where the triangle just reaches speed */
    assert_close(rig_axis_time(v * v / a, v, a), 2 * v / a, 1e-12);
    assert_close(rig_axis_time(v * v / a + 1e-9, v, a), 2 * v / a, 1e-9);
}

static void test_simulated(void **state)
{
    (void)state;
    static const double cases[][3] = {{1, 15, 30}, {5, 15, 30}, {7.5, 15, 30},
                                      {40, 20, 40}, {170, 15, 30}, {3, 30, 60}};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        assert_close(rig_axis_time(cases[i][0], cases[i][1], cases[i][2]),
                     simulate(cases[i][0], cases[i][1], cases[i][2]), 1e-4);
}

static void test_axes_together(void **state)
{
    (void)state;
    struct rig_profile rig;
    rig_profile_default(&rig);
    struct rig_axes from = {0, 0, 0}, to = {30, 10, 0};
    /* sample 30 deg at 20/40: 30/20 + 20/40 = 2.0 s; arm 10 deg at 15/30:
     * 10/15 + 15/30 = 1.1667 s; the move lasts as long as the slower axis */
    assert_close(rig_move_time(&rig, &from, &to), 2.0, 1e-12);
    to = (struct rig_axes){1, 40, 0};
    assert_close(rig_move_time(&rig, &from, &to), 40.0 / 15 + 0.5, 1e-12);
    /* the azimuth axis counts only on a rig that has it */
    to = (struct rig_axes){0, 0, 170};
    assert_close(rig_move_time(&rig, &from, &to), 170.0 / 30 + 0.5, 1e-12);
    rig.out_of_plane = 0;
    assert_close(rig_move_time(&rig, &from, &to), 0, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_closed_forms),
        cmocka_unit_test(test_simulated),
        cmocka_unit_test(test_axes_together),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
