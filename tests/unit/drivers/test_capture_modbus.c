/* The capture engine on the Modbus drivers, outside goniod: capture_run
 * with an open_devices hook that builds the rig from drv_modbus.h against
 * a gonio-sim process (ideal scene) on its pty. Every sample must be the
 * material at the axis positions the journal records, and the rig clock
 * must agree with the planner's estimate.
 *
 * gonio-sim runs on its simulated clock (--clock simulated): the rig time
 * is what it models (moves, settles, integrations, the line's frames),
 * whatever the host spends, so each point's rig time is held to the rig
 * profile's model of it from the axes the journal records, within what
 * the clock's 1 ms register rounds away, under any load. The faulty line
 * runs on wall time: what it tests is the bus's retries against real
 * timeouts, and only the samples are held there. */
#include <math.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "brdf/angles.h"
#include "brdf/material.h"
#include "capture/capture.h"
#include "sim_source/sim_source.h"
#include "drivers/drv_modbus.h"
#include "planner/planner.h"
#include "rig/motion.h"
#include "tests/gonio_test.h"
#include "tests/unit/drivers/sim_proc.h"

static struct sim_proc sim;

static double drv_test_wall(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

struct rig_host {
    const char *pty;
    double time_scale, timeout_s;
    int retries;
    int baud; /* gonio-sim --baud and the bus's; 0: a line that costs nothing */
    drv_modbus_bus *bus;
    const brdf_material *truth;
    size_t n, bad;
    double worst_rel;
    double last_rig_time;
    double rig_times[8]; /* of the first samples */
    /* On the simulated clock: the rig profile, where the axes were at the
     * last sample (home before the first), and the worst difference of a
     * point's rig time from its model (move from there, settle,
     * integration), seconds. */
    const struct rig_profile *model;
    struct rig_axes at;
    double worst_model;
};

static int open_devices(void *user, const struct rig_profile *rig, const char *dir,
                        struct capture_devices *dev, struct gonio_err *err)
{
    (void)dir;
    struct rig_host *h = user;
    struct drv_modbus_bus_cfg cfg;
    drv_modbus_bus_cfg_default(&cfg);
    cfg.device = h->pty;
    cfg.time_scale = h->time_scale;
    if (h->timeout_s > 0) {
        cfg.timeout_s = h->timeout_s;
        cfg.retries = h->retries;
    }
    if (h->baud > 0)
        cfg.baud = h->baud;
    h->bus = drv_modbus_bus_new_rtu(&cfg, err);
    if (!h->bus)
        return -GONIO_EDEVICE;
    memset(dev, 0, sizeof *dev);
    /* The rig profile's mechanics, as goniod builds them (daemon/devices.c):
     * the backlash approach legs are in the estimate too. */
    struct drv_modbus_axis_opts opts = {.in_position_deg = rig->mech.in_position_deg,
                                        .backlash_deg = rig->mech.backlash_deg,
                                        .approach = rig->mech.approach,
                                        .move_retries = rig->mech.move_retries};
    dev->sample = drv_axis_new_modbus(h->bus, 1, &rig->sample, &opts, "sample", err);
    dev->arm = drv_axis_new_modbus(h->bus, 2, &rig->arm, &opts, "arm", err);
    if (rig->out_of_plane)
        dev->azimuth = drv_axis_new_modbus(h->bus, 4, &rig->azimuth, &opts, "azimuth", err);
    dev->detector = drv_detector_new_modbus(h->bus, 3, err);
    dev->clock = drv_clock_new_modbus(h->bus, 3, err);
    if (!dev->sample || !dev->arm || (rig->out_of_plane && !dev->azimuth) || !dev->detector ||
        !dev->clock)
        return -GONIO_EDEVICE;
    return 0;
}

static void close_devices(void *user, struct capture_devices *dev)
{
    struct rig_host *h = user;
    drv_axis_free(dev->sample);
    drv_axis_free(dev->arm);
    drv_axis_free(dev->azimuth);
    drv_detector_free(dev->detector);
    drv_clock_free(dev->clock);
    drv_modbus_bus_free(h->bus);
    h->bus = NULL;
}

/* Each journalled sample against an independent evaluation of the
 * material at its recorded axes (theta_i = s, theta_r = a - s). */
static void on_sample(void *user, const struct journal_sample *s, size_t done, size_t total)
{
    (void)done;
    (void)total;
    struct rig_host *h = user;
    struct brdf_pair p;
    brdf_pair_inplane(s->s, s->a - s->s, &p);
    double want[3];
    brdf_material_eval(h->truth, &p, 1, want);
    for (int k = 0; k < 3; k++) {
        double rel = fabs(s->rgb[k] - want[k]) / fabs(want[k]);
        if (!(rel <= 1e-6))
            h->bad++;
        if (rel > h->worst_rel)
            h->worst_rel = rel;
    }
    if (h->n < sizeof h->rig_times / sizeof *h->rig_times)
        h->rig_times[h->n] = s->rig_time_s;
    if (h->model) { /* in-plane plans: the azimuth rests at 0 */
        struct rig_axes to = {.s = s->s, .a = s->a, .az = 0};
        double modelled = rig_move_time_backlash(h->model, &h->at, &to) + h->model->settle_s +
                      s->integration_s;
        h->worst_model = fmax(h->worst_model, fabs(s->rig_time_s - h->last_rig_time - modelled));
        h->at = to;
    }
    h->n++;
    h->last_rig_time = s->rig_time_s;
}

static void capture_on_modbus(const char *plan_name, const char *scene, const char *scale,
                              double tolerance, struct rig_host *host_in)
{
    char baud[16];
    snprintf(baud, sizeof baud, "%d", host_in ? host_in->baud : 0);
    const char *const args[] = {strcmp(scale, "simulated") ? "--time-scale" : "--clock", scale,
                                "--scene", scene, host_in && host_in->baud > 0 ? "--baud" : NULL,
                                baud, NULL};
    assert_int_equal(sim_proc_start(&sim, args), 0);
    struct gonio_err err = {0};
    brdf_material *truth = brdf_material_open(brdf_material_default_spec(), &err);
    assert_non_null(truth);

    char dir[64];
    snprintf(dir, sizeof dir, "/tmp/gonio-capmb-XXXXXX");
    assert_non_null(mkdtemp(dir));
    char out[128];
    snprintf(out, sizeof out, "%s/cap", dir);
    struct capture_config cfg = {.plan = plan_name, .model = "abc",
                                 .out_dir = out, .quiet = 1,
                                 .assess_nodes = gonio_test_assess_nodes()};
    int simulated = !strcmp(scale, "simulated");
    struct rig_profile model;
    assert_int_equal(rig_profile_load("default", &model, &err), 0);
    struct rig_host host = {.pty = sim.pty, .truth = truth,
                            .time_scale = simulated ? 1.0 : atof(scale),
                            .model = simulated && !(host_in && host_in->baud) ? &model : NULL};
    if (host_in) {
        host.timeout_s = host_in->timeout_s;
        host.retries = host_in->retries;
        host.baud = host_in->baud;
    }
    double wall0 = drv_test_wall();
    /* The scene gonio-sim runs describes the rig in setup.json. */
    sim_source *described = sim_source_describe(scene, &err);
    assert_non_null(described);
    struct capture_rig devices;
    sim_source_rig(described, &devices);
    devices.open = open_devices;
    devices.close = close_devices;
    devices.user = &host;
    struct capture_hooks hooks = {.on_sample = on_sample, .user = &host};
    struct capture_summary sum;
    int rc = capture_run(&cfg, &devices, &hooks, &sum, &err);
    sim_source_free(described);
    if (rc < 0)
        fail_msg("capture_run: %s", err.msg);
    double wall = drv_test_wall() - wall0;

    /* The planner's estimate for the same plan on the same rig profile. */
    struct rig_profile rig;
    struct plan *plan;
    assert_int_equal(rig_profile_load("default", &rig, &err), 0);
    assert_true(plan_load(plan_name, &rig, &plan, &err) > 0);
    struct plan_estimate est;
    plan_estimate(plan, &rig, &est);

    assert_int_equal(host.n, plan_count(plan));
    assert_int_equal(sum.samples, plan_count(plan));
    assert_int_equal(host.bad, 0);
    fprintf(stderr, "# %s on Modbus RTU, clock %s: %zu samples, worst relative difference "
            "%.2e, rig time %.3f s, estimate %.3f s, worst point off its model %.4f s, wall "
            "time %.2f s (with fit)\n", plan_name, scale, host.n, host.worst_rel,
            sum.rig_time_s, est.total_s, host.worst_model, wall);
    if (host.model) {
        /* Each rig time is the clock register's reading, rounded to 1 ms:
         * a point's, a difference of two, is within 1 ms of the modelled
         * time, and a move's ends, rounded to whole steps, add under 1 ms
         * at these speeds. Host time would add whole milliseconds. */
        assert_true(host.worst_model <= 2e-3);
    }
    if (tolerance > 0) /* the plan's own order: the estimate is the model's sum */
        assert_true(fabs(sum.rig_time_s - est.total_s) <= tolerance * (double)host.n);
    else /* never faster than the estimate (targets rounded to whole steps: 0.1 %) */
        assert_true(sum.rig_time_s >= est.total_s * 0.999);
    assert_close(sum.rig_time_s, host.last_rig_time, 0);
    if (host_in)
        memcpy(host_in->rig_times, host.rig_times, sizeof host.rig_times);

    plan_free(plan);
    brdf_material_free(truth);
    char cmd[160];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    assert_int_equal(system(cmd), 0);
}

/* A failed assertion leaves the test early: the simulator must still go. */
static int stop_sim(void **state)
{
    (void)state;
    return sim.pid > 0 && sim_proc_stop(&sim) != 0 ? -1 : 0;
}

/* DS4 in its own order: the total is the planner's estimate, within the
 * clock's rounding per point (2 ms: what test_capture_ds3 allows a point). */
static void test_capture_ds4(void **state)
{
    (void)state;
    capture_on_modbus("ds4", "ideal", "simulated", 2e-3, NULL);
}

/* DS3 runs its pre-scan first, so its order is not the estimate's: each
 * point is held to its model, and the total is no less than the
 * estimate's (its order is the travel-optimal one). */
static void test_capture_ds3(void **state)
{
    (void)state;
    capture_on_modbus("ds3", "ideal", "simulated", 0, NULL);
}

/* A line that drops, garbles and delays 5 % of the exchanges each (the
 * scene's comm_faults, decided by gonio-sim per exchange): the bus's
 * retries and flushes must still deliver every sample exactly. */
static void test_capture_faulty_line(void **state)
{
    (void)state;
    /* late replies come after half the bus's timeout (both stretched under
     * valgrind, gonio_test_time_factor) */
    double k = gonio_test_time_factor();
    char yaml[256];
    snprintf(yaml, sizeof yaml,
             "name: faulty-line\nmaterial: default\nrig: default\nseed: 3\neffects:\n"
             "  - {name: comm_faults, drop: 0.05, corrupt: 0.05, late: 0.05, timeout_s: %g}\n",
             0.05 * k);
    char dir[64], path[96];
    snprintf(dir, sizeof dir, "/tmp/gonio-faulty-XXXXXX");
    assert_non_null(mkdtemp(dir));
    snprintf(path, sizeof path, "%s/faulty-line.yaml", dir);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    assert_int_equal(fputs(yaml, f) >= 0, 1);
    assert_int_equal(fclose(f), 0);
    struct rig_host opts = {.timeout_s = 0.1 * k, .retries = 5};
    capture_on_modbus("ds4", path, "20", 0, &opts);
    unlink(path);
    rmdir(dir);
}

/* The bus off the critical path, on a line slow enough that its frames
 * count, yet fast enough that the encoder reads fit in the settle (0.3 s):
 * 2400 baud, 4.6 ms a character of 11 bits (gonio-sim's), charged on the
 * simulated clock, so the host's time adds nothing.
 * DS4's points 1 to 5 move the arm alone, upwards (no backlash leg). Had
 * the encoder reads stayed between the drive's rest and the settle, each
 * of these points would hold beyond its estimate (move, settle,
 * integration) at least these frames one after the other, each with its
 * t3.5 silence (3.5 characters): the leg's write request (12 registers: 33
 * characters), the status answer that sees the rest (13), the feedback
 * read (8 and 9); then, as the integration is shorter than the trigger's
 * answer and the read's request together, the trigger's request (8, sent
 * its lag of 8 characters of 10 bits early) and answer (8), the read's
 * request (8) and answer (41), less the integration. The point must take
 * less than that, and not less than its estimate: the settle and the
 * integration run whole. And as the five points send the same frames,
 * they take the same time over their estimates, within the clock's
 * rounding (2 ms): the host's time, which differs from point to point,
 * would count. */
static void test_capture_slow_line(void **state)
{
    (void)state;
    struct rig_host h = {.baud = 2400};
    capture_on_modbus("ds4", "ideal", "simulated", 0, &h);
    struct gonio_err err = {0};
    struct rig_profile rig;
    struct plan *plan;
    assert_int_equal(rig_profile_load("default", &rig, &err), 0);
    assert_true(plan_load("ds4", &rig, &plan, &err) > 0);
    double point_s[6], over_min = INFINITY, over_max = -INFINITY;
    struct plan_estimate est;
    assert_int_equal(plan_count(plan), 6);
    plan_estimate_points(plan, &rig, NULL, NULL, point_s, &est);
    double ch = 11.0 / h.baud, gap = 3.5;
    double reads_on_path = ((33 + gap) + (13 + gap) + (8 + gap + 9 + gap) +
                            (8 + gap - 80.0 / 11) + (8 + gap) + (8 + gap) + (41 + gap)) * ch -
                           rig.integration_s;
    for (int k = 1; k < 6; k++) {
        double over = h.rig_times[k] - h.rig_times[k - 1] - point_s[k];
        fprintf(stderr, "# point %d: %.3f s over its estimate of %.3f s (reads on the path: "
                "at least %.3f s)\n", k, over, point_s[k], reads_on_path);
        assert_true(over >= 0);
        assert_true(over < reads_on_path);
        over_min = fmin(over_min, over);
        over_max = fmax(over_max, over);
    }
    assert_true(over_max - over_min <= 2e-3);
    plan_free(plan);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_capture_ds4, stop_sim),
        cmocka_unit_test_teardown(test_capture_ds3, stop_sim),
        cmocka_unit_test_teardown(test_capture_faulty_line, stop_sim),
        cmocka_unit_test_teardown(test_capture_slow_line, stop_sim),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
