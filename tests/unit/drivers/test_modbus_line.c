/* What a move costs on a slow bus (docs/protocol-modbus.md, "Bus cost per
 * move"): the Modbus axis against a gonio-sim process that charges each
 * RTU exchange its frames' time at 19200 baud. A move the drive reports
 * IN-POS for is a write and a status read, the encoder's feedback is read
 * only when asked for (while the axes settle), and the rest is dated by
 * the status read, not by whatever the bus did after it. A backlash leg
 * has its position stored on the drive while the first leg runs, then
 * starts with the trigger alone. */
#include <math.h>
#include <string.h>

#include "drivers/drv_modbus.h"
#include "modbus_map/modbus_map.h"
#include "rig/rig.h"
#include "tests/gonio_test.h"
#include "tests/unit/drivers/sim_proc.h"

#define BAUD 19200
#define SCALE 10.0

static struct sim_proc sim;
static drv_modbus_bus *bus;
static struct rig_profile rig;

static int group_setup(void **state)
{
    (void)state;
    static const char *const args[] = {"--time-scale", "10", "--baud", "19200", NULL};
    struct gonio_err err = {0};
    if (sim_proc_start(&sim, args) < 0 || rig_profile_load("default", &rig, &err) < 0)
        return -1;
    struct drv_modbus_bus_cfg cfg;
    drv_modbus_bus_cfg_default(&cfg);
    cfg.device = sim.pty;
    cfg.baud = BAUD;
    cfg.time_scale = SCALE;
    cfg.timeout_s *= gonio_test_time_factor();
    bus = drv_modbus_bus_new_rtu(&cfg, &err);
    if (!bus)
        fprintf(stderr, "%s\n", err.msg);
    return bus ? 0 : -1;
}

static int group_teardown(void **state)
{
    (void)state;
    drv_modbus_bus_free(bus);
    return sim_proc_stop(&sim) == 0 ? 0 : -1;
}

static long requests(void)
{
    struct drv_modbus_stats st;
    drv_modbus_bus_stats(bus, &st);
    return st.requests;
}

/* Requests a move to deg takes until the axis rests, and the position
 * then read (with the requests that read costs). */
static long move(drv_axis *ax, double deg, long *read_cost, double *at)
{
    struct gonio_err err = {0};
    long n = requests();
    if (drv_axis_start_move(ax, deg, &err) < 0 || drv_axis_wait(ax, &err) < 0)
        fail_msg("move to %g: %s", deg, err.msg);
    long moved = requests() - n;
    n = requests();
    if (drv_axis_position(ax, at, &err) < 0)
        fail_msg("position: %s", err.msg);
    *read_cost = requests() - n;
    return moved;
}

static void test_move_costs_write_and_status(void **state)
{
    (void)state;
    struct drv_modbus_axis_opts opts = {.in_position_deg = rig.mech.in_position_deg,
                                        .backlash_deg = rig.mech.backlash_deg,
                                        .approach = rig.mech.approach,
                                        .move_retries = rig.mech.move_retries};
    struct gonio_err err = {0};
    drv_axis *arm = drv_axis_new_modbus(bus, MB_SLAVE_ARM, &rig.arm, &opts, "arm", &err);
    assert_non_null(arm);
    double at = NAN;
    long read_cost = 0;

    /* The first move reads where the axis is (it knows nothing yet). */
    move(arm, 10.0, &read_cost, &at);
    assert_int_equal(read_cost, 1);
    assert_true(fabs(at - 10.0) <= 0.005);

    /* Upward, from the reference side: the block from the position to the
     * trigger, one status read that sees IN-POS; the encoder only when
     * asked, once. */
    assert_int_equal(move(arm, 12.0, &read_cost, &at), 2);
    assert_int_equal(read_cost, 1);
    assert_true(fabs(at - 12.0) <= 0.005);
    /* The rest was dated by the status read: since its answer the bus
     * carried at least that answer's 13 characters and the feedback
     * read's 8 + 9, 10 bits each at BAUD, in rig time. */
    double least = (13 + 8 + 9) * 10.0 / BAUD;
    double rested = drv_axis_rested(arm);
    if (!(rested >= least))
        fail_msg("rested %.4f s after the feedback read, at least %.4f s expected", rested,
                 least);
    double again = NAN;
    long n = requests();
    assert_int_equal(drv_axis_position(arm, &again, &err), 0);
    assert_int_equal(requests(), n);
    assert_true(again == at);

    /* Downward, against the approach: the leg beyond the target, its
     * final leg's position stored meanwhile, a status read, the trigger
     * alone, a status read. */
    assert_int_equal(move(arm, 5.0, &read_cost, &at), 5);
    assert_int_equal(read_cost, 1);
    assert_true(fabs(at - 5.0) <= 0.005);

    /* Already there: nothing sent; the encoder read once, while waiting
     * (a drive that restarted since would have lost the position). */
    assert_int_equal(move(arm, 5.0, &read_cost, &at), 1);
    assert_int_equal(read_cost, 0);
    assert_true(fabs(at - 5.0) <= 0.005);
    drv_axis_free(arm);
}

/* A speed libmodbus has no case for (1800 baud) is refused when the bus
 * opens, naming it: libmodbus would set the line to 9600 without a word
 * and the devices would stay silent. gonio-sim's own line is 19200. */
static void test_unsupported_speed_is_refused(void **state)
{
    (void)state;
    struct drv_modbus_bus_cfg cfg;
    drv_modbus_bus_cfg_default(&cfg);
    cfg.device = sim.pty;
    cfg.time_scale = SCALE;
    struct gonio_err err = {0};
    cfg.baud = 1800;
    assert_null(drv_modbus_bus_new_rtu(&cfg, &err));
    if (!strstr(err.msg, "baud 1800") || !strstr(err.msg, "9600 baud instead"))
        fail_msg("%s", err.msg);
    cfg.baud = 2400;
    drv_modbus_bus *other = drv_modbus_bus_new_rtu(&cfg, &err);
    if (!other)
        fail_msg("%s", err.msg);
    drv_modbus_bus_free(other);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_move_costs_write_and_status),
        cmocka_unit_test(test_unsupported_speed_is_refused),
    };
    return cmocka_run_group_tests(tests, group_setup, group_teardown);
}
