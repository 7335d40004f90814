/* The axis mechanics (drivers/drivers.h) on the in-process rig, the same
 * cases test_modbus_mechanics puts to gonio-sim's drives, with a scene
 * that jitters the azimuth (0.3 deg), stalls the arm on its moves 2 and 3
 * (alarm 0x10) and raises alarm 0x70 (abnormal operation data) on its move
 * 6, and one that raises a sensor error (0x28) on the sample's move 2: re-commands
 * bring a jittered drive into the band or the move fails saying overshoot
 * or short and what was tried; a deviation alarm is reset, a sensor error
 * re-homed, 0x70 is not retried; drv_axis_stats counts what it took. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "brdf/material.h"
#include "drivers/drv_sim.h"
#include "rig/rig.h"
#include "sim/scene.h"
#include "tests/gonio_test.h"

static brdf_material *material;
static struct sim_scene scene, sensor_scene;

static int load_scene(const char *effects, struct sim_scene *out)
{
    char dir[64] = "/tmp/gonio-axmech-XXXXXX", path[96];
    if (!mkdtemp(dir))
        return -1;
    snprintf(path, sizeof path, "%s/scene.yaml", dir);
    FILE *f = fopen(path, "w");
    if (!f)
        return -1;
    fprintf(f, "name: mechanics\nmaterial: default\nrig: default\ndetector: {kind: rgb}\n"
            "seed: 3\neffects:\n%s", effects);
    fclose(f);
    struct gonio_err err = {0};
    int rc = sim_scene_load(path, out, &err);
    unlink(path);
    rmdir(dir);
    if (rc < 0)
        fprintf(stderr, "%s\n", err.msg);
    return rc;
}

static int group_setup(void **state)
{
    (void)state;
    material = brdf_material_open("default", NULL);
    if (!material ||
        load_scene("  - {name: jitter, sigma_deg: 0.3, axes: [azimuth]}\n"
                   "  - {name: stall, axes: [arm], at_moves: [2, 3]}\n"
                   "  - {name: alarm, axes: [arm], at_moves: [6], code: 112}\n",
                   &scene) < 0)
        return -1;
    return load_scene("  - {name: alarm, axes: [sample], at_moves: [2], code: 40}\n",
                      &sensor_scene) < 0 ? -1 : 0;
}

static int group_teardown(void **state)
{
    (void)state;
    brdf_material_free(material);
    return 0;
}

/* A rig whose drives come to rest within band, with tries, no backlash. */
static sim_rig *rig_of(const struct sim_scene *sc, struct rig_profile *prof, double band,
                       int retries)
{
    rig_profile_default(prof);
    prof->mech = (struct rig_mechanics){.in_position_deg = band, .approach = 1,
                                         .move_retries = retries};
    struct gonio_err err = {0};
    sim_rig *rig = sim_rig_new_scene(prof, material, sc, NULL, &err);
    if (!rig)
        fail_msg("%s", err.msg);
    return rig;
}

static void test_recommand(void **state)
{
    (void)state;
    struct rig_profile prof;
    sim_rig *rig = rig_of(&scene, &prof, 0.05, 0);
    drv_axis *once = drv_axis_new_sim(rig, SIM_AXIS_AZIMUTH);
    struct gonio_err err = {0};
    int failed = 0;
    double from = 0;
    for (int i = 1; i <= 10; i++) {
        double target = (i % 2 ? 1 : -1) * 10.0 * i;
        assert_int_equal(drv_axis_start_move(once, target, &err), 0);
        int rc = drv_axis_wait(once, &err);
        double at = sim_rig_position(rig, SIM_AXIS_AZIMUTH);
        if (rc == 0) {
            assert_true(fabs(at - target) <= 0.05 + 1e-9);
        } else {
            failed++;
            assert_int_equal(rc, -GONIO_EDEVICE);
            char want[160];
            double over = (at - target) * (target > from ? 1 : -1);
            snprintf(want, sizeof want, "axis azimuth: stopped at %g deg, %.3g deg %s %g deg", at,
                     fabs(over), over > 0 ? "past (overshoot)" : "short of", target);
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
    sim_rig_free(rig);

    rig = rig_of(&scene, &prof, 0.05, 20);
    drv_axis *tries = drv_axis_new_sim(rig, SIM_AXIS_AZIMUTH);
    for (int i = 1; i <= 10; i++) {
        double target = (i % 2 ? -1 : 1) * 7.0 * i;
        assert_int_equal(drv_axis_start_move(tries, target, &err), 0);
        if (drv_axis_wait(tries, &err) < 0)
            fail_msg("%s", err.msg);
        double told = NAN;
        assert_int_equal(drv_axis_position(tries, &told, &err), 0);
        assert_close(told, sim_rig_position(rig, SIM_AXIS_AZIMUTH), 0); /* not the target */
        assert_true(fabs(told - target) <= 0.05 + 1e-9);
    }
    drv_axis_stats(tries, &st);
    assert_true(st.recommands > 0);
    assert_int_equal(st.moves, 10 + 2 * st.recommands); /* back off, come again */
    assert_int_equal(st.alarms_recovered, 0);
    drv_axis_free(tries);
    sim_rig_free(rig);

    /* One try left over ten moves: some move runs out and says so. */
    rig = rig_of(&scene, &prof, 0.05, 1);
    drv_axis *two = drv_axis_new_sim(rig, SIM_AXIS_AZIMUTH);
    int rc = 0;
    for (int i = 0; i < 10 && rc == 0; i++)
        if ((rc = drv_axis_start_move(two, 5.0 * (i + 1), &err)) == 0)
            rc = drv_axis_wait(two, &err);
    assert_int_equal(rc, -GONIO_EDEVICE);
    assert_non_null(strstr(err.msg, "after 2 tries (re-commanded once)"));
    drv_axis_free(two);
    sim_rig_free(rig);
}

/* The arm stalls on its moves 2 and 3: without tries the move fails naming
 * the alarm; with them the alarm is reset and the move completes from the
 * reference side, with no re-homing; its move 6 raises 0x70, which is not
 * retried though tries are left. */
static void test_alarms(void **state)
{
    (void)state;
    struct rig_profile prof;
    sim_rig *rig = rig_of(&scene, &prof, 0.05, 0);
    drv_axis *once = drv_axis_new_sim(rig, SIM_AXIS_ARM);
    struct gonio_err err = {0};
    assert_int_equal(drv_axis_start_move(once, 20, &err), 0);
    assert_int_equal(drv_axis_wait(once, &err), 0);
    assert_int_equal(drv_axis_start_move(once, -10, &err), 0);
    assert_int_equal(drv_axis_wait(once, &err), -GONIO_EDEVICE);
    assert_string_equal(err.msg, "axis arm: drive alarm 0x10 (excessive position deviation)");
    assert_int_equal(drv_axis_alarm_reset(once, &err), 0);
    drv_axis_free(once);

    prof.mech.move_retries = 2; /* an axis takes the rig's profile as it is made */
    drv_axis *arm = drv_axis_new_sim(rig, SIM_AXIS_ARM);
    assert_int_equal(drv_axis_start_move(arm, -10, &err), 0); /* move 3: stalls */
    if (drv_axis_wait(arm, &err) < 0)
        fail_msg("%s", err.msg);
    assert_close(sim_rig_position(rig, SIM_AXIS_ARM), -10, 0);
    struct drv_axis_stats st;
    drv_axis_stats(arm, &st);
    assert_int_equal(st.alarms_recovered, 1);
    assert_int_equal(st.rehomes, 0);
    assert_int_equal(st.recommands, 0);
    assert_int_equal(st.moves, 3); /* the stalled move, back off, come again */

    assert_int_equal(drv_axis_start_move(arm, 30, &err), 0); /* move 6: 0x70 */
    assert_int_equal(drv_axis_wait(arm, &err), -GONIO_EDEVICE);
    assert_string_equal(err.msg, "axis arm: drive alarm 0x70 (abnormal operation data)");
    drv_axis_stats(arm, &st);
    assert_int_equal(st.alarms_recovered, 1);
    drv_axis_free(arm);
    sim_rig_free(rig);
}

/* A sensor error on the sample's move 2: the position is in doubt, so the
 * axis is re-homed before the move is tried again. */
static void test_sensor_alarm_rehomes(void **state)
{
    (void)state;
    struct rig_profile prof;
    sim_rig *rig = rig_of(&sensor_scene, &prof, 0.05, 1);
    drv_axis *s = drv_axis_new_sim(rig, SIM_AXIS_SAMPLE);
    struct gonio_err err = {0};
    assert_int_equal(drv_axis_start_move(s, 10, &err), 0);
    assert_int_equal(drv_axis_wait(s, &err), 0);
    assert_int_equal(drv_axis_start_move(s, 30, &err), 0);
    if (drv_axis_wait(s, &err) < 0)
        fail_msg("%s", err.msg);
    assert_close(sim_rig_position(rig, SIM_AXIS_SAMPLE), 30, 0);
    struct drv_axis_stats st;
    drv_axis_stats(s, &st);
    assert_int_equal(st.alarms_recovered, 1);
    assert_int_equal(st.rehomes, 1);
    drv_axis_free(s);
    sim_rig_free(rig);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_recommand),
        cmocka_unit_test(test_alarms),
        cmocka_unit_test(test_sensor_alarm_rehomes),
    };
    return cmocka_run_group_tests(tests, group_setup, group_teardown);
}
