/* The engine on a host's devices, as goniod's Modbus rig hands them over:
 * no scene is loaded and no truth errors are written unless the request
 * names a reference (then labelled with it); the rig clock continues across
 * a resume although the host's clock restarts with every opening (as the
 * Modbus clock counts from its creation), and clock that ran while the host
 * held the capture paused is reported apart. The host builds its devices
 * over an in-process simulated rig the engine knows nothing of, kept (with
 * its axes where they are) from one opening to the next as gonio-sim is, so
 * the figures are exact. Runs without the shared data.
 *
 * The pre-scan a host's rig makes by default (capture_config.prescan):
 * its points come first, each journalled once, and the plan's order skips
 * them; a capture interrupted in it resumes to the same journal, point for
 * point, as one never interrupted; and on a detector that auto-exposes
 * (lab's noise read by the simulator's ideal meter, tests/gonio_test_cal.h),
 * the ETA right after it is within 5 % of the rig time the capture takes,
 * where the fixed estimate is not. */
#include <string.h>
#include <sys/stat.h>

#include <jansson.h>

#include "brdf/material.h"
#include "capture/capture.h"
#include "drivers/drivers_private.h"
#include "drivers/drv_sim.h"
#include "sim/scene.h"
#include "sim/sim.h"
#include "tests/gonio_test.h"
#include "tests/gonio_test_cal.h"

static char dir[256];

static int setup(void **state)
{
    (void)state;
    return gonio_test_dir_make(dir, sizeof dir, "capdev");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

/* A host whose rig is a simulated one of the embedded default material,
 * created at the first opening and kept until host_done. control: abort at
 * the abort_at-th point boundary; at the pause_at-th, let pause_s of rig
 * clock run and report the pause. */
struct host {
    brdf_material *material;
    struct rig_profile rig; /* the sim keeps a pointer: the host's own copy */
    sim_rig *sim;
    size_t calls, abort_at, pause_at;
    double pause_s;
    const struct sim_scene *scene; /* NULL: no effects */
    /* on_progress: the rig time plus the ETA once done reached eta_at,
     * and the first ETA */
    size_t eta_at;
    double first_eta_s, total_at_s;
    int progressed;
};

/* The host's rig clock: the simulated time since the devices opened. */
struct opened_clock {
    sim_rig *sim;
    double t0;
};

static double opened_now(void *priv)
{
    struct opened_clock *c = priv;
    return sim_rig_now(c->sim) - c->t0;
}

static int opened_sleep(void *priv, double seconds)
{
    struct opened_clock *c = priv;
    if (seconds > 0)
        sim_rig_advance(c->sim, seconds);
    return 0;
}

static const struct drv_clock_ops opened_clock_ops = {
    .name = "test-opened",
    .now = opened_now,
    .sleep = opened_sleep,
    .free_priv = free,
};

static int open_devices(void *user, const struct rig_profile *rig, const char *out,
                        struct capture_devices *d, struct gonio_err *err)
{
    (void)out;
    struct host *h = user;
    if (!h->sim) {
        h->rig = *rig;
        if (!(h->sim = h->scene ? sim_rig_new_scene(&h->rig, h->material, h->scene, NULL, err)
                                : sim_rig_new(&h->rig, h->material, err)))
            return -GONIO_EDEVICE;
    }
    struct opened_clock *c = malloc(sizeof *c);
    assert_non_null(c);
    *c = (struct opened_clock){h->sim, sim_rig_now(h->sim)};
    memset(d, 0, sizeof *d);
    d->sample = drv_axis_new_sim(h->sim, SIM_AXIS_SAMPLE);
    d->arm = drv_axis_new_sim(h->sim, SIM_AXIS_ARM);
    d->azimuth = drv_axis_new_sim(h->sim, SIM_AXIS_AZIMUTH);
    d->detector = drv_detector_new_sim(h->sim);
    d->clock = drv_clock_alloc(&opened_clock_ops, c);
    return 0;
}

static void close_devices(void *user, struct capture_devices *d)
{
    (void)user;
    drv_axis_free(d->sample);
    drv_axis_free(d->arm);
    drv_axis_free(d->azimuth);
    drv_detector_free(d->detector);
    drv_clock_free(d->clock);
}

/* The rig of the next capture starts afresh. */
static void host_done(struct host *h)
{
    sim_rig_free(h->sim);
    h->sim = NULL;
}

static enum capture_control control(void *user)
{
    struct host *h = user;
    h->calls++;
    if (h->abort_at && h->calls == h->abort_at)
        return CAPTURE_ABORT;
    if (h->pause_at && h->calls == h->pause_at) {
        sim_rig_advance(h->sim, h->pause_s); /* the rig's clock runs on */
        return CAPTURE_PAUSED;
    }
    return CAPTURE_GO;
}

static void on_progress(void *user, const struct capture_progress *p)
{
    struct host *h = user;
    if (!h->progressed++)
        h->first_eta_s = p->eta_s;
    if (p->done == h->eta_at && p->done > p->already_done)
        h->total_at_s = p->rig_time_s + p->eta_s;
}

static int prescan = 0; /* capture_config.prescan of run() */

static int run(const char *name, const char *truth, struct host *h, struct capture_summary *s,
               struct gonio_err *err)
{
    char out[300];
    snprintf(out, sizeof out, "%s/%s", dir, name);
    struct capture_config cfg = {.plan = "ds3", .rig = "default", .truth = truth,
                                 .model = "abc",
                                 .out_dir = out, .quiet = 1, .prescan = prescan,
                                 .assess_nodes = gonio_test_assess_nodes()};
    struct capture_rig devices = {.open = open_devices, .close = close_devices,
                                  .driver = "modbus-tcp", .detector = "modbus", .user = h};
    struct capture_hooks hooks = {.control = control, .on_progress = on_progress, .user = h};
    h->progressed = 0;
    h->calls = 0;
    return capture_run(&cfg, &devices, &hooks, s, err);
}

static json_t *load(const char *name, const char *file)
{
    char path[400];
    snprintf(path, sizeof path, "%s/%s/%s", dir, name, file);
    json_t *j = json_load_file(path, 0, NULL);
    assert_non_null(j);
    return j;
}

static struct host new_host(void)
{
    struct gonio_err err;
    struct host h = {.material = brdf_material_open("default", &err)};
    assert_non_null(h.material);
    return h;
}

static void test_no_reference_no_truth_errors(void **state)
{
    (void)state;
    struct host h = new_host();
    struct capture_summary s;
    struct gonio_err err = {0};
    assert_int_equal(run("hw", NULL, &h, &s, &err), 0);
    host_done(&h);
    assert_int_equal(s.samples, 52);
    assert_false(s.has_truth);
    assert_string_equal(s.material, "");
    json_t *r = load("hw", "results.json");
    json_t *errors = json_object_get(r, "errors");
    assert_non_null(json_object_get(errors, "plan"));
    assert_null(json_object_get(errors, "inplane"));
    assert_null(json_object_get(errors, "full"));
    assert_true(json_is_null(json_object_get(r, "truth")));
    assert_true(json_is_null(json_object_get(r, "material")));
    json_decref(r);
    /* What is known of the rig, and no scene or material nobody gave. */
    json_t *su = load("hw", "setup.json");
    assert_string_equal(json_string_value(json_object_get(su, "driver")), "modbus-tcp");
    assert_string_equal(json_string_value(json_object_get(su, "detector")), "modbus");
    assert_null(json_object_get(su, "scene"));
    assert_null(json_object_get(su, "material"));
    json_decref(su);
    brdf_material_free(h.material);
}

static void test_named_reference_labels_truth_errors(void **state)
{
    (void)state;
    struct host h = new_host();
    struct capture_summary s;
    struct gonio_err err = {0};
    assert_int_equal(run("hw-truth", "default", &h, &s, &err), 0);
    host_done(&h);
    assert_true(s.has_truth);
    /* the host's rig measures the default material: a small error against it */
    assert_true(s.err_full.log > 0 && s.err_full.log < 0.1);
    json_t *r = load("hw-truth", "results.json");
    assert_string_equal(json_string_value(json_object_get(r, "truth")),
                        brdf_material_default_spec());
    assert_non_null(json_object_get(json_object_get(r, "errors"), "full"));
    json_decref(r);
    brdf_material_free(h.material);
}

/* The largest rig time between two consecutive samples: one point's time. */
static double max_point_time(const char *name)
{
    char path[400];
    snprintf(path, sizeof path, "%s/%s/samples.csv", dir, name);
    struct journal_sample *js;
    size_t n;
    assert_int_equal(journal_read(path, &js, &n, NULL), 0);
    double worst = n ? js[0].rig_time_s : 0;
    for (size_t i = 1; i < n; i++)
        if (js[i].rig_time_s - js[i - 1].rig_time_s > worst)
            worst = js[i].rig_time_s - js[i - 1].rig_time_s;
    free(js);
    return worst;
}

static void test_rig_clock_continues_and_pause_is_apart(void **state)
{
    (void)state;
    struct host h = new_host();
    struct capture_summary whole, part, paused;
    struct gonio_err err = {0};
    assert_int_equal(run("whole", NULL, &h, &whole, &err), 0);
    host_done(&h);
    assert_true(whole.rig_time_s > 0);
    assert_true(whole.paused_s == 0);

    /* Interrupted after 20 points, resumed on a clock that starts at 0. */
    h.abort_at = 21;
    assert_int_equal(run("part", NULL, &h, &part, &err), 0);
    assert_string_equal(part.stop_reason, "aborted");
    h.abort_at = 0;
    assert_int_equal(run("part", NULL, &h, &part, &err), 0);
    assert_int_equal(part.samples, 52);
    host_done(&h);
    double one_point = max_point_time("whole");
    fprintf(stderr, "# rig time uninterrupted %.3f s, interrupted and resumed %.3f s "
            "(one point: at most %.3f s)\n", whole.rig_time_s, part.rig_time_s, one_point);
    assert_true(fabs(part.rig_time_s - whole.rig_time_s) <= one_point);

    /* 100 s of rig clock while paused: reported apart, not rig time. */
    h.pause_at = 10;
    h.pause_s = 100;
    assert_int_equal(run("paused", NULL, &h, &paused, &err), 0);
    host_done(&h);
    assert_close(paused.paused_s, 100, 1e-9);
    assert_close(paused.rig_time_s, whole.rig_time_s, 1e-9);
    json_t *r = load("paused", "results.json");
    assert_close(json_real_value(json_object_get(r, "paused_s")), 100, 1e-9);
    json_decref(r);
    brdf_material_free(h.material);
}

/* The journal's points in record order (DS3: 52 at most). */
static size_t journal_order(const char *name, int *points)
{
    char path[400];
    snprintf(path, sizeof path, "%s/%s/samples.csv", dir, name);
    struct journal_sample *js;
    size_t n;
    assert_int_equal(journal_read(path, &js, &n, NULL), 0);
    assert_true(n <= 52);
    for (size_t i = 0; i < n; i++)
        points[i] = js[i].point;
    free(js);
    return n;
}

/* A whole DS3 capture (52 points) with a pre-scan of k: one point in each
 * of k equal stretches of the plan's order first, every point once, then
 * plan order without the pre-scanned ones. */
static void check_prescan(const char *name, int k)
{
    int pts[52];
    assert_int_equal(journal_order(name, pts), 52);
    for (int j = 0; j < k; j++) {
        assert_true(pts[j] >= j * 52 / k);
        assert_true(pts[j] < (j + 1) * 52 / k);
    }
    int seen[52] = {0}, prev = -1;
    for (int i = 0; i < 52; i++)
        assert_int_equal(seen[pts[i]]++, 0); /* each point once */
    for (int i = k; i < 52; i++) { /* then plan order, without the pre-scanned */
        assert_true(pts[i] > prev);
        prev = pts[i];
        for (int j = 0; j < k; j++)
            assert_int_not_equal(pts[i], pts[j]);
    }
}

static void test_prescan_first_once_then_plan_order(void **state)
{
    (void)state;
    struct host h = new_host();
    struct capture_summary s;
    struct gonio_err err = {0};
    /* the default on a host's rig: DS3 has 52 points, one in 25 is 2 */
    assert_int_equal(run("pre", NULL, &h, &s, &err), 0);
    host_done(&h);
    assert_int_equal(s.samples, 52);
    check_prescan("pre", 2);
    prescan = 6;
    assert_int_equal(run("pre6", NULL, &h, &s, &err), 0);
    host_done(&h);
    check_prescan("pre6", 6);
    int pts[52];
    /* --prescan 0: none, plan order from the first point */
    prescan = CAPTURE_PRESCAN_OFF;
    assert_int_equal(run("nopre", NULL, &h, &s, &err), 0);
    host_done(&h);
    prescan = 0;
    assert_int_equal(journal_order("nopre", pts), 52);
    for (int k = 0; k < 52; k++)
        assert_int_equal(pts[k], k);
    brdf_material_free(h.material);
}

/* Interrupted during a pre-scan of 6 (after 2 points) and right after it,
 * then resumed: the journal of the capture never interrupted. */
static void test_prescan_resume(void **state)
{
    (void)state;
    struct host h = new_host();
    struct capture_summary s;
    struct gonio_err err = {0};
    int whole[52], pts[52];
    prescan = 6;
    assert_int_equal(run("pre-whole", NULL, &h, &s, &err), 0);
    host_done(&h);
    assert_int_equal(journal_order("pre-whole", whole), 52);
    const size_t abort_at[2] = {4, 8}; /* control calls: the start, then one per point */
    const size_t kept[2] = {2, 6};
    for (int c = 0; c < 2; c++) {
        char name[32];
        snprintf(name, sizeof name, "pre-cut%d", c);
        h.abort_at = abort_at[c];
        assert_int_equal(run(name, NULL, &h, &s, &err), 0);
        assert_string_equal(s.stop_reason, "aborted");
        assert_int_equal(journal_order(name, pts), kept[c]);
        h.abort_at = 0;
        assert_int_equal(run(name, NULL, &h, &s, &err), 0);
        host_done(&h);
        assert_int_equal(s.samples, 52);
        assert_int_equal(journal_order(name, pts), 52);
        assert_memory_equal(pts, whole, sizeof whole);
    }
    prescan = 0;
    brdf_material_free(h.material);
}

/* A metering detector integrates longer than the rig profile's fixed
 * integration where the material is dark: the first ETA (the fixed
 * estimate) is short by more than 10 %, the one after the pre-scan within
 * 5 % of the rig time the capture takes. Deterministic: the host's rig is
 * the in-process simulator, its clock simulated. */
static void test_prescan_eta_metered(void **state)
{
    (void)state;
    struct gonio_err err = {0};
    char path[300];
    gonio_test_metered_scene(dir, path, sizeof path);
    struct sim_scene lab;
    assert_int_equal(sim_scene_load(path, &lab, &err), 0);
    struct host h = new_host();
    h.scene = &lab;
    h.eta_at = 2; /* the default pre-scan of DS3 */
    struct capture_summary s;
    assert_int_equal(run("pre-lab", NULL, &h, &s, &err), 0);
    host_done(&h);
    double first = h.first_eta_s, after = h.total_at_s, actual = s.rig_time_s;
    fprintf(stderr, "# metered, DS3 on a host's rig: fixed estimate %.1f s, after the pre-scan "
            "%.1f s, actual %.1f s (%+.1f %%, %+.1f %%)\n", first, after, actual,
            100 * (first - actual) / actual, 100 * (after - actual) / actual);
    assert_true(first < 0.9 * actual);
    assert_true(fabs(after - actual) <= 0.05 * actual);
    brdf_material_free(h.material);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_no_reference_no_truth_errors),
        cmocka_unit_test(test_named_reference_labels_truth_errors),
        cmocka_unit_test(test_rig_clock_continues_and_pause_is_apart),
        cmocka_unit_test(test_prescan_first_once_then_plan_order),
        cmocka_unit_test(test_prescan_resume),
        cmocka_unit_test(test_prescan_eta_metered),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
