/* The Modbus drivers against a gonio-sim process (ideal scene, default rig,
 * 100 steps/deg, time scale 50), on its pty (RTU) and over TCP: moves end
 * at the target's step, homing returns to 0, stop stops short, the
 * detector reads the material at the axes, soft limits raise the drive's
 * alarm, and an absent slave times out without disturbing the next
 * answer. */
#include <errno.h>
#include <math.h>
#include <string.h>

#include "brdf/angles.h"
#include "brdf/material.h"
#include "drivers/drv_modbus.h"
#include "rig/rig.h"
#include "tests/gonio_test.h"
#include "tests/unit/drivers/sim_proc.h"

#define SCALE 50.0

static struct sim_proc sim;
static drv_modbus_bus *rtu, *tcp;
static struct rig_profile rig;
static brdf_material *material;

static int group_setup(void **state)
{
    (void)state;
    static const char *const args[] = {"--time-scale", "50", "--tcp", "127.0.0.1:0", NULL};
    if (sim_proc_start(&sim, args) < 0)
        return -1;
    struct gonio_err err = {0};
    if (rig_profile_load("default", &rig, &err) < 0) {
        fprintf(stderr, "%s\n", err.msg);
        return -1;
    }
    material = brdf_material_open(brdf_material_default_spec(), &err);
    struct drv_modbus_bus_cfg cfg;
    drv_modbus_bus_cfg_default(&cfg);
    cfg.device = sim.pty;
    cfg.time_scale = SCALE;
    /* Nothing here waits for a timeout but the absent slave (its own bus):
     * the timeout only bounds how long the host may take to answer. */
    cfg.timeout_s = 2.0 * gonio_test_time_factor();
    rtu = drv_modbus_bus_new_rtu(&cfg, &err);
    cfg.host = "127.0.0.1";
    cfg.port = sim.port;
    tcp = rtu ? drv_modbus_bus_new_tcp(&cfg, &err) : NULL;
    if (!material || !rtu || !tcp) {
        fprintf(stderr, "setup: %s\n", err.msg);
        return -1;
    }
    return 0;
}

static int group_teardown(void **state)
{
    (void)state;
    drv_modbus_bus_free(rtu);
    drv_modbus_bus_free(tcp);
    brdf_material_free(material);
    /* gonio-sim must leave cleanly on SIGTERM. */
    return sim_proc_stop(&sim) == 0 ? 0 : -1;
}

static drv_axis *axis(drv_modbus_bus *bus, int slave, const struct rig_axis *prof,
                      const char *name)
{
    struct gonio_err err = {0};
    drv_axis *ax = drv_axis_new_modbus(bus, slave, prof, NULL, name, &err);
    if (!ax)
        fail_msg("%s", err.msg);
    return ax;
}

static void move(drv_axis *ax, double deg)
{
    struct gonio_err err = {0};
    if (drv_axis_start_move(ax, deg, &err) < 0 || drv_axis_wait(ax, &err) < 0)
        fail_msg("move %s to %g: %s", drv_axis_name(ax), deg, err.msg);
}

static double position(drv_axis *ax)
{
    struct gonio_err err = {0};
    double deg = NAN;
    if (drv_axis_position(ax, &deg, &err) < 0)
        fail_msg("position %s: %s", drv_axis_name(ax), err.msg);
    return deg;
}

/* A move ends on the drive step nearest the target: 100 steps/deg. */
static void moves_end_on_target_steps(drv_modbus_bus *bus)
{
    drv_axis *s = axis(bus, 1, &rig.sample, "sample"), *a = axis(bus, 2, &rig.arm, "arm");
    struct gonio_err err = {0};
    assert_int_equal(drv_axis_start_move(s, 12.344, &err), 0);
    assert_int_equal(drv_axis_start_move(a, -31.257, &err), 0);
    assert_int_equal(drv_axis_wait(s, &err), 0);
    assert_int_equal(drv_axis_wait(a, &err), 0);
    assert_close(position(s), 1234 / 100.0, 1e-12);
    assert_close(position(a), -3126 / 100.0, 1e-12);
    move(s, 0);
    move(a, 0);
    assert_close(position(s), 0, 0);
    drv_axis_free(s);
    drv_axis_free(a);
}

static void test_move_rtu(void **state)
{
    (void)state;
    moves_end_on_target_steps(rtu);
}

static void test_move_tcp(void **state)
{
    (void)state;
    moves_end_on_target_steps(tcp);
}

static void test_home(void **state)
{
    (void)state;
    drv_axis *s = axis(rtu, 1, &rig.sample, "sample");
    struct gonio_err err = {0};
    move(s, -7.5);
    assert_close(position(s), -7.5, 1e-12);
    assert_int_equal(drv_axis_home(s, &err), 0);
    assert_close(position(s), 0, 0);
    drv_axis_free(s);
}

/* Stopped half-way, the axis stays where it stopped and waiting for the
 * target fails instead of hanging. On a gonio-sim of its own on the
 * simulated clock, so that where the stop lands is the rig's doing, not
 * the host's: the move runs for exactly the second of rig time the clock
 * is told to pass (the wait register), whatever the host spends around
 * it. The azimuth's trapezoid at 30 deg/s and 60 deg/s^2 covers 7.5 deg
 * in its 0.5 s of acceleration and 15 deg in the next 0.5 s: it is
 * stopped at 22.5 deg (2250 steps), and another second of rig time later
 * it is still there. On the wall clock a host that held the test for
 * the move's 6 s of rig time (0.12 s of wall time) let it arrive. */
static struct sim_proc simclk;

static int stop_simclk(void **state)
{
    (void)state;
    return simclk.pid > 0 && sim_proc_stop(&simclk) != 0 ? -1 : 0;
}

static void test_stop(void **state)
{
    (void)state;
    static const char *const args[] = {"--clock", "simulated", NULL};
    assert_int_equal(sim_proc_start(&simclk, args), 0);
    drv_modbus_bus *bus = sim_proc_rtu(&simclk, 1);
    assert_non_null(bus);
    struct gonio_err err = {0};
    drv_clock *c = drv_clock_new_modbus(bus, 3, &err);
    assert_non_null(c);
    drv_axis *az = axis(bus, 4, &rig.azimuth, "azimuth");
    assert_int_equal(drv_axis_start_move(az, 170, &err), 0);
    assert_int_equal(drv_clock_sleep(c, 1.0), 0);
    assert_int_equal(drv_axis_stop(az, &err), 0);
    double here = position(az);
    assert_close(here, 22.5, 0.011);
    assert_int_equal(drv_clock_sleep(c, 1.0), 0); /* moving, it would be at 52.5 */
    assert_close(position(az), here, 0);
    assert_int_equal(drv_axis_wait(az, &err), -GONIO_EDEVICE);
    assert_non_null(strstr(err.msg, "short of 170"));
    move(az, 0);
    assert_close(position(az), 0, 0);
    drv_axis_free(az);
    drv_clock_free(c);
    drv_modbus_bus_free(bus);
}

/* The detector reads the material at the axes: an independent evaluation
 * of the same material at the positions the drives report, with the
 * planner's mapping theta_i = s, theta_r = a - s. Channels are float32. */
static void detector_reads_material(drv_modbus_bus *bus)
{
    drv_axis *s = axis(bus, 1, &rig.sample, "sample"), *a = axis(bus, 2, &rig.arm, "arm");
    struct gonio_err err = {0};
    drv_detector *d = drv_detector_new_modbus(bus, 3, &err);
    assert_non_null(d);
    const double pts[][2] = {{30, 30 - 20}, {30, 30 + 28}, {60, 60 + 55}, {0, -45}};
    for (size_t i = 0; i < sizeof pts / sizeof pts[0]; i++) {
        move(s, pts[i][0]);
        move(a, pts[i][1]);
        struct drv_reading r;
        assert_int_equal(drv_detector_acquire(d, 0.05, &r, &err), 0);
        assert_close(r.integration_s, 0.05, 1e-9);
        assert_int_equal(r.unit, DRV_UNIT_BRDF); /* no adc: calibrated, no raw block read */
        assert_true(isnan(r.monitor));
        double ps = position(s), pa = position(a);
        struct brdf_pair p;
        brdf_pair_inplane(ps, pa - ps, &p);
        double want[3];
        brdf_material_eval(material, &p, 1, want);
        for (int k = 0; k < 3; k++) {
            assert_true(want[k] > 0);
            assert_rel_close(r.rgb[k], want[k], 1e-6);
        }
    }
    move(s, 0);
    move(a, 0);
    drv_detector_free(d);
    drv_axis_free(s);
    drv_axis_free(a);
}

static void test_detector_rtu(void **state)
{
    (void)state;
    detector_reads_material(rtu);
}

static void test_detector_tcp(void **state)
{
    (void)state;
    detector_reads_material(tcp);
}

/* The driver refuses a target beyond its profile's limits without sending
 * it; a driver whose limits are wider than the drive's gets the drive's
 * overtravel alarm, which holds until reset. */
static void test_soft_limits(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    drv_axis *s = axis(rtu, 1, &rig.sample, "sample");
    assert_int_equal(drv_axis_start_move(s, 95, &err), -GONIO_EUNREACHABLE);
    assert_close(position(s), 0, 0);

    struct rig_axis wide = rig.sample;
    wide.min = -120;
    wide.max = 120;
    drv_axis *w = axis(rtu, 1, &wide, "sample");
    assert_int_equal(drv_axis_start_move(w, 100, &err), 0);
    assert_int_equal(drv_axis_wait(w, &err), -GONIO_EDEVICE);
    assert_non_null(strstr(err.msg, "drive alarm 0x66"));
    assert_close(position(w), 0, 0); /* did not move */
    /* In alarm, a valid move is ignored too. */
    assert_int_equal(drv_axis_start_move(w, 10, &err), 0);
    assert_int_equal(drv_axis_wait(w, &err), -GONIO_EDEVICE);
    assert_int_equal(drv_axis_alarm_reset(w, &err), 0);
    move(w, 10);
    assert_close(position(w), 10, 1e-12);
    move(w, 0);
    drv_axis_free(w);
    drv_axis_free(s);
}

/* No slave 7 on the bus: the request times out (after its retry), and
 * the next request to a present slave gets its own answer. On a bus and a
 * gonio-sim of their own, with one retry: every attempt at the ghost
 * waits the whole timeout, which must still be long enough for the
 * present slaves' answers on a loaded host (1 s; 4 s under valgrind). */
static void test_absent_slave(void **state)
{
    (void)state;
    static const char *const args[] = {"--clock", "simulated", NULL};
    assert_int_equal(sim_proc_start(&simclk, args), 0);
    struct drv_modbus_bus_cfg cfg;
    drv_modbus_bus_cfg_default(&cfg);
    cfg.device = simclk.pty;
    cfg.timeout_s = 1.0 * gonio_test_time_factor();
    cfg.retries = 1;
    struct gonio_err err = {0};
    drv_modbus_bus *bus = drv_modbus_bus_new_rtu(&cfg, &err);
    assert_non_null(bus);
    drv_axis *s = axis(bus, 1, &rig.sample, "sample");
    drv_axis *ghost = axis(bus, 7, &rig.sample, "ghost");
    move(s, 3.21);
    double deg;
    assert_int_equal(drv_axis_position(ghost, &deg, &err), -ETIMEDOUT);
    assert_non_null(strstr(err.msg, "no answer"));
    assert_non_null(strstr(err.msg, "(2 attempts)"));
    assert_close(position(s), 3.21, 1e-12);
    assert_int_equal(drv_axis_position(ghost, &deg, &err), -ETIMEDOUT);
    drv_axis *a = axis(bus, 2, &rig.arm, "arm");
    assert_close(position(a), 0, 0);
    move(s, 0);
    drv_axis_free(a);
    drv_axis_free(ghost);
    drv_axis_free(s);
    drv_modbus_bus_free(bus);
}

/* With backlash compensation a target below the axis is reached through
 * an overshoot below it: after the first leg the drive sits at target -
 * backlash, and the wait brings it up to the target. */
static void test_backlash(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    struct drv_modbus_axis_opts opts = {.steps_per_deg = 100, .backlash_deg = 2};
    drv_axis *b = drv_axis_new_modbus(rtu, 2, &rig.arm, &opts, "arm", &err);
    drv_axis *plain = axis(rtu, 2, &rig.arm, "arm");
    assert_non_null(b);
    move(b, 10); /* from below: direct */
    assert_int_equal(drv_axis_start_move(b, 5, &err), 0);
    sim_proc_nap(100); /* 5 rig seconds: the 7 deg leg is over */
    assert_close(position(plain), 3, 1e-12);
    assert_int_equal(drv_axis_wait(b, &err), 0);
    assert_close(position(plain), 5, 1e-12);
    move(plain, 0);
    drv_axis_free(b);
    drv_axis_free(plain);
}

/* The clock reads the simulated rig time: it advances SCALE times faster
 * than wall time. */
static void test_clock(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    drv_clock *c = drv_clock_new_modbus(tcp, 3, &err);
    assert_non_null(c);
    double t0 = drv_clock_now(c);
    assert_int_equal(drv_clock_sleep(c, 5.0), 0); /* 0.1 s of wall time */
    double t1 = drv_clock_now(c);
    assert_true(t1 - t0 >= 4.99); /* wall time would give 0.1 */
    drv_clock_free(c);
}

static long requests(const drv_modbus_bus *bus)
{
    struct drv_modbus_stats st;
    drv_modbus_bus_stats(bus, &st);
    return st.requests;
}

/* On a simulated clock (a gonio-sim of its own, --clock simulated) the
 * rig time is the device's, whatever the host does meanwhile. The
 * detector's reading carries the clock: right after it the clock reads
 * nothing, and the integration (from 0) is all the rig time there is; a
 * settle is one write of the wait register and passes exactly; an
 * exchange that models no time (a position read on a free line) adds
 * none, though the clock reads the register again after it. */
static void test_clock_from_detector(void **state)
{
    (void)state;
    static const char *const args[] = {"--clock", "simulated", NULL};
    assert_int_equal(sim_proc_start(&simclk, args), 0);
    drv_modbus_bus *bus = sim_proc_rtu(&simclk, 1);
    assert_non_null(bus);
    struct gonio_err err = {0};
    drv_clock *c = drv_clock_new_modbus(bus, 3, &err);
    drv_detector *d = drv_detector_new_modbus(bus, 3, &err);
    drv_axis *s = axis(bus, 1, &rig.sample, "sample");
    assert_non_null(c);
    assert_non_null(d);
    struct drv_reading r;
    assert_int_equal(drv_detector_acquire(d, 0.05, &r, &err), 0);
    long n = requests(bus);
    double t0 = drv_clock_now(c);
    assert_int_equal(requests(bus), n);
    assert_close(t0, 0.05, 1e-9); /* the register's 50 ms */
    assert_int_equal(drv_clock_sleep(c, 5.0), 0);
    assert_int_equal(requests(bus), n + 1); /* the wait */
    double t1 = drv_clock_now(c);
    assert_int_equal(requests(bus), n + 2);
    assert_close(t1 - t0, 5.0, 1e-9);
    position(s); /* another exchange: the detector's clock reading is old news */
    n = requests(bus);
    double t2 = drv_clock_now(c);
    assert_int_equal(requests(bus), n + 1);
    assert_close(t2, t1, 0);
    struct drv_clock_stats st;
    drv_clock_stats(c, &st);
    assert_int_equal(st.backward + st.restarts, 0);
    drv_axis_free(s);
    drv_detector_free(d);
    drv_clock_free(c);
    drv_modbus_bus_free(bus);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_move_rtu),     cmocka_unit_test(test_move_tcp),
        cmocka_unit_test(test_home),
        cmocka_unit_test_teardown(test_stop, stop_simclk),
        cmocka_unit_test(test_detector_rtu), cmocka_unit_test(test_detector_tcp),
        cmocka_unit_test(test_soft_limits),
        cmocka_unit_test_teardown(test_absent_slave, stop_simclk),
        cmocka_unit_test(test_backlash),     cmocka_unit_test(test_clock),
        cmocka_unit_test_teardown(test_clock_from_detector, stop_simclk),
    };
    return cmocka_run_group_tests(tests, group_setup, group_teardown);
}
