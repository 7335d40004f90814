/* goniod's capture worker resolves a request once: the check before the
 * reply (worker_check) prepares the capture's job, and the run it starts
 * (worker_start) measures with that job. Counted where the resolution
 * costs most: the plan's orderings (planner/order.c), intercepted at link
 * time (-Wl,--wrap=plan_order_indices). One per capture: the check's; a
 * resume, which no check precedes, orders once in the worker thread. */
#include <poll.h>
#include <sys/stat.h>
#include <stdio.h>
#include <string.h>

#include "daemon/worker.h"
#include "planner/plan_private.h"
#include "tests/gonio_test.h"

static size_t orderings;

int __real_plan_order_indices(const struct plan_point *pts, size_t n,
                              enum plan_order_mode mode, const struct rig_profile *rig,
                              const struct rig_axes *start, size_t *order);
int __wrap_plan_order_indices(const struct plan_point *pts, size_t n,
                              enum plan_order_mode mode, const struct rig_profile *rig,
                              const struct rig_axes *start, size_t *order);
int __wrap_plan_order_indices(const struct plan_point *pts, size_t n,
                              enum plan_order_mode mode, const struct rig_profile *rig,
                              const struct rig_axes *start, size_t *order)
{
    orderings++;
    return __real_plan_order_indices(pts, n, mode, rig, start, order);
}

static char dir[64];

static int setup(void **state)
{
    (void)state;
    return gonio_test_dir_make(dir, sizeof dir, "worker-job");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

/* Wait for the capture's stop message; its rc and stop reason. */
static int wait_stop(worker *w, char *reason, size_t len)
{
    for (;;) {
        struct pollfd pfd = {.fd = worker_wake_fd(w), .events = POLLIN};
        assert_true(poll(&pfd, 1, 600 * 1000) == 1);
        struct worker_msg *m;
        while ((m = worker_take(w))) {
            if (m->kind == WORKER_MSG_STOP) {
                const struct worker_msg_stop *stop = (const struct worker_msg_stop *)m;
                int rc = stop->rc;
                snprintf(reason, len, "%s", stop->reason);
                if (rc < 0)
                    fprintf(stderr, "# capture failed: %s\n", stop->err.msg);
                free(m);
                return rc;
            }
            free(m);
        }
    }
}

static void test_check_and_run_share_the_job(void **state)
{
    (void)state;
    struct goniod_config cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.driver = GONIOD_DRIVER_SIM;
    cfg.assess_nodes = (long)gonio_test_assess_nodes();
    snprintf(cfg.capture_root, sizeof cfg.capture_root, "%s", dir);
    struct gonio_err err = {0};
    worker *w = worker_new(&cfg, &err);
    assert_non_null(w);

    struct worker_request req;
    memset(&req, 0, sizeof req);
    snprintf(req.id, sizeof req.id, "once");
    snprintf(req.dir, sizeof req.dir, "%s/once", dir);
    snprintf(req.plan, sizeof req.plan, "ds4");
    snprintf(req.scene, sizeof req.scene, "ideal");
    snprintf(req.model, sizeof req.model, "abc");
    assert_int_equal(mkdir(req.dir, 0755), 0);

    orderings = 0;
    assert_int_equal(worker_check(w, &req, &err), 0);
    assert_int_equal(orderings, 1);
    assert_int_equal(worker_start(w, &req, &err), 0);
    char reason[32];
    assert_int_equal(wait_stop(w, reason, sizeof reason), 0);
    assert_string_equal(reason, "complete");
    assert_int_equal(orderings, 1); /* the run used the check's job */

    /* A resume is not checked first: the worker thread prepares it. */
    req.resume = 1;
    assert_int_equal(worker_start(w, &req, &err), 0);
    assert_int_equal(wait_stop(w, reason, sizeof reason), 0);
    assert_int_equal(orderings, 2);

    /* A check of another request is not the job of this one. */
    struct worker_request other = req;
    snprintf(other.id, sizeof other.id, "other");
    snprintf(other.dir, sizeof other.dir, "%s/other", dir);
    assert_int_equal(worker_check(w, &other, &err), 0);
    assert_int_equal(orderings, 3);
    assert_int_equal(worker_start(w, &req, &err), 0);
    assert_int_equal(wait_stop(w, reason, sizeof reason), 0);
    assert_int_equal(orderings, 4);
    worker_free(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_check_and_run_share_the_job),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
