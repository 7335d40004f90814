/* The Modbus axis's mechanics against a gonio-sim process whose scene
 * jitters the azimuth (0.3 deg), stalls the arm on its moves 2 and 3
 * (alarm 0x10) and raises alarm 0x28 (sensor error) on the sample's move
 * 2, with drives reporting IN-POS within 0.01 deg: a drive resting outside
 * the driver's band is re-commanded until it rests inside, or the move
 * fails saying overshoot or short; recoverable alarms are reset (and a
 * sensor error re-homed) and the move completes; drv_axis_stats counts
 * what it took. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "drivers/drv_modbus.h"
#include "rig/rig.h"
#include "tests/gonio_test.h"
#include "tests/unit/drivers/sim_proc.h"

static struct sim_proc sim;
static drv_modbus_bus *bus;
static struct rig_profile rig;
static char scene_dir[64], scene_path[96];

static int group_setup(void **state)
{
    (void)state;
    snprintf(scene_dir, sizeof scene_dir, "/tmp/gonio-mech-XXXXXX");
    if (!mkdtemp(scene_dir))
        return -1;
    snprintf(scene_path, sizeof scene_path, "%s/scene.yaml", scene_dir);
    FILE *f = fopen(scene_path, "w");
    if (!f)
        return -1;
    fputs("name: mechanics\nmaterial: default\nrig: default\ndetector: {kind: rgb}\nseed: 3\n"
          "effects:\n"
          "  - {name: jitter, sigma_deg: 0.3, axes: [azimuth]}\n"
          "  - {name: stall, axes: [arm], at_moves: [2, 3]}\n"
          "  - {name: alarm, axes: [sample], at_moves: [2], code: 40}\n",
          f);
    fclose(f);
    const char *const args[] = {"--scene", scene_path, "--time-scale", "50", "--in-pos-deg",
                                "0.01", NULL};
    struct gonio_err err = {0};
    if (sim_proc_start(&sim, args) < 0 || rig_profile_load("default", &rig, &err) < 0)
        return -1;
    bus = sim_proc_rtu(&sim, 50);
    return bus ? 0 : -1;
}

static int group_teardown(void **state)
{
    (void)state;
    drv_modbus_bus_free(bus);
    unlink(scene_path);
    rmdir(scene_dir);
    return sim_proc_stop(&sim) == 0 ? 0 : -1;
}

static drv_axis *axis(int slave, const struct rig_axis *prof, const char *name, double band,
                      int retries)
{
    struct drv_modbus_axis_opts opts = {.in_position_deg = band, .move_retries = retries};
    struct gonio_err err = {0};
    drv_axis *ax = drv_axis_new_modbus(bus, slave, prof, &opts, name, &err);
    if (!ax)
        fail_msg("%s", err.msg);
    return ax;
}

/* The encoder, read by a handle that knows nothing of the last move. */
static double encoder(int slave, const struct rig_axis *prof)
{
    drv_axis *r = axis(slave, prof, "reader", 0, 0);
    struct gonio_err err = {0};
    double deg = NAN;
    if (drv_axis_position(r, &deg, &err) < 0)
        fail_msg("%s", err.msg);
    drv_axis_free(r);
    return deg;
}

/* Without tries, a jittered azimuth mostly rests outside a 0.05 deg band:
 * the move fails, naming overshoot or short along the move, by how much.
 * With tries, every move ends inside the band (where the encoder says),
 * and the re-commands are counted. */
static void test_recommand(void **state)
{
    (void)state;
    drv_axis *once = axis(4, &rig.azimuth, "azimuth", 0.05, 0);
    struct gonio_err err = {0};
    int failed = 0;
    double from = 0;
    for (int i = 1; i <= 10; i++) {
        double target = (i % 2 ? 1 : -1) * 10.0 * i;
        assert_int_equal(drv_axis_start_move(once, target, &err), 0);
        int rc = drv_axis_wait(once, &err);
        double at = encoder(4, &rig.azimuth);
        if (rc == 0) {
            assert_true(fabs(at - target) <= 0.05 + 1e-9);
        } else {
            failed++;
            assert_int_equal(rc, -GONIO_EDEVICE);
            char want[160];
            double over = (at - target) * (target > from ? 1 : -1);
            snprintf(want, sizeof want, "axis azimuth (slave 4): stopped at %g deg, %.3g deg %s "
                     "%g deg", at, fabs(over), over > 0 ? "past (overshoot)" : "short of",
                     target);
            assert_string_equal(err.msg, want);
        }
        from = at;
    }
    assert_true(failed > 0);
    struct drv_axis_stats st;
    drv_axis_stats(once, &st);
    assert_int_equal(st.recommands, 0);
    assert_int_equal(st.moves, 10);
    drv_axis_free(once);

    drv_axis *tries = axis(4, &rig.azimuth, "azimuth", 0.05, 20);
    for (int i = 1; i <= 10; i++) {
        double target = (i % 2 ? -1 : 1) * 7.0 * i;
        assert_int_equal(drv_axis_start_move(tries, target, &err), 0);
        if (drv_axis_wait(tries, &err) < 0)
            fail_msg("%s", err.msg);
        double told = NAN;
        assert_int_equal(drv_axis_position(tries, &told, &err), 0);
        assert_close(told, encoder(4, &rig.azimuth), 0); /* the feedback, not the target */
        assert_true(fabs(told - target) <= 0.05 + 1e-9);
    }
    drv_axis_stats(tries, &st);
    assert_true(st.recommands > 0);
    assert_int_equal(st.moves, 10 + 2 * st.recommands); /* back off, come again */
    assert_int_equal(st.alarms_recovered, 0);

    /* One try left over three moves: some move runs out and says so. */
    drv_axis *two = axis(4, &rig.azimuth, "azimuth", 0.05, 1);
    int rc = 0;
    for (int i = 0; i < 10 && rc == 0; i++)
        if ((rc = drv_axis_start_move(two, 5.0 * (i + 1), &err)) == 0)
            rc = drv_axis_wait(two, &err);
    assert_int_equal(rc, -GONIO_EDEVICE);
    assert_non_null(strstr(err.msg, "after 2 tries (re-commanded once)"));
    drv_axis_free(two);
    drv_axis_free(tries);
}

/* The arm stalls on its moves 2 and 3 (alarm 0x10). Without tries the
 * move fails naming the alarm; with tries the alarm is reset and the move
 * completes from the reference side, with no re-homing. */
static void test_deviation_alarm(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    drv_axis *once = axis(2, &rig.arm, "arm", 0.05, 0);
    assert_int_equal(drv_axis_start_move(once, 20, &err), 0);
    assert_int_equal(drv_axis_wait(once, &err), 0);
    assert_int_equal(drv_axis_start_move(once, -10, &err), 0);
    assert_int_equal(drv_axis_wait(once, &err), -GONIO_EDEVICE);
    assert_string_equal(err.msg, "axis arm (slave 2): drive alarm 0x10 (excessive position "
                                 "deviation)");
    assert_int_equal(drv_axis_alarm_reset(once, &err), 0);
    drv_axis_free(once);

    drv_axis *arm = axis(2, &rig.arm, "arm", 0.05, 2);
    assert_int_equal(drv_axis_start_move(arm, -10, &err), 0); /* move 3: stalls */
    if (drv_axis_wait(arm, &err) < 0)
        fail_msg("%s", err.msg);
    assert_close(encoder(2, &rig.arm), -10, 1e-12);
    struct drv_axis_stats st;
    drv_axis_stats(arm, &st);
    assert_int_equal(st.alarms_recovered, 1);
    assert_int_equal(st.rehomes, 0);
    assert_int_equal(st.recommands, 0);
    assert_int_equal(st.moves, 3); /* the stalled move, back off, come again */
    drv_axis_free(arm);
}

/* A sensor error (0x28) on the sample's move 2: the position is in doubt,
 * so the axis is re-homed before the move is tried again. */
static void test_sensor_alarm_rehomes(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    drv_axis *s = axis(1, &rig.sample, "sample", 0.05, 1);
    assert_int_equal(drv_axis_start_move(s, 10, &err), 0);
    assert_int_equal(drv_axis_wait(s, &err), 0);
    assert_int_equal(drv_axis_start_move(s, 30, &err), 0);
    if (drv_axis_wait(s, &err) < 0)
        fail_msg("%s", err.msg);
    assert_close(encoder(1, &rig.sample), 30, 1e-12);
    struct drv_axis_stats st;
    drv_axis_stats(s, &st);
    assert_int_equal(st.alarms_recovered, 1);
    assert_int_equal(st.rehomes, 1);
    drv_axis_free(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_recommand),
        cmocka_unit_test(test_deviation_alarm),
        cmocka_unit_test(test_sensor_alarm_rehomes),
    };
    return cmocka_run_group_tests(tests, group_setup, group_teardown);
}
