/* The rig-time estimate of a capture before its first move (capture_check,
 * the figure of gonio plan --scene and the first ETA) against the rig time
 * the offline capture then reports: within 5 % on the ideal and lab scenes,
 * where the rig's fixed integration (plan_estimate) misses the lab scene's
 * auto-exposure by 11-32 %. And the progress hook: the first ETA is the
 * estimate, the ETA ends at 0, the rig time only grows. Runs without the
 * shared data (the scenes measure the embedded default material). */
#include <math.h>
#include <string.h>

#include "daemon/capture.h"
#include "planner/planner.h"
#include "tests/gonio_test.h"

static char dir[256];

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/gonio-estimate-XXXXXX");
    return mkdtemp(dir) ? 0 : -1;
}

static int teardown(void **state)
{
    (void)state;
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    return system(cmd);
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
    snprintf(out, sizeof out, "%s/%s-%s", dir, plan, scene);
    struct capture_config cfg = {.plan = plan, .scene = scene, .model = "abc", .out_dir = out,
                                 .quiet = 1, .measure_only = 1};
    struct gonio_err err = {0};
    struct plan_estimate est;
    assert_int_equal(capture_check(&cfg, NULL, &est, &err), 0);
    *est_s = est.total_s;

    struct plan_rig rig;
    struct plan *p;
    assert_int_equal(plan_rig_load("default", &rig, &err), 0);
    assert_true(plan_load(plan, &rig, &p, &err) > 0);
    plan_estimate(p, &rig, &est);
    *fixed_s = est.total_s;
    plan_free(p);

    struct capture_hooks hooks = {.on_progress = on_progress, .user = seen};
    struct capture_summary s;
    assert_int_equal(capture_run(&cfg, &hooks, &s, &err), 0);
    *actual_s = s.rig_time_s;
}

static void test_estimate_within_5_percent(void **state)
{
    (void)state;
    static const char *const plans[] = {"ds3", "ds4"};
    static const char *const scenes[] = {"ideal", "lab"};
    for (size_t i = 0; i < 2; i++)
        for (size_t k = 0; k < 2; k++) {
            double est, fixed, actual;
            struct seen seen = {0};
            estimate_and_capture(plans[i], scenes[k], &est, &fixed, &actual, &seen);
            print_message("%s on %s: estimate %.1f s (fixed integration %.1f s), actual %.1f s\n",
                          plans[i], scenes[k], est, fixed, actual);
            assert_true(fabs(est - actual) <= 0.05 * actual);
            /* The lab scene auto-exposes: the fixed integration misses it. */
            if (!strcmp(scenes[k], "lab"))
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
        cmocka_unit_test(test_estimate_within_5_percent),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
