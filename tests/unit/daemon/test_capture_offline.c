/* The offline capture engine on the embedded default material: samples are
 * the material's values at the measured axes, the rig clock matches the
 * planner's estimate, a torn journal resumes with every point once, and bad
 * input writes nothing. Runs without the shared data. */
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "brdf/material.h"
#include "daemon/capture.h"
#include "daemon/journal.h"
#include "planner/planner.h"
#include "tests/gonio_test.h"

static char dir[256];

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/gonio-capture-XXXXXX");
    return mkdtemp(dir) ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd);
}

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

static struct capture_config config(const char *out)
{
    return (struct capture_config){
        .plan = "ds3", .scene = "ideal", .model = "abc", .out_dir = out, .quiet = 1,
        .assess_nodes = gonio_test_assess_nodes()};
}

/* Every planned point exactly once, each sample the material's exact value. */
static void check_samples(const char *out, size_t want)
{
    char path[512];
    snprintf(path, sizeof path, "%s/samples.csv", out);
    struct journal_sample *s;
    size_t n;
    assert_int_equal(journal_read(path, &s, &n, NULL), 0);
    assert_int_equal(n, want);
    unsigned char *seen = calloc(want, 1);
    struct gonio_err err;
    brdf_material *m = brdf_material_open("default", &err);
    assert_non_null(m);
    for (size_t i = 0; i < n; i++) {
        assert_true(s[i].point >= 0 && (size_t)s[i].point < want);
        assert_false(seen[s[i].point]);
        seen[s[i].point] = 1;
        struct brdf_pair p;
        double rgb[3];
        brdf_pair_inplane(s[i].s, s[i].a - s[i].s, &p);
        brdf_material_eval(m, &p, 1, rgb);
        assert_memory_equal(rgb, s[i].rgb, sizeof rgb);
        if (i > 0)
            assert_true(s[i].rig_time_s > s[i - 1].rig_time_s);
    }
    brdf_material_free(m);
    free(seen);
    free(s);
}

static void test_capture_matches_material_and_estimate(void **state)
{
    (void)state;
    char out[300];
    snprintf(out, sizeof out, "%s/full", dir);
    struct capture_config cfg = config(out);
    struct capture_summary s;
    struct gonio_err err = {0};
    assert_int_equal(capture_run_offline(&cfg, &s, &err), 0);
    assert_int_equal(s.samples, 52);
    check_samples(out, 52);

    /* The simulated clock runs the same motion as the planner's estimate. */
    struct plan_rig rig;
    struct plan *plan;
    assert_int_equal(plan_rig_load("default", &rig, &err), 0);
    assert_int_equal(plan_load("ds3", &rig, &plan, &err), 52);
    struct plan_estimate est;
    plan_estimate(plan, &rig, &est);
    assert_rel_close(s.rig_time_s, est.total_s, 1e-9);
    assert_rel_close(s.move_s, est.move_s, 1e-9);
    plan_free(plan);

    /* The fit is of the true material: errors are finite and small. */
    assert_true(s.has_truth);
    assert_true(isfinite(s.params.B) && s.params.eta > 1);
    assert_true(s.err_full.log > 0 && s.err_full.log < 0.1);
    assert_true(s.err_inplane.log > 0 && s.err_inplane.log < 0.1);

    char path[512];
    snprintf(path, sizeof path, "%s/results.json", out);
    assert_true(exists(path));
    snprintf(path, sizeof path, "%s/plan.json", out);
    assert_true(exists(path));
}

static void test_resume_after_torn_journal(void **state)
{
    (void)state;
    char out[300], path[512];
    snprintf(out, sizeof out, "%s/resume", dir);
    struct capture_config cfg = config(out);
    struct capture_summary first, second;
    struct gonio_err err = {0};
    assert_int_equal(capture_run_offline(&cfg, &first, &err), 0);

    /* Keep the first 20 records and half of the 21st, as a crash would. */
    snprintf(path, sizeof path, "%s/samples.csv", out);
    FILE *f = fopen(path, "r");
    char *buf = malloc(1 << 20);
    size_t len = fread(buf, 1, 1 << 20, f);
    fclose(f);
    size_t cut = 0;
    for (int lines = 0; lines < 21; cut++)
        if (buf[cut] == '\n')
            lines++;
    cut += 30;
    assert_true(cut < len);
    assert_int_equal(truncate(path, (off_t)cut), 0);
    free(buf);
    snprintf(path, sizeof path, "%s/results.json", out);
    unlink(path);

    assert_int_equal(capture_run_offline(&cfg, &second, &err), 0);
    assert_int_equal(second.samples, 52);
    check_samples(out, 52);
    assert_true(exists(path));
    /* Noise-free samples of the same points: the same fit. */
    assert_rel_close(second.err_full.log, first.err_full.log, 1e-6);
}

static void test_bad_scene_writes_nothing(void **state)
{
    (void)state;
    char scene[300], out[300];
    snprintf(scene, sizeof scene, "%s/bad-scene.yaml", dir);
    snprintf(out, sizeof out, "%s/never", dir);
    FILE *f = fopen(scene, "w");
    fputs("material: default\nrig: default\nexposure: 3\n", f);
    fclose(f);
    struct capture_config cfg = config(out);
    cfg.scene = scene;
    struct capture_summary s;
    struct gonio_err err = {0};
    int rc = capture_run_offline(&cfg, &s, &err);
    assert_int_equal(rc, -GONIO_EBADCONFIG);
    assert_non_null(strstr(err.msg, scene));
    assert_non_null(strstr(err.msg, "exposure"));
    assert_false(exists(out));
}

static void test_unknown_material_and_plan_write_nothing(void **state)
{
    (void)state;
    char out[300];
    snprintf(out, sizeof out, "%s/never2", dir);
    struct capture_config cfg = config(out);
    cfg.material = "builtin:no-such-material";
    struct capture_summary s;
    struct gonio_err err = {0};
    assert_true(capture_run_offline(&cfg, &s, &err) < 0);
    assert_int_equal(gonio_exit_status(err.code), 2);
    assert_non_null(strstr(err.msg, "no-such-material"));
    assert_false(exists(out));

    cfg = config(out);
    cfg.plan = "no-such-plan";
    assert_true(capture_run_offline(&cfg, &s, &err) < 0);
    assert_int_equal(gonio_exit_status(err.code), 2);
    assert_false(exists(out));
}

static void test_other_capture_in_directory_is_refused(void **state)
{
    (void)state;
    char out[300];
    snprintf(out, sizeof out, "%s/full", dir); /* holds the DS3 capture */
    struct capture_config cfg = config(out);
    cfg.plan = "ds4";
    struct capture_summary s;
    struct gonio_err err = {0};
    assert_true(capture_run_offline(&cfg, &s, &err) < 0);
    assert_non_null(strstr(err.msg, "another plan"));
    check_samples(out, 52); /* the DS3 capture is untouched */
}

static enum capture_control abort_after_ten(void *user)
{
    size_t *calls = user;
    return ++*calls > 10 ? CAPTURE_ABORT : CAPTURE_GO;
}

static void test_abort_keeps_data_and_resumes(void **state)
{
    (void)state;
    char out[300], path[512];
    snprintf(out, sizeof out, "%s/abort", dir);
    struct capture_config cfg = config(out);
    size_t calls = 0;
    struct capture_hooks hooks = {.control = abort_after_ten, .user = &calls};
    struct capture_summary s;
    struct gonio_err err = {0};
    assert_int_equal(capture_run(&cfg, &hooks, &s, &err), 0);
    assert_string_equal(s.stop_reason, "aborted");
    assert_int_equal(s.samples, 10);
    check_samples(out, 10);
    snprintf(path, sizeof path, "%s/results.json", out);
    assert_false(exists(path));

    assert_int_equal(capture_run_offline(&cfg, &s, &err), 0);
    assert_string_equal(s.stop_reason, "complete");
    check_samples(out, 52);
    assert_true(exists(path));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_capture_matches_material_and_estimate),
        cmocka_unit_test(test_resume_after_torn_journal),
        cmocka_unit_test(test_bad_scene_writes_nothing),
        cmocka_unit_test(test_unknown_material_and_plan_write_nothing),
        cmocka_unit_test(test_other_capture_in_directory_is_refused),
        cmocka_unit_test(test_abort_keeps_data_and_resumes),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
