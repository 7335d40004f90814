/* Devices that restart under the Modbus drivers (gonio-sim killed and
 * started again on its TCP port, a power cycle of the whole rig): the rig
 * clock carries on, monotonic, with no 32-bit wrap, and counts the restart;
 * an axis whose fresh drive reports IN-POS for its own target is
 * re-commanded to ours (the encoder is compared with the target), or the
 * move fails naming the axis, target and position; the detector refuses a
 * reading across a restart, and closes its shutter again after one; a
 * device that stays away is named as such. */
#include <errno.h>
#include <math.h>
#include <string.h>
#include <sys/stat.h>

#include "common/clock.h"
#include "drivers/drv_modbus.h"
#include "rig/rig.h"
#include "tests/gonio_test.h"
#include "tests/unit/drivers/sim_proc.h"

#define SCALE 50.0

static struct sim_proc sim;
static drv_modbus_bus *bus;
static struct rig_profile rig;
/* RTU: the bus is on a link to the pty, which a restarted gonio-sim points
 * at its new pty (as a serial adapter plugged in again). */
static char link_dir[64], link_path[96];

static int start_sim(int port)
{
    char where[64];
    snprintf(where, sizeof where, "127.0.0.1:%d", port);
    const char *const args[] = {"--time-scale", "50", "--tcp", where, "--link", link_path,
                                NULL};
    return sim_proc_start(&sim, args);
}

/* Each test: a fresh gonio-sim and a TCP bus to it. */
static int setup(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    snprintf(link_dir, sizeof link_dir, "/tmp/gonio-restart-XXXXXX");
    if (!mkdtemp(link_dir))
        return -1;
    snprintf(link_path, sizeof link_path, "%s/rig", link_dir);
    if (rig_profile_load("default", &rig, &err) < 0 || start_sim(0) < 0)
        return -1;
    struct drv_modbus_bus_cfg cfg;
    drv_modbus_bus_cfg_default(&cfg);
    cfg.host = "127.0.0.1";
    cfg.port = sim.port;
    cfg.device = link_path;
    cfg.time_scale = SCALE;
    cfg.timeout_s = 0.2 * gonio_test_time_factor();
    bus = *(const int *)*state ? drv_modbus_bus_new_rtu(&cfg, &err)
                               : drv_modbus_bus_new_tcp(&cfg, &err);
    if (!bus)
        fprintf(stderr, "%s\n", err.msg);
    return bus ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    drv_modbus_bus_free(bus);
    bus = NULL;
    if (sim.pid > 0)
        sim_proc_stop(&sim);
    unlink(link_path);
    rmdir(link_dir);
    return 0;
}

/* A power cycle: SIGKILL, down ms, then the same port again (the new
 * process serves once it has printed its pty). */
static void restart(long ms)
{
    int port = sim.port;
    kill(sim.pid, SIGKILL);
    waitpid(sim.pid, NULL, 0);
    sim.pid = 0;
    sim_proc_nap(ms);
    if (start_sim(port) < 0)
        fail_msg("gonio-sim did not start again on port %d", port);
}

static drv_axis *arm_axis(int retries)
{
    struct gonio_err err = {0};
    struct drv_modbus_axis_opts opts = {.in_position_deg = 0.05, .move_retries = retries};
    drv_axis *ax = drv_axis_new_modbus(bus, 2, &rig.arm, &opts, "arm", &err);
    if (!ax)
        fail_msg("%s", err.msg);
    return ax;
}

static double move_to(drv_axis *ax, double deg)
{
    struct gonio_err err = {0};
    double at = NAN;
    if (drv_axis_start_move(ax, deg, &err) < 0 || drv_axis_wait(ax, &err) < 0 ||
        drv_axis_position(ax, &at, &err) < 0)
        fail_msg("move to %g: %s", deg, err.msg);
    return at;
}

static void test_clock_carries_on(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    drv_clock *c = drv_clock_new_modbus(bus, 3, &err);
    assert_non_null(c);
    assert_int_equal(drv_clock_sleep(c, 20.0), 0); /* the old clock well past 0 */
    double t1 = drv_clock_now(c), w1 = gonio_monotonic_s();
    restart(200);
    double t2 = drv_clock_now(c), w2 = gonio_monotonic_s();
    fprintf(stderr, "# rig time %.3f s before the restart, %.3f s after\n", t1, t2);
    assert_true(t2 >= t1);
    /* The rig time across the restart is at most what the wall time
     * between the readings allows (no 2^32 ms wrap: 4.29e6 s). */
    assert_true(t2 - t1 <= (w2 - w1) * SCALE * 1.5 + 1.0);
    struct drv_clock_stats st;
    drv_clock_stats(c, &st);
    assert_int_equal(st.restarts, 1);
    assert_int_equal(st.backward, 0);
    /* And it runs on from there at the rig's rate. */
    assert_int_equal(drv_clock_sleep(c, 5.0), 0);
    double t3 = drv_clock_now(c);
    assert_true(t3 - t2 >= 4.99);
    drv_clock_stats(c, &st);
    assert_int_equal(st.restarts, 1);
    drv_clock_free(c);
}

/* The drive restarts between the move's command and its end: the fresh
 * drive rests at 0 with IN-POS (its own target). On TCP, and on RTU. */
static void test_inpos_checked(void **state)
{
    (void)state;
    drv_axis *ax = arm_axis(2);
    struct gonio_err err = {0};
    assert_int_equal(drv_axis_start_move(ax, 30.0, &err), 0);
    restart(100);
    double at = NAN;
    if (drv_axis_wait(ax, &err) < 0 || drv_axis_position(ax, &at, &err) < 0)
        fail_msg("%s", err.msg);
    assert_true(fabs(at - 30.0) <= 0.05);
    struct drv_axis_stats st;
    drv_axis_stats(ax, &st);
    assert_int_equal(st.recommands, 1);
    /* Resting at 30 and told 30 again after another restart: nothing to
     * send, but the encoder says 0, and the axis goes back to 30. */
    restart(0);
    assert_true(fabs(move_to(ax, 30.0) - 30.0) <= 0.05);
    drv_axis_stats(ax, &st);
    assert_int_equal(st.recommands, 2);
    drv_axis_free(ax);
}

/* Without tries left, the move fails naming axis, position and target. */
static void test_inpos_miss_named(void **state)
{
    (void)state;
    drv_axis *ax = arm_axis(0);
    struct gonio_err err = {0};
    assert_int_equal(drv_axis_start_move(ax, 30.0, &err), 0);
    restart(0);
    double at = NAN;
    int rc = drv_axis_wait(ax, &err);
    if (rc == 0)
        rc = drv_axis_position(ax, &at, &err);
    assert_int_equal(rc, -GONIO_EDEVICE);
    fprintf(stderr, "# %s\n", err.msg);
    assert_non_null(strstr(err.msg, "axis arm (slave 2): reported IN-POS at 0 deg, 30 deg short "
                                    "of 30 deg"));
    drv_axis_free(ax);
}

static void test_detector_refuses_across_restart(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    drv_detector *d = drv_detector_new_modbus(bus, 3, &err);
    assert_non_null(d);
    struct drv_reading r;
    for (int i = 0; i < 3; i++)
        assert_int_equal(drv_detector_acquire(d, 0.05, &r, &err), 0);
    restart(100);
    assert_int_equal(drv_detector_acquire(d, 0.05, &r, &err), -GONIO_EDEVICE);
    fprintf(stderr, "# %s\n", err.msg);
    assert_non_null(strstr(err.msg, "detector (slave 3): the device restarted (sequence"));
    /* The next reading is the restarted device's own: taken. */
    assert_int_equal(drv_detector_acquire(d, 0.05, &r, &err), 0);
    drv_detector_free(d);
}

/* A detector comes back from a restart with its shutter open: a closed one
 * is closed again before the next integration, so a dark frame stays dark
 * (the ideal scene reads the material's light, > 0, when open). */
static void test_shutter_closed_again_after_restart(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    drv_detector *d = drv_detector_new_modbus(bus, 3, &err);
    assert_non_null(d);
    struct drv_reading r;
    assert_int_equal(drv_detector_acquire(d, 0.05, &r, &err), 0);
    assert_true(r.rgb[1] > 0);
    assert_int_equal(drv_detector_shutter(d, 1, &err), 0);
    assert_int_equal(drv_detector_acquire(d, 0.05, &r, &err), 0);
    assert_close(r.rgb[1], 0, 0);
    restart(100);
    assert_int_equal(drv_detector_acquire(d, 0.05, &r, &err), -GONIO_EDEVICE);
    assert_int_equal(drv_detector_acquire(d, 0.05, &r, &err), 0);
    for (int c = 0; c < 3; c++)
        assert_close(r.rgb[c], 0, 0);
    drv_detector_free(d);
}

static void test_vanished_device_named(void **state)
{
    (void)state;
    drv_axis *ax = arm_axis(0);
    kill(sim.pid, SIGKILL);
    waitpid(sim.pid, NULL, 0);
    sim.pid = 0;
    struct gonio_err err = {0};
    double at;
    assert_int_equal(drv_axis_position(ax, &at, &err), -GONIO_EDEVICE);
    fprintf(stderr, "# %s\n", err.msg);
    assert_non_null(strstr(err.msg, "the device closed the connection; reconnecting: "
                                    "Connection refused (5 attempts)"));
    assert_null(strstr(err.msg, "Bad file descriptor"));
    drv_axis_free(ax);
}

static const int tcp = 0, rtu = 1;

#define ON(test, kind) \
    {#test " (" #kind ")", test, setup, teardown, (void *)&kind}

int main(void)
{
    const struct CMUnitTest tests[] = {
        ON(test_clock_carries_on, tcp),       ON(test_clock_carries_on, rtu),
        ON(test_inpos_checked, tcp),          ON(test_inpos_checked, rtu),
        ON(test_inpos_miss_named, tcp),       ON(test_detector_refuses_across_restart, tcp),
        ON(test_detector_refuses_across_restart, rtu),
        ON(test_vanished_device_named, tcp),
        ON(test_shutter_closed_again_after_restart, tcp),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
