/* The rig clock when devices answer late (a scene with comm_faults late:
 * gonio-sim holds half its answers 0.05 s of wall time, 2.5 s of rig
 * time, and reads the registers as it answers): the rig time after each
 * reading never goes back, and the clock never had to hold it (a reading
 * is carried forward from when the device had surely taken it, not from
 * when it was asked for: from then, a late answer followed by a prompt
 * one would take the rig time back by up to 2.5 s). */
#include <errno.h>
#include <math.h>
#include <string.h>
#include <sys/stat.h>

#include "drivers/drv_modbus.h"
#include "rig/rig.h"
#include "tests/gonio_test.h"
#include "tests/unit/drivers/sim_proc.h"

#define SCALE 50.0

static struct sim_proc sim;
static drv_modbus_bus *bus;
static struct rig_profile rig;
static char dir[64] = "/tmp/gonio-late-XXXXXX", scene[96];

static int group_setup(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    if (rig_profile_load("default", &rig, &err) < 0 || !mkdtemp(dir))
        return -1;
    snprintf(scene, sizeof scene, "%s/late.yaml", dir);
    FILE *f = fopen(scene, "w");
    if (!f)
        return -1;
    fputs("name: late\nmaterial: default\nrig: default\ndetector: {kind: rgb}\nseed: 5\n"
          "effects:\n  - {name: comm_faults, late: 0.5, timeout_s: 0.05}\n", f);
    fclose(f);
    const char *const args[] = {"--time-scale", "50", "--scene", scene, "--tcp", "127.0.0.1:0",
                                NULL};
    if (sim_proc_start(&sim, args) < 0)
        return -1;
    struct drv_modbus_bus_cfg cfg;
    drv_modbus_bus_cfg_default(&cfg);
    cfg.host = "127.0.0.1";
    cfg.port = sim.port;
    cfg.time_scale = SCALE;
    cfg.timeout_s = 0.5 * gonio_test_time_factor(); /* the late answers are taken */
    bus = drv_modbus_bus_new_tcp(&cfg, &err);
    if (!bus)
        fprintf(stderr, "%s\n", err.msg);
    return bus ? 0 : -1;
}

static int group_teardown(void **state)
{
    (void)state;
    drv_modbus_bus_free(bus);
    unlink(scene);
    rmdir(dir);
    return sim_proc_stop(&sim) == 0 ? 0 : -1;
}

static void test_clock_never_back(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    drv_clock *c = drv_clock_new_modbus(bus, 3, &err);
    drv_detector *d = drv_detector_new_modbus(bus, 3, &err);
    struct drv_modbus_axis_opts opts = {.in_position_deg = 0.05, .move_retries = 2};
    drv_axis *arm = drv_axis_new_modbus(bus, 2, &rig.arm, &opts, "arm", &err);
    if (!c || !d || !arm)
        fail_msg("%s", err.msg);
    double last = drv_clock_now(c), at;
    struct drv_reading r;
    for (int i = 0; i < 60; i++) {
        /* A point: a move on every fourth, integrate, date the sample. */
        if ((i % 4 == 0 && (drv_axis_start_move(arm, i % 8 ? 12.0 : 10.0, &err) < 0 ||
                            drv_axis_wait(arm, &err) < 0 ||
                            drv_axis_position(arm, &at, &err) < 0)) ||
            drv_detector_acquire(d, 0.02, &r, &err) < 0)
            fail_msg("point %d: %s", i, err.msg);
        double t = drv_clock_now(c);
        if (t < last)
            fail_msg("point %d: rig time %.3f s after %.3f s", i, t, last);
        last = t;
    }
    struct drv_modbus_stats bs;
    drv_modbus_bus_stats(bus, &bs);
    struct drv_clock_stats cs;
    drv_clock_stats(c, &cs);
    fprintf(stderr, "# %ld requests, rig time %.3f s, held %ld times, %ld restarts\n",
            bs.requests, last, cs.backward, cs.restarts);
    assert_int_equal(cs.backward, 0);
    assert_int_equal(cs.restarts, 0);
    drv_axis_free(arm);
    drv_detector_free(d);
    drv_clock_free(c);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_clock_never_back),
    };
    return cmocka_run_group_tests(tests, group_setup, group_teardown);
}
