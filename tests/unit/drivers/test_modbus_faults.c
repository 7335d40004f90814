/* Faults injected into gonio-sim reach the drivers and the capture engine
 * as named errors: an axis that stops moving without an alarm (stall,
 * noticed by the driver), a drive that halts with alarm 0x30 (overload),
 * a capture that meets the overload fails on its first point with the
 * alarm in its message and the axes stopped, and a slave that answers
 * after the timeout does not have its late answer taken for the next. */
#include <errno.h>
#include <string.h>
#include <sys/stat.h>

#include "capture/capture.h"
#include "drivers/drv_modbus.h"
#include "rig/rig.h"
#include "tests/gonio_test.h"
#include "tests/unit/drivers/sim_proc.h"

static struct sim_proc sim;
static drv_modbus_bus *bus;
static struct rig_profile rig;

static int group_setup(void **state)
{
    (void)state;
    /* An obstacle at arm +18 (stall) and at sample +25 (overload). */
    static const char *const args[] = {"--time-scale", "50", "--stall", "2:18",
                                       "--overload", "1:25", NULL};
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
    return sim_proc_stop(&sim) == 0 ? 0 : -1;
}

static double position(drv_axis *ax)
{
    double deg = -1e9;
    struct gonio_err err = {0};
    if (drv_axis_position(ax, &deg, &err) < 0)
        fail_msg("%s", err.msg);
    return deg;
}

static void test_stall(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    drv_axis *arm = drv_axis_new_modbus(bus, 2, &rig.arm, NULL, "arm", &err);
    assert_non_null(arm);
    assert_int_equal(drv_axis_start_move(arm, 20, &err), 0);
    assert_int_equal(drv_axis_wait(arm, &err), -GONIO_EDEVICE);
    assert_non_null(strstr(err.msg, "axis arm"));
    assert_non_null(strstr(err.msg, "(stall)"));
    assert_close(position(arm), 18, 1e-12);
    assert_int_equal(drv_axis_stop(arm, &err), 0);
    /* Away from the obstacle the axis moves again. */
    assert_int_equal(drv_axis_start_move(arm, 0, &err), 0);
    assert_int_equal(drv_axis_wait(arm, &err), 0);
    assert_close(position(arm), 0, 0);
    drv_axis_free(arm);
}

static void test_overload(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    drv_axis *s = drv_axis_new_modbus(bus, 1, &rig.sample, NULL, "sample", &err);
    assert_non_null(s);
    assert_int_equal(drv_axis_start_move(s, 40, &err), 0);
    assert_int_equal(drv_axis_wait(s, &err), -GONIO_EDEVICE);
    assert_non_null(strstr(err.msg, "axis sample (slave 1): drive alarm 0x30 (overload)"));
    assert_close(position(s), 25, 1e-12);
    assert_int_equal(drv_axis_alarm_reset(s, &err), 0);
    assert_int_equal(drv_axis_start_move(s, 0, &err), 0);
    assert_int_equal(drv_axis_wait(s, &err), 0);
    assert_close(position(s), 0, 0);
    drv_axis_free(s);
}

static int open_devices(void *user, const struct rig_profile *r, const char *dir,
                        struct capture_devices *dev, struct gonio_err *err)
{
    (void)user;
    (void)dir;
    memset(dev, 0, sizeof *dev);
    dev->sample = drv_axis_new_modbus(bus, 1, &r->sample, NULL, "sample", err);
    dev->arm = drv_axis_new_modbus(bus, 2, &r->arm, NULL, "arm", err);
    dev->azimuth = drv_axis_new_modbus(bus, 4, &r->azimuth, NULL, "azimuth", err);
    dev->detector = drv_detector_new_modbus(bus, 3, err);
    dev->clock = drv_clock_new_modbus(bus, 3, err);
    return dev->sample && dev->arm && dev->azimuth && dev->detector && dev->clock
               ? 0
               : -GONIO_EDEVICE;
}

static void close_devices(void *user, struct capture_devices *dev)
{
    (void)user;
    drv_axis_free(dev->sample);
    drv_axis_free(dev->arm);
    drv_axis_free(dev->azimuth);
    drv_detector_free(dev->detector);
    drv_clock_free(dev->clock);
}

/* DS4's first point puts the sample at 30 deg: across the obstacle at 25. */
static void test_capture_stops_on_alarm(void **state)
{
    (void)state;
    char dir[64];
    snprintf(dir, sizeof dir, "/tmp/gonio-capfault-XXXXXX");
    assert_non_null(mkdtemp(dir));
    char out[128];
    snprintf(out, sizeof out, "%s/cap", dir);
    struct capture_config cfg = {
        .plan = "ds4", .rig = "default", .model = "abc", .out_dir = out, .quiet = 1};
    struct capture_rig devices = {.open = open_devices, .close = close_devices};
    struct capture_summary sum;
    struct gonio_err err = {0};
    assert_int_equal(capture_run(&cfg, &devices, NULL, &sum, &err), -GONIO_EDEVICE);
    assert_non_null(strstr(err.msg, "drive alarm 0x30 (overload)"));
    /* The engine stopped the axes: the arm is not moving any more. */
    drv_axis *arm = drv_axis_new_modbus(bus, 2, &rig.arm, NULL, "arm", &err);
    double a1 = position(arm);
    sim_proc_nap(50);
    assert_close(position(arm), a1, 0);
    drv_axis *s = drv_axis_new_modbus(bus, 1, &rig.sample, NULL, "sample", &err);
    assert_close(position(s), 25, 1e-12);
    assert_int_equal(drv_axis_alarm_reset(s, &err), 0);
    drv_axis_free(s);
    drv_axis_free(arm);
    char cmd[160];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    assert_int_equal(system(cmd), 0);
}

/* Slave 1 answers late, after the bus's timeout, and holds up the server
 * meanwhile, as a slow device holds an RTU bus. Its late answer must be
 * flushed, not read as the arm's: with no retries a foreign answer would
 * fail the arm's request (or, from the same slave, be taken for it). What
 * is tested is wall time by design (a timeout, and the drain after it
 * that waits for the line to stay quiet: drivers/drv_modbus_bus.c), so
 * the answer is placed in the middle of the drain's window, as far from
 * both of its ends as it can be: 1 s of timeout (4 s under valgrind), a
 * drain of 1 s, the answer 0.5 s after the timeout. The host's delays
 * are what move the answer (gonio-sim woken late, the driver's timeout
 * started late): an ordinary exchange takes under 20 ms here and was seen
 * at 0.2 s with four busy loops beside a test under nice 19, so the 0.5 s
 * on either side, and the 1 s an ordinary answer may take, hold on a
 * host 10x slower than that. The default drain (the timeout, at most
 * 0.1 s) would leave 50 ms on either side. */
static struct sim_proc slow;

static int stop_slow(void **state)
{
    (void)state;
    return slow.pid > 0 && sim_proc_stop(&slow) != 0 ? -1 : 0;
}

static void test_late_reply_is_not_taken(void **state)
{
    (void)state;
    double timeout = 1.0 * gonio_test_time_factor(), window = 1.0;
    char delay[32];
    snprintf(delay, sizeof delay, "1:%.0f", 1e3 * (timeout + 0.5 * window));
    const char *const args[] = {"--time-scale", "50", "--delay", delay, NULL};
    assert_int_equal(sim_proc_start(&slow, args), 0);
    struct gonio_err err = {0};
    struct drv_modbus_bus_cfg cfg;
    drv_modbus_bus_cfg_default(&cfg);
    cfg.device = slow.pty;
    cfg.time_scale = 50;
    cfg.timeout_s = timeout;
    cfg.drain_s = window;
    cfg.retries = 0;
    drv_modbus_bus *b = drv_modbus_bus_new_rtu(&cfg, &err);
    assert_non_null(b);
    drv_axis *arm = drv_axis_new_modbus(b, 2, &rig.arm, NULL, "arm", &err);
    drv_axis *s = drv_axis_new_modbus(b, 1, &rig.sample, NULL, "sample", &err);
    /* A second handle on the arm: it knows no position, so every read
     * goes over the bus (the mover answers from the end of its move). */
    drv_axis *arm_reader = drv_axis_new_modbus(b, 2, &rig.arm, NULL, "arm", &err);
    assert_int_equal(drv_axis_start_move(arm, 7.77, &err), 0);
    assert_int_equal(drv_axis_wait(arm, &err), 0);
    for (int i = 0; i < 3; i++) {
        double deg = 0;
        assert_int_equal(drv_axis_position(s, &deg, &err), -ETIMEDOUT);
        int rc = drv_axis_position(arm_reader, &deg, &err);
        if (rc < 0)
            fail_msg("arm after a late answer: %s", err.msg);
        assert_close(deg, 7.77, 1e-12);
    }
    drv_axis_free(s);
    drv_axis_free(arm_reader);
    drv_axis_free(arm);
    drv_modbus_bus_free(b);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_stall),
        cmocka_unit_test(test_overload),
        cmocka_unit_test(test_capture_stops_on_alarm),
        cmocka_unit_test_teardown(test_late_reply_is_not_taken, stop_slow),
    };
    return cmocka_run_group_tests(tests, group_setup, group_teardown);
}
