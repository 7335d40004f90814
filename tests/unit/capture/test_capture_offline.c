/* The offline capture engine on the embedded default material: samples are
 * the material's values at the measured axes, the rig clock matches the
 * planner's estimate, and the scene-aware estimate before the first move
 * (capture_check, the first ETA) holds within 5 % on a scene whose
 * detector meters each reading (lab's noise with the simulator's ideal
 * meter, tests/gonio_test_cal.h), whose auto-exposure the fixed
 * integration misses by 11-32 %; a torn journal
 * resumes with every point once, a
 * resume of another scene, material or rig is refused, a directory another
 * process writes is refused, and bad input writes nothing. Runs without the
 * shared data. */
#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "brdf/material.h"
#include "common/paths.h"
#include "capture/capture.h"
#include "sim_source/sim_source.h"
#include "journal/journal.h"
#include "planner/planner.h"
#include "tests/gonio_test.h"
#include "tests/gonio_test_cal.h"

static char dir[256];

static int setup(void **state)
{
    (void)state;
    return gonio_test_dir_make(dir, sizeof dir, "capture");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

static struct capture_config config(const char *out)
{
    return (struct capture_config){
        .plan = "ds3", .model = "abc", .out_dir = out, .quiet = 1,
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
    assert_int_equal(sim_source_capture("ideal", &cfg, NULL, &s, &err), 0);
    assert_int_equal(s.samples, 52);
    check_samples(out, 52);

    /* The simulated clock runs the same motion as the planner's estimate,
     * backlash approach legs included: the default rig has backlash, and
     * DS3 moves its axes both ways. */
    struct rig_profile rig;
    struct plan *plan;
    assert_int_equal(rig_profile_load("default", &rig, &err), 0);
    assert_true(rig.mech.backlash_deg > 0);
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
    assert_int_equal(sim_source_capture("ideal", &cfg, NULL, &first, &err), 0);

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

    assert_int_equal(sim_source_capture("ideal", &cfg, NULL, &second, &err), 0);
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
    struct capture_summary s;
    struct gonio_err err = {0};
    int rc = sim_source_capture(scene, &cfg, NULL, &s, &err);
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
    assert_true(sim_source_capture("ideal", &cfg, NULL, &s, &err) < 0);
    assert_int_equal(gonio_exit_status(err.code), 2);
    assert_non_null(strstr(err.msg, "no-such-material"));
    assert_false(exists(out));

    cfg = config(out);
    cfg.plan = "no-such-plan";
    assert_true(sim_source_capture("ideal", &cfg, NULL, &s, &err) < 0);
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
    assert_true(sim_source_capture("ideal", &cfg, NULL, &s, &err) < 0);
    assert_non_null(strstr(err.msg, "another plan"));
    check_samples(out, 52); /* the DS3 capture is untouched */
}

/* A whole file, for byte-for-byte comparisons (NUL-terminated; free it). */
static char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    char *buf = malloc(1 << 20);
    *len = fread(buf, 1, (1 << 20) - 1, f);
    buf[*len] = '\0';
    fclose(f);
    return buf;
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

/* Resume `out` (the DS3 capture of scene ideal) with cfg: refused as bad
 * input, the message naming want, the journal and setup.json unchanged. */
static void check_refused(const char *out, const char *scene, const struct capture_config *cfg,
                          const char *want)
{
    char path[512], setup[512];
    snprintf(path, sizeof path, "%s/samples.csv", out);
    snprintf(setup, sizeof setup, "%s/setup.json", out);
    size_t len, len2, slen, slen2;
    char *before = slurp(path, &len), *sbefore = slurp(setup, &slen);
    struct capture_summary s;
    struct gonio_err err = {0};
    int rc = sim_source_capture(scene, cfg, NULL, &s, &err);
    assert_int_equal(rc, -GONIO_EUSAGE);
    assert_int_equal(gonio_exit_status(rc), 2);
    if (!strstr(err.msg, want))
        fail_msg("message '%s' lacks '%s'", err.msg, want);
    char *after = slurp(path, &len2), *safter = slurp(setup, &slen2);
    assert_int_equal(len, len2);
    assert_memory_equal(before, after, len);
    assert_int_equal(slen, slen2);
    assert_memory_equal(sbefore, safter, slen);
    free(before);
    free(after);
    free(sbefore);
    free(safter);
}

static void test_resume_of_another_setup_is_refused(void **state)
{
    (void)state;
    char out[300], scene[300], rig[300], msg[600];
    snprintf(out, sizeof out, "%s/full", dir); /* the DS3 capture of scene ideal */
    struct capture_config cfg = config(out);

    snprintf(scene, sizeof scene, "%s/other.yaml", dir);
    write_text(scene, "name: other\nmaterial: default\nrig: default\n");
    snprintf(msg, sizeof msg, "%s: setup.json has scene 'ideal', this capture asks for 'other'; "
             "use a new directory", out);
    check_refused(out, scene, &cfg, msg);

    cfg = config(out);
    cfg.material = "builtin:red-plastic";
    check_refused(out, "ideal", &cfg, "setup.json has material 'builtin:nylon', this capture asks for "
                  "'builtin:red-plastic'");

    /* The same profile under another name is another rig. */
    char rigs[600];
    snprintf(rigs, sizeof rigs, "%s/rigs/default.yaml", gonio_config_dir());
    char *text = slurp(rigs, &(size_t){0});
    char *name = strstr(text, "\nname: default\n");
    assert_non_null(name);
    snprintf(rig, sizeof rig, "%s/rig.yaml", dir);
    FILE *f = fopen(rig, "w");
    fprintf(f, "%.*s\nname: other\n%s", (int)(name - text), text, name + strlen("\nname: default\n"));
    fclose(f);
    free(text);
    cfg = config(out);
    cfg.rig = rig;
    check_refused(out, "ideal", &cfg, "setup.json has rig 'default', this capture asks for 'other'");
}

/* While another process holds the directory, a capture is refused with
 * that process's pid and writes nothing. */
static void test_directory_in_use_is_refused(void **state)
{
    (void)state;
    char out[300], path[400];
    snprintf(out, sizeof out, "%s/held", dir);
    assert_int_equal(mkdir(out, 0755), 0);
    snprintf(path, sizeof path, "%s/lock", out);
    int ready[2];
    assert_int_equal(pipe(ready), 0);
    pid_t child = gonio_test_fork();
    assert_true(child >= 0);
    if (child == 0) {
        int fd = open(path, O_RDWR | O_CREAT, 0644);
        struct flock fl = {.l_type = F_WRLCK, .l_whence = SEEK_SET};
        char ok = fd >= 0 && fcntl(fd, F_SETLK, &fl) == 0 ? 'y' : 'n';
        if (write(ready[1], &ok, 1) != 1)
            _exit(1);
        pause();
        _exit(0);
    }
    char ok = 0;
    assert_int_equal(read(ready[0], &ok, 1), 1);
    assert_int_equal(ok, 'y');
    struct capture_config cfg = config(out);
    struct capture_summary s;
    struct gonio_err err = {0};
    int rc = sim_source_capture("ideal", &cfg, NULL, &s, &err);
    kill(child, SIGKILL);
    waitpid(child, NULL, 0);
    close(ready[0]);
    close(ready[1]);
    assert_true(rc < 0);
    char want[400];
    snprintf(want, sizeof want, "%s: capture directory is in use by pid %ld", out, (long)child);
    assert_string_equal(err.msg, want);
    snprintf(path, sizeof path, "%s/plan.json", out);
    assert_false(exists(path));
    snprintf(path, sizeof path, "%s/samples.csv", out);
    assert_false(exists(path));
    /* The holder gone, the directory is free again. */
    assert_int_equal(sim_source_capture("ideal", &cfg, NULL, &s, &err), 0);
    check_samples(out, 52);
}

/* The first call comes before anything is written, then one per point. */
static enum capture_control abort_after_ten(void *user)
{
    size_t *calls = user;
    return ++*calls > 11 ? CAPTURE_ABORT : CAPTURE_GO;
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
    assert_int_equal(sim_source_capture("ideal", &cfg, &hooks, &s, &err), 0);
    assert_string_equal(s.stop_reason, "aborted");
    assert_int_equal(s.samples, 10);
    check_samples(out, 10);
    snprintf(path, sizeof path, "%s/results.json", out);
    assert_false(exists(path));

    assert_int_equal(sim_source_capture("ideal", &cfg, NULL, &s, &err), 0);
    assert_string_equal(s.stop_reason, "complete");
    check_samples(out, 52);
    assert_true(exists(path));
}

struct seen {
    size_t calls;
    double first_eta, first_estimate, last_eta, last_rig;
    int rig_went_back;
};

static void on_progress(void *user, const struct capture_progress *p)
{
    struct seen *s = user;
    if (s->calls++ == 0) {
        s->first_eta = p->eta_s;
        s->first_estimate = p->estimate_s;
    } else if (p->rig_time_s < s->last_rig) {
        s->rig_went_back = 1;
    }
    s->last_eta = p->eta_s;
    s->last_rig = p->rig_time_s;
}

/* capture_check's estimate, and the capture's rig time, of plan on scene. */
static void estimate_and_capture(const char *plan, const char *scene, double *est_s,
                                 double *fixed_s, double *actual_s, struct seen *seen)
{
    char out[400];
    snprintf(out, sizeof out, "%s/est-%s-%s", dir, plan, scene);
    struct capture_config cfg = {.plan = plan, .model = "abc", .out_dir = out,
                                 .quiet = 1, .measure_only = 1};
    struct gonio_err err = {0};
    struct plan_estimate est;
    assert_int_equal(sim_source_check(scene, &cfg, &est, &err), 0);
    *est_s = est.total_s;

    struct rig_profile rig;
    struct plan *p;
    assert_int_equal(rig_profile_load("default", &rig, &err), 0);
    assert_true(plan_load(plan, &rig, &p, &err) > 0);
    plan_estimate(p, &rig, &est);
    *fixed_s = est.total_s;
    plan_free(p);

    struct capture_hooks hooks = {.on_progress = on_progress, .user = seen};
    struct capture_summary s;
    assert_int_equal(sim_source_capture(scene, &cfg, &hooks, &s, &err), 0);
    *actual_s = s.rig_time_s;
}

static void test_estimate_within_5_percent(void **state)
{
    (void)state;
    static const char *const plans[] = {"ds3", "ds4"};
    char metered[300];
    gonio_test_metered_scene(dir, metered, sizeof metered);
    const char *const scenes[] = {"ideal", metered};
    for (size_t i = 0; i < 2; i++)
        for (size_t k = 0; k < 2; k++) {
            double est, fixed, actual;
            struct seen seen = {0};
            estimate_and_capture(plans[i], scenes[k], &est, &fixed, &actual, &seen);
            print_message("%s on %s: estimate %.1f s (fixed integration %.1f s), actual %.1f s\n",
                          plans[i], scenes[k], est, fixed, actual);
            assert_true(fabs(est - actual) <= 0.05 * actual);
            /* The metered scene auto-exposes: the fixed integration misses it. */
            if (k == 1)
                assert_true(fabs(fixed - actual) > 0.05 * actual);
            /* The first ETA is the estimate, before the first move; the
             * last is 0; the rig clock never runs back. */
            assert_true(seen.calls > 1);
            assert_true(fabs(seen.first_eta - est) < 1e-9 * est);
            assert_true(fabs(seen.first_estimate - est) < 1e-9 * est);
            assert_true(fabs(seen.last_eta) < 1e-9);
            assert_false(seen.rig_went_back);
        }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_capture_matches_material_and_estimate),
        cmocka_unit_test(test_resume_after_torn_journal),
        cmocka_unit_test(test_bad_scene_writes_nothing),
        cmocka_unit_test(test_unknown_material_and_plan_write_nothing),
        cmocka_unit_test(test_other_capture_in_directory_is_refused),
        cmocka_unit_test(test_resume_of_another_setup_is_refused),
        cmocka_unit_test(test_directory_in_use_is_refused),
        cmocka_unit_test(test_abort_keeps_data_and_resumes),
        cmocka_unit_test(test_estimate_within_5_percent),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
