/* Captures stopped on convergence (the streaming fit in the acquisition
 * loop): a progressive DS1 capture of the embedded default material stops
 * early with stop_reason "converged", never before the plan's min_points,
 * with the first points of the plan order and nothing else journalled;
 * a resume keeps the decision; --stop all measures everything; a bad
 * --stop value writes nothing. Runs without the shared data. At the small
 * size (gonio_test_small) DS2 instead of DS1 and truth errors on a sample
 * of the full domain. */
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "capture/capture.h"
#include "sim_source/sim_source.h"
#include "journal/journal.h"
#include "planner/planner.h"
#include "tests/gonio_test.h"

static char dir[256];

static int setup(void **state)
{
    (void)state;
    return gonio_test_dir_make(dir, sizeof dir, "converge");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

static struct capture_config config(const char *out, const char *plan, const char *stop)
{
    return (struct capture_config){.plan = plan, .model = "abc",
                                   .out_dir = out, .order = "progressive", .stop = stop,
                                   .quiet = 1, .assess_nodes = gonio_test_assess_nodes()};
}

static size_t journal_count(const char *out, size_t plan_n)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/samples.csv", out);
    struct journal_sample *s;
    size_t n;
    assert_int_equal(journal_read(path, &s, &n, NULL), 0);
    /* a prefix of the execution order, each point once */
    for (size_t i = 0; i < n; i++) {
        assert_true(s[i].point >= 0 && (size_t)s[i].point < plan_n);
        assert_int_equal(s[i].point, (int)i);
    }
    free(s);
    return n;
}

static int results_say_converged(const char *out)
{
    char path[1024], text[8192];
    snprintf(path, sizeof path, "%s/results.json", out);
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    size_t len = fread(text, 1, sizeof text - 1, f);
    fclose(f);
    text[len] = 0;
    return strstr(text, "\"converged\": true") != NULL;
}

/* At the small size (valgrind) DS2 (progressive [ds3]) instead of DS1:
 * ordering DS1's 912 points and refitting along them cost memcheck
 * minutes. */
static void test_converge_stops_early(void **state)
{
    (void)state;
    const char *name = gonio_test_small() ? "ds2" : "ds1";
    struct rig_profile rig;
    rig_profile_default(&rig);
    struct plan *plan;
    assert_true(plan_load(name, &rig, &plan, NULL) > 0);
    size_t total = plan_count(plan);
    long min_points = plan_stop(plan)->min_points;
    plan_free(plan);

    char out[512];
    snprintf(out, sizeof out, "%s/%s", dir, name);
    struct capture_config cfg = config(out, name, "converge");
    struct capture_summary s;
    struct gonio_err err = {0};
    assert_int_equal(sim_source_capture("ideal", &cfg, NULL, &s, &err), 0);
    assert_string_equal(s.stop_reason, "converged");
    assert_int_equal(s.converged, 1);
    assert_true(s.samples < total);
    assert_true((long)s.samples >= min_points);
    assert_int_equal(journal_count(out, total), s.samples);
    assert_true(results_say_converged(out));
    /* the rig time is that of the measured prefix only: well short of the
     * whole plan's estimate in the same order */
    assert_true(plan_load(name, &rig, &plan, NULL) > 0);
    assert_int_equal(plan_order(plan, PLAN_ORDER_PROGRESSIVE, &rig), 0);
    struct plan_estimate est;
    plan_estimate(plan, &rig, &est);
    plan_free(plan);
    assert_true(s.rig_time_s < est.total_s);
    /* a fit close to the material: the model came from enough data */
    assert_true(s.has_truth);
    assert_true(s.err_full.log < 0.05);

    /* resuming replays the journal: same decision, nothing measured */
    struct capture_summary again;
    assert_int_equal(sim_source_capture("ideal", &cfg, NULL, &again, &err), 0);
    assert_string_equal(again.stop_reason, "converged");
    assert_int_equal(again.samples, s.samples);
    assert_int_equal(journal_count(out, total), s.samples);
    assert_memory_equal(&again.params, &s.params, sizeof s.params);
}

static void test_stop_all_measures_everything(void **state)
{
    (void)state;
    char out[512];
    snprintf(out, sizeof out, "%s/all", dir);
    struct capture_config cfg = config(out, "example-custom", "all");
    struct capture_summary s;
    struct gonio_err err = {0};
    struct rig_profile rig;
    rig_profile_default(&rig);
    struct plan *plan;
    assert_true(plan_load("example-custom", &rig, &plan, NULL) > 0);
    size_t total = plan_count(plan);
    /* the file asks for convergence; --stop all overrides it */
    assert_int_equal(plan_stop(plan)->kind, PLAN_STOP_CONVERGE);
    plan_free(plan);
    assert_int_equal(sim_source_capture("ideal", &cfg, NULL, &s, &err), 0);
    assert_string_equal(s.stop_reason, "complete");
    assert_int_equal(s.samples, total);
    assert_int_equal(journal_count(out, total), total);
}

static void test_bad_stop_writes_nothing(void **state)
{
    (void)state;
    char out[512];
    snprintf(out, sizeof out, "%s/bad", dir);
    struct capture_config cfg = config(out, "ds3", "sometimes");
    struct capture_summary s;
    struct gonio_err err = {0};
    assert_int_equal(sim_source_capture("ideal", &cfg, NULL, &s, &err), -GONIO_EUSAGE);
    assert_non_null(strstr(err.msg, "sometimes"));
    struct stat st;
    assert_int_not_equal(stat(out, &st), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_converge_stops_early),
        cmocka_unit_test(test_stop_all_measures_everything),
        cmocka_unit_test(test_bad_stop_writes_nothing),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
