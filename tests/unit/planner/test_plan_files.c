/* Plan and rig files: refused pairs name the file, the pair and the
 * reason; bad YAML is refused with path:line:col; declared fields are kept. */
#include "tests/gonio_test.h"

#include <math.h>
#include <string.h>
#include <unistd.h>

#include "planner/planner.h"

static char dir[4096];

static int setup(void **state)
{
    (void)state;
    const char *base = getenv("GONIO_TMP");
    char tmpl[4096];
    if (base && *base) {
        if (gonio_mkdir_p(base, NULL) < 0)
            return -1;
        snprintf(tmpl, sizeof tmpl, "%s/planXXXXXX", base);
    } else {
        snprintf(tmpl, sizeof tmpl, "/tmp/gonio-planXXXXXX");
    }
    if (!mkdtemp(tmpl))
        return -1;
    snprintf(dir, sizeof dir, "%s", tmpl);
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    char cmd[4200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd) == 0 ? 0 : -1;
}

static const char *write_yaml(const char *name, const char *text)
{
    static char path[2][4200];
    static int which;
    which ^= 1;
    snprintf(path[which], sizeof path[which], "%s/%s", dir, name);
    FILE *f = fopen(path[which], "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
    return path[which];
}

/* err.msg must start with "path:line:col: " and contain every fragment. */
static void check_msg(const struct gonio_err *err, const char *path, int line, int col,
                      const char *f1, const char *f2)
{
    char want[4400];
    snprintf(want, sizeof want, "%s:%d:%d: ", path, line, col);
    if (strncmp(err->msg, want, strlen(want)) || (f1 && !strstr(err->msg, f1)) ||
        (f2 && !strstr(err->msg, f2))) {
        print_error("message '%s'\nexpected '%s' ... '%s' ... '%s'\n", err->msg, want,
                    f1 ? f1 : "", f2 ? f2 : "");
        fail();
    }
}

static void expect_plan_error(const char *text, int code, int line, int col, const char *f1,
                              const char *f2)
{
    struct rig_profile rig;
    rig_profile_default(&rig);
    const char *path = write_yaml("plan.yaml", text);
    struct plan *p = (struct plan *)1;
    struct gonio_err err = {0};
    assert_int_equal(plan_load(path, &rig, &p, &err), -code);
    assert_null(p);
    assert_int_equal(gonio_exit_status(-code), 2);
    check_msg(&err, path, line, col, f1, f2);
}

static void test_unreachable_refused(void **state)
{
    (void)state;
    /* a = 30 + (-28) = 2 deg: on the source */
    expect_plan_error("pairs:\n  - [30, -60]\n  - [30, -28]\n", GONIO_EUNREACHABLE, 3, 5,
                      "pair (theta_i 30, theta_r -28)", "blind zone");
    expect_plan_error("pairs:\n  - [0, 0]\n", GONIO_EUNREACHABLE, 2, 5,
                      "pair (theta_i 0, theta_r 0)", "blind zone");
    /* a = 80 + 85 = 165 is inside +-170, but theta_i 85 + theta_r 89 is not */
    expect_plan_error("pairs:\n  - [85, 89]\n", GONIO_EUNREACHABLE, 2, 5,
                      "pair (theta_i 85, theta_r 89)", "beyond its limits");

    /* the arm of a smaller rig stops at 60: DS4's a = 66 and 90 are refused */
    const char *rig_path = write_yaml("small.yaml",
                                      "name: small\nout_of_plane: false\nblind_deg: 5\n"
                                      "settle_s: 0.3\n"
                                      "integration: {fixed_s: 0.05, auto_min_s: 0.001, "
                                      "auto_max_s: 2}\n"
                                      "axes:\n"
                                      "  sample: {speed: 20, accel: 40, min: -40, max: 40}\n"
                                      "  arm: {speed: 15, accel: 30, min: -60, max: 60}\n");
    struct rig_profile rig;
    struct gonio_err err = {0};
    assert_int_equal(rig_profile_load(rig_path, &rig, &err), 0);
    assert_string_equal(rig.name, "small");
    struct plan *p;
    char ds4[4200];
    snprintf(ds4, sizeof ds4, "%s/plans/ds4.yaml", gonio_config_dir());
    assert_int_equal(plan_load("ds4", &rig, &p, &err), -GONIO_EUNREACHABLE);
    assert_non_null(strstr(err.msg, ds4));
    assert_non_null(strstr(err.msg, "pair (theta_i 30, theta_r 36)"));
    assert_non_null(strstr(err.msg, "a = 66"));
    /* grid pairs beyond the axes are refused too, not dropped */
    assert_int_equal(plan_load("ds3", &rig, &p, &err), -GONIO_EUNREACHABLE);
    assert_non_null(strstr(err.msg, "pair (theta_i 0, theta_r -80)"));
    assert_non_null(strstr(err.msg, "a = -80"));
    const char *grid = write_yaml("grid.yaml", "grid:\n  theta_i_step: 45\n  theta_i_max: 45\n"
                                               "  diffuse_step: 20\n  glossy_step: 5\n"
                                               "  theta_r_min: -30\n  theta_r_max: 30\n");
    assert_int_equal(plan_load(grid, &rig, &p, &err), -GONIO_EUNREACHABLE);
    check_msg(&err, grid, 2, 3, "pair (theta_i 45, theta_r -30)", "s = 45");
    /* and out-of-plane pairs need the azimuth axis */
    const char *oop = write_yaml("oop.yaml", "pairs:\n  - [30, 0, 40, 90]\n");
    assert_int_equal(plan_load(oop, &rig, &p, &err), -GONIO_EUNREACHABLE);
    assert_non_null(strstr(err.msg, "out-of-plane axis"));
    rig_profile_default(&rig);
    assert_int_equal(plan_load(oop, &rig, &p, &err), 1);
    assert_true(plan_is_out_of_plane(p));
    const struct plan_point *pt = plan_point(p, 0);
    assert_true(pt->out_of_plane);
    assert_close(pt->theta_o, 40, 0);
    assert_close(pt->phi_o, 90, 0);
    plan_free(p);
}

/* A rig that sees less near the source than the plans' grid rule (10 deg
 * against blind: 5): the grid pairs in its blind zone are left out and
 * counted, not a refusal of the whole plan; the rest is DS1 as written. */
static void test_wider_blind_zone(void **state)
{
    (void)state;
    const char *rig_path = write_yaml("blind10.yaml",
                                      "name: blind10\nout_of_plane: false\nblind_deg: 10\n"
                                      "settle_s: 0.3\n"
                                      "integration: {fixed_s: 0.05, auto_min_s: 0.001, "
                                      "auto_max_s: 2}\n"
                                      "axes:\n"
                                      "  sample: {speed: 20, accel: 40, min: -90, max: 90}\n"
                                      "  arm: {speed: 15, accel: 30, min: -170, max: 170}\n");
    struct rig_profile rig, def;
    struct gonio_err err = {0};
    assert_int_equal(rig_profile_load(rig_path, &rig, &err), 0);
    rig_profile_default(&def);
    for (int k = 0; k < 2; k++) {
        const char *name = k ? "ds3" : "ds1";
        struct plan *wide, *narrow;
        assert_true(plan_load(name, &rig, &wide, &err) > 0);
        assert_true(plan_load(name, &def, &narrow, &err) > 0);
        assert_int_equal(plan_dropped(narrow), 0);
        assert_true(plan_dropped(wide) > 0);
        assert_int_equal(plan_count(wide) + plan_dropped(wide), plan_count(narrow));
        size_t inside = 0;
        for (size_t i = 0; i < plan_count(narrow); i++) {
            const struct plan_point *pt = plan_point(narrow, i);
            inside += fabs(pt->theta_i + pt->theta_r) < 10 - 1e-9;
        }
        assert_int_equal(plan_dropped(wide), inside);
        for (size_t i = 0; i < plan_count(wide); i++) {
            const struct plan_point *pt = plan_point(wide, i);
            assert_true(fabs(pt->theta_i + pt->theta_r) >= 10 - 1e-9);
        }
        plan_free(wide);
        plan_free(narrow);
    }
}

static void test_bad_yaml(void **state)
{
    (void)state;
    expect_plan_error("pairs: [[30, 20]\n", GONIO_EBADCONFIG, 2, 1, "YAML syntax", NULL);
    expect_plan_error("pairs:\n  - [30, 20]\norderr: travel\n", GONIO_EBADCONFIG, 3, 1,
                      "key 'orderr': unknown key", NULL);
    expect_plan_error("grid:\n  theta_i_step: 5\n  diffuse_step: 5\n  glossy_step: 1\n"
                      "  glossy_halfwidth: 15\n",
                      GONIO_EBADCONFIG, 5, 3, "key 'glossy_halfwidth'", "unknown key");
    expect_plan_error("pairs:\n  - [95, 20]\n", GONIO_EBADCONFIG, 2, 6, "key 'theta_i'",
                      "out of range (value '95', allowed 0..90)");
    expect_plan_error("grid:\n  theta_i_step: five\n  diffuse_step: 5\n  glossy_step: 1\n",
                      GONIO_EBADCONFIG, 2, 17, "key 'theta_i_step'", "wrong type");
    expect_plan_error("grid:\n  theta_i_step: 5\n  glossy_step: 1\n", GONIO_EBADCONFIG, 2, 3,
                      "key 'diffuse_step'", "missing required key");
    expect_plan_error("pairs:\n  - [30, 20]\norder: fastest\n", GONIO_EBADCONFIG, 3, 8,
                      "key 'order'", "allowed travel, progressive, as-written");
    expect_plan_error("pairs:\n  - [30, 20]\n  - [30, 40]\n  - [30, 20]\n", GONIO_EBADCONFIG,
                      4, 5, "listed twice", "first at line 2");
    expect_plan_error("pairs:\n  - [30, 20]\n  - [30, 0, 40, 90]\n", GONIO_EBADCONFIG, 3, 5,
                      "mixes in-plane and out-of-plane", NULL);
    expect_plan_error("pairs:\n  - [30]\n", GONIO_EBADCONFIG, 2, 5, "key 'pairs'",
                      "[theta_i, theta_r]");
    expect_plan_error("description: nothing to measure\n", GONIO_EBADCONFIG, 1, 1,
                      "one of grid, pairs, domain", NULL);
    expect_plan_error("pairs:\n  - [30, 20]\nstop:\n  converge: {tol: 2}\n", GONIO_EBADCONFIG,
                      4, 19, "key 'tol'", "out of range");
    expect_plan_error("pairs:\n  - [30, 20]\nstop: never\n", GONIO_EBADCONFIG, 3, 7,
                      "key 'stop'", "allowed all");
    expect_plan_error("domain: {set: full, n: 10}\n", GONIO_EBADCONFIG, 1, 24, "key 'n'",
                      "only for set oop-random");
    expect_plan_error("domain: {set: random}\n", GONIO_EBADCONFIG, 1, 15, "key 'set'",
                      "allowed full, inplane, oop-random");
}

static void test_bad_rig(void **state)
{
    (void)state;
    static const char *const base =
        "out_of_plane: false\nblind_deg: 5\nsettle_s: 0.3\n"
        "integration: {fixed_s: 0.05, auto_min_s: 0.001, auto_max_s: 2}\n"
        "axes:\n"
        "  sample: {speed: 20, accel: 40, min: -90, max: 90}\n";
    struct {
        const char *tail;
        int line, col;
        const char *f1, *f2;
    } cases[] = {
        {"  arm: {speed: -15, accel: 30, min: -170, max: 170}\n", 7, 16, "key 'speed'",
         "out of range"},
        {"  arm: {speed: 15, accel: 30, min: -170, max: 170, jerk: 1}\n", 7, 52, "key 'jerk'",
         "unknown key"},
        {"  arm: {speed: 15, accel: 30, min: -170}\n", 7, 8, "key 'max'",
         "missing required key"},
        {"  arm: {speed: 15, accel: 30, min: 170, max: -170}\n", 7, 46, "key 'max'",
         "must exceed min"},
        {"  elevation: {speed: 15, accel: 30, min: -170, max: 170}\n", 7, 3,
         "key 'elevation'", "unknown key"},
        {"  arm: {speed: 15, accel: 30, min: -170, max: 170}\nmechanics: {in_position_deg: 0}\n",
         8, 30, "key 'in_position_deg'", "out of range"},
        {"  arm: {speed: 15, accel: 30, min: -170, max: 170}\nmechanics: {backlash_deg: -1}\n",
         8, 27, "key 'backlash_deg'", "out of range"},
        {"  arm: {speed: 15, accel: 30, min: -170, max: 170}\nmechanics: {approach: up}\n", 8,
         23, "key 'approach'", "allowed positive, negative"},
        {"  arm: {speed: 15, accel: 30, min: -170, max: 170}\nmechanics: {move_retries: 21}\n",
         8, 27, "key 'move_retries'", "out of range"},
        {"  arm: {speed: 15, accel: 30, min: -170, max: 170}\nmechanics: {retries: 2}\n", 8, 13,
         "key 'retries'", "unknown key"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char text[1024];
        snprintf(text, sizeof text, "%s%s", base, cases[i].tail);
        const char *path = write_yaml("rig.yaml", text);
        struct rig_profile rig;
        struct gonio_err err = {0};
        assert_int_equal(rig_profile_load(path, &rig, &err), -GONIO_EBADCONFIG);
        check_msg(&err, path, cases[i].line, cases[i].col, cases[i].f1, cases[i].f2);
    }
    /* an out-of-plane rig needs its azimuth axis */
    char text[1024];
    snprintf(text, sizeof text, "%s%s", "out_of_plane: true\n", strchr(base, '\n') + 1);
    strcat(text, "  arm: {speed: 15, accel: 30, min: -170, max: 170}\n");
    const char *path = write_yaml("rig.yaml", text);
    struct rig_profile rig;
    struct gonio_err err = {0};
    assert_int_equal(rig_profile_load(path, &rig, &err), -GONIO_EBADCONFIG);
    check_msg(&err, path, 1, 15, "key 'out_of_plane'", "azimuth");
}

/* The shipped default profile carries DESIGN.md section 9's numbers. */
static void test_default_rig(void **state)
{
    (void)state;
    struct rig_profile rig;
    struct gonio_err err = {0};
    assert_int_equal(rig_profile_load("default", &rig, &err), 0);
    assert_close(rig.sample.speed, 20, 0);
    assert_close(rig.sample.accel, 40, 0);
    assert_close(rig.arm.speed, 15, 0);
    assert_close(rig.arm.accel, 30, 0);
    assert_close(rig.settle_s, 0.3, 0);
    assert_close(rig.integration_s, 0.05, 0);
    assert_close(rig.auto_min_s, 0.001, 0);
    assert_close(rig.auto_max_s, 2, 0);
    assert_close(rig.blind_deg, 5, 0);
    assert_close(rig.sample.max, 90, 0);
    assert_close(rig.sample.min, -90, 0);
    assert_close(rig.arm.max, 170, 0);
    assert_close(rig.arm.min, -170, 0);
    assert_true(rig.out_of_plane);
    assert_true(rig.azimuth.speed > 0 && rig.azimuth.accel > 0);
    /* the mechanics the drivers use (docs/plans.md) */
    assert_close(rig.mech.in_position_deg, 0.1, 0);
    assert_close(rig.mech.backlash_deg, 0.05, 0);
    assert_int_equal(rig.mech.approach, 1);
    assert_int_equal(rig.mech.move_retries, 10);
    /* a profile without them gets the defaults; approach negative is -1 */
    const char *path = write_yaml("rig.yaml", "out_of_plane: false\nblind_deg: 5\nsettle_s: 0\n"
                                  "integration: {fixed_s: 0.05, auto_min_s: 0.001, "
                                  "auto_max_s: 2}\naxes:\n"
                                  "  sample: {speed: 20, accel: 40, min: -90, max: 90}\n"
                                  "  arm: {speed: 15, accel: 30, min: -170, max: 170}\n");
    assert_int_equal(rig_profile_load(path, &rig, &err), 0);
    assert_close(rig.mech.in_position_deg, 0.1, 0);
    assert_close(rig.mech.backlash_deg, 0, 0);
    assert_int_equal(rig.mech.move_retries, 3);
    FILE *f = fopen(path, "a");
    assert_non_null(f);
    fputs("mechanics: {approach: negative, in_position_deg: 0.02}\n", f);
    fclose(f);
    assert_int_equal(rig_profile_load(path, &rig, &err), 0);
    assert_int_equal(rig.mech.approach, -1);
    assert_close(rig.mech.in_position_deg, 0.02, 0);
}

static void test_declared_fields(void **state)
{
    (void)state;
    struct rig_profile rig;
    rig_profile_default(&rig);
    struct plan *p;
    struct gonio_err err = {0};
    assert_int_equal(plan_load("example-custom", &rig, &p, &err), 9);
    assert_string_equal(plan_name(p), "example-custom");
    assert_int_equal(plan_declared_order(p), PLAN_ORDER_AS_WRITTEN);
    const struct plan_stop *st = plan_stop(p);
    assert_int_equal(st->kind, PLAN_STOP_CONVERGE);
    assert_close(st->tol, 0.01, 0);
    assert_int_equal(st->rounds, 2);
    assert_int_equal(st->every, 4);
    assert_int_equal(st->min_points, 6);
    /* as written: the file's first and last pairs */
    assert_close(plan_point(p, 0)->theta_i, 15, 0);
    assert_close(plan_point(p, 0)->theta_r, -45, 0);
    assert_close(plan_point(p, 8)->theta_r, 70, 0);
    plan_free(p);

    /* defaults: travel, stop all; a name from the file name */
    const char *path = write_yaml("my-plan.yaml", "pairs:\n  - [10, 20]\n");
    assert_int_equal(plan_load(path, &rig, &p, &err), 1);
    assert_string_equal(plan_name(p), "my-plan");
    assert_int_equal(plan_declared_order(p), PLAN_ORDER_TRAVEL);
    assert_int_equal(plan_stop(p)->kind, PLAN_STOP_ALL);
    plan_free(p);

    assert_int_equal(plan_load("no-such-plan", &rig, &p, &err), -GONIO_ENOTFOUND);
    assert_non_null(strstr(err.msg, "no-such-plan"));
    assert_int_equal(gonio_exit_status(err.code), 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_unreachable_refused),
        cmocka_unit_test(test_wider_blind_zone),
        cmocka_unit_test(test_bad_yaml),
        cmocka_unit_test(test_bad_rig),
        cmocka_unit_test(test_default_rig),
        cmocka_unit_test(test_declared_fields),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
