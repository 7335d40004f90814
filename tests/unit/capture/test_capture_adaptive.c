/* Adaptive captures (--order adaptive, adaptive/adaptive.h) on the
 * in-process ideal rig: one completes with the policy's stop reason, its
 * journal's points distinct and within the rig-time budget; a capture
 * interrupted part way and resumed measures the same points in the same
 * order, with the same readings, as one never interrupted; a resume that
 * changes the policy's options is refused and leaves the journal as it
 * was, also on the lab scene with a budget, where the policy learns the
 * rig's pace from the journal; on the lab and bad-day scenes the budget
 * holds. Their detectors give counts: each is calibrated once (dark, then
 * the reference at the pool's points, tests/gonio_test_cal.h) and every
 * capture on it reduces its counts with that; a budget or target
 * outside the adaptive order is refused before anything is written, and so
 * is an uncalibrated adaptive capture. The
 * pool is DS2 and the material the embedded default, so the test needs no
 * shared data. */
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "capture/capture.h"
#include "sim_source/sim_source.h"
#include "journal/journal.h"
#include "tests/gonio_test.h"
#include "tests/gonio_test_cal.h"

static char dir[256];

/* The calibrations of the realistic scenes, one folder each: both are of
 * rig default and detector rgb, so a capture takes the newest of its own. */
static const char *const realistic[] = {"lab", "bad-day"};

static void cal_root(const char *scene, char *root, size_t size)
{
    snprintf(root, size, "%s/cal-%s", dir, scene);
}

static int setup(void **state)
{
    (void)state;
    if (gonio_test_dir_make(dir, sizeof dir, "adaptive") < 0)
        return -1;
    for (int i = 0; i < 2; i++) {
        char root[300];
        cal_root(realistic[i], root, sizeof root);
        if (gonio_test_calibrate(root, realistic[i], NULL, "ds2", NULL, 0) < 0)
            return -1;
    }
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

#define BUDGET_MIN 0.75 /* DS2's pool on the default rig: some 15 points */

static struct capture_config config(const char *out, const char *plan, double budget_min)
{
    return (struct capture_config){.plan = plan, .model = "abc",
                                   .out_dir = out, .order = "adaptive", .stop = "all",
                                   .budget_min = budget_min, .quiet = 1,
                                   .assess_nodes = gonio_test_assess_nodes()};
}

static size_t journal_of(const char *out, struct journal_sample **s)
{
    char path[1024];
    size_t n;
    snprintf(path, sizeof path, "%s/samples.csv", out);
    assert_int_equal(journal_read(path, s, &n, NULL), 0);
    return n;
}

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

static void test_completes_within_budget(void **state)
{
    (void)state;
    char out[300];
    snprintf(out, sizeof out, "%s/whole", dir);
    struct capture_config cfg = config(out, "ds2", BUDGET_MIN);
    struct capture_summary s;
    struct gonio_err err = {0};
    assert_int_equal(sim_source_capture("ideal", &cfg, NULL, &s, &err), 0);
    assert_string_equal(s.stop_reason, "budget");
    assert_true(s.adaptive);
    assert_string_equal(s.policy.stop, "budget");
    assert_true(s.rig_time_s <= 60 * BUDGET_MIN);
    assert_true(s.samples >= 6 && s.samples < 160);
    assert_int_equal(s.decisions, s.samples);
    struct journal_sample *js;
    size_t n = journal_of(out, &js);
    assert_int_equal(n, s.samples);
    unsigned char seen[160] = {0};
    for (size_t i = 0; i < n; i++) {
        assert_true(js[i].point >= 0 && js[i].point < 160);
        assert_false(seen[js[i].point]);
        seen[js[i].point] = 1;
    }
    /* Not DS2's written order: the policy chose. */
    int in_order = 1;
    for (size_t i = 0; i < n; i++)
        in_order &= js[i].point == (int)i;
    assert_false(in_order);
    free(js);
    printf("adaptive ds2 pool, %.2f min budget: %zu samples, rig time %.1f s, decisions %.4f "
           "s mean, %.4f s max\n",
           BUDGET_MIN, s.samples, s.rig_time_s, s.decision_mean_s, s.decision_max_s);
}

/* The first call comes before anything is written, then one per point. */
struct abort_after {
    size_t calls, points;
};

static enum capture_control abort_after(void *user)
{
    struct abort_after *a = user;
    return ++a->calls > a->points + 1 ? CAPTURE_ABORT : CAPTURE_GO;
}

/* The resumed capture's journal is the uninterrupted one's: the same
 * points in the same order, the same readings, the same rig times. */
static void same_journals(const char *whole, const char *part, size_t n)
{
    struct journal_sample *a, *b;
    size_t na = journal_of(whole, &a), nb = journal_of(part, &b);
    assert_int_equal(na, n);
    assert_int_equal(nb, n);
    for (size_t i = 0; i < na; i++) {
        assert_int_equal(a[i].point, b[i].point);
        assert_memory_equal(a[i].rgb, b[i].rgb, sizeof a[i].rgb);
        assert_true(a[i].rig_time_s == b[i].rig_time_s);
    }
    free(a);
    free(b);
}

/* Stopped on convergence, which reads the policy's history of predictions
 * against rig time: the resumed run must rebuild that history and go on
 * with the rig clock where it was. */
static void test_resume_continues_the_same_sequence(void **state)
{
    (void)state;
    char whole[300], part[300];
    snprintf(whole, sizeof whole, "%s/ref", dir);
    snprintf(part, sizeof part, "%s/part", dir);
    struct capture_config cw = config(whole, "ds2", 0), cp = config(part, "ds2", 0);
    cw.stop = cp.stop = "converge";
    struct capture_summary s;
    struct gonio_err err = {0};
    assert_int_equal(sim_source_capture("ideal", &cw, NULL, &s, &err), 0);
    assert_string_equal(s.stop_reason, "converged");
    size_t n_whole = s.samples;
    assert_true(n_whole > 8 && n_whole < 160);
    printf("converged after %zu samples\n", n_whole);

    /* Late, where the history decides the stop. */
    struct abort_after ab = {0, n_whole - 2};
    struct capture_hooks hooks = {.control = abort_after, .user = &ab};
    assert_int_equal(sim_source_capture("ideal", &cp, &hooks, &s, &err), 0);
    assert_string_equal(s.stop_reason, "aborted");
    assert_int_equal(s.samples, ab.points);
    /* A resume asking for another budget would decide otherwise: refused,
     * the journal as it was. */
    struct capture_config changed = cp;
    changed.budget_min = BUDGET_MIN;
    assert_int_equal(sim_source_capture("ideal", &changed, NULL, &s, &err), -GONIO_EUSAGE);
    assert_non_null(strstr(err.msg, "setup.json has adaptive"));
    struct journal_sample *a;
    assert_int_equal(journal_of(part, &a), ab.points);
    free(a);

    assert_int_equal(sim_source_capture("ideal", &cp, NULL, &s, &err), 0);
    assert_string_equal(s.stop_reason, "converged");
    same_journals(whole, part, n_whole);
}

/* On the lab scene with a budget, where the policy costs points with what
 * the rig took for the ones before: the resumed run learns
 * it again from the journal, so it goes on with the points the
 * uninterrupted one chose, and both end within the budget. The lab
 * simulator's noise and drift do not resume where they were (sim/), so
 * the readings differ from the first point measured after the resume, and
 * with them the decisions from the second after it: the points up to
 * there are the policy's alone. */
static void test_resume_on_lab_within_budget(void **state)
{
    (void)state;
    char whole[300], part[300];
    snprintf(whole, sizeof whole, "%s/lab-ref", dir);
    snprintf(part, sizeof part, "%s/lab-part", dir);
    struct capture_config cw = config(whole, "ds2", 1), cp = config(part, "ds2", 1);
    char cal[300];
    cal_root("lab", cal, sizeof cal);
    cw.calibrations = cp.calibrations = cal;
    struct capture_summary s;
    struct gonio_err err = {0};
    assert_int_equal(sim_source_capture("lab", &cw, NULL, &s, &err), 0);
    assert_string_equal(s.stop_reason, "budget");
    size_t n_whole = s.samples;
    assert_true(n_whole > 8);
    struct abort_after ab = {0, n_whole / 2};
    struct capture_hooks hooks = {.control = abort_after, .user = &ab};
    assert_int_equal(sim_source_capture("lab", &cp, &hooks, &s, &err), 0);
    assert_string_equal(s.stop_reason, "aborted");
    assert_int_equal(sim_source_capture("lab", &cp, NULL, &s, &err), 0);
    assert_string_equal(s.stop_reason, "budget");
    assert_true(s.rig_time_s <= 60);
    struct journal_sample *a, *b;
    size_t na = journal_of(whole, &a), nb = journal_of(part, &b);
    assert_true(na >= ab.points + 2 && nb >= ab.points + 2);
    for (size_t i = 0; i < ab.points + 2; i++)
        assert_int_equal(a[i].point, b[i].point);
    free(a);
    free(b);
}

/* On the realistic scenes, calibrated (lab; bad day: slow, faulty axes
 * too), the capture's rig time stays within its budget. */
static void test_budget_held_on_lab_and_bad_day(void **state)
{
    (void)state;
    const char *const *scenes = realistic;
    const double budgets[] = {0.25, 0.5, 1};
    for (size_t i = 0; i < 2; i++)
        for (size_t k = 0; k < 3; k++) {
            char out[300];
            snprintf(out, sizeof out, "%s/%s-%g", dir, scenes[i], budgets[k]);
            struct capture_config cfg = config(out, "ds2", budgets[k]);
            char cal[300];
            cal_root(scenes[i], cal, sizeof cal);
            cfg.calibrations = cal;
            struct capture_summary s;
            struct gonio_err err = {0};
            int rc = sim_source_capture(scenes[i], &cfg, NULL, &s, &err);
            if (rc)
                fail_msg("%s: %s", scenes[i], err.msg);
            assert_string_equal(s.stop_reason, "budget");
            printf("%s, %.2f min budget: %zu samples, rig time %.2f s\n", scenes[i],
                   budgets[k], s.samples, s.rig_time_s);
            assert_true(s.samples >= 4);
            assert_true(s.rig_time_s <= 60 * budgets[k]);
        }
}

static void test_budget_needs_adaptive_order(void **state)
{
    (void)state;
    char out[300];
    snprintf(out, sizeof out, "%s/refused", dir);
    struct capture_config cfg = config(out, "ds2", BUDGET_MIN);
    cfg.order = "travel";
    struct capture_summary s;
    struct gonio_err err = {0};
    assert_int_equal(sim_source_capture("ideal", &cfg, NULL, &s, &err), -GONIO_EUSAGE);
    assert_non_null(strstr(err.msg, "--budget"));
    assert_false(exists(out));
    cfg.budget_min = 0;
    cfg.stop_target = 0.05;
    assert_int_equal(sim_source_capture("ideal", &cfg, NULL, &s, &err), -GONIO_EUSAGE);
    assert_non_null(strstr(err.msg, "--stop-target"));
    assert_false(exists(out));
    cfg.order = "adaptive";
    cfg.stop_target = -1;
    assert_int_equal(sim_source_capture("ideal", &cfg, NULL, &s, &err), -GONIO_EUSAGE);
    assert_false(exists(out));
}

/* The adaptive policy chooses its points from BRDF values: an uncalibrated
 * capture (counts, lab) is refused before anything is written, naming
 * both options, as it is on a detector of BRDF. */
static void test_uncalibrated_refused(void **state)
{
    (void)state;
    char out[300];
    snprintf(out, sizeof out, "%s/uncalibrated", dir);
    struct capture_config cfg = config(out, "ds2", BUDGET_MIN);
    cfg.uncalibrated = 1;
    static const char *const scenes[] = {"lab", "ideal"};
    for (int i = 0; i < 2; i++) {
        struct capture_summary s;
        struct gonio_err err = {0};
        int rc = sim_source_capture(scenes[i], &cfg, NULL, &s, &err);
        assert_int_equal(rc, -GONIO_EUSAGE);
        assert_int_equal(gonio_exit_status(rc), 2);
        assert_non_null(strstr(err.msg, "--uncalibrated"));
        assert_non_null(strstr(err.msg, "--order adaptive"));
        assert_false(exists(out));
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_completes_within_budget),
        cmocka_unit_test(test_resume_continues_the_same_sequence),
        cmocka_unit_test(test_resume_on_lab_within_budget),
        cmocka_unit_test(test_budget_held_on_lab_and_bad_day),
        cmocka_unit_test(test_budget_needs_adaptive_order),
        cmocka_unit_test(test_uncalibrated_refused),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
