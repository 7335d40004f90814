/* The ETA of an auto-ranged capture (docs/plans.md, "Auto-ranging"):
 * DS1 --uncalibrated on the lab scene, whose detector gives counts, on
 * the simulated rig clock, so every figure is rig time. Right after the
 * pre-scan the rig time so far plus the ETA is within 5 % of the rig time
 * the capture took, for a diffuse, two plastics and a metal; from there
 * on it stays within each one's bound: 5 % for the diffuse, 6 % for
 * red-plastic, whose one clip at the 0.8 s rung the rate models' weights
 * carry (capture/rate_map.h; 9.1 % on the plain model alone), and 10 % for
 * gray-plastic and the metal, which reach 8.5 and 9.7 % before a quarter of
 * the points (docs/plans.md, docs/notes/eta-ranging.md). */
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include <cmocka.h>

#include "capture/capture.h"
#include "common/paths.h"
#include "sim_source/sim_source.h"
#include "tests/gonio_test.h"

#define SCENE "lab"
#define AT_PRESCAN 0.05 /* right after the pre-scan */

static char dir[64];

struct seen {
    size_t prescan, n;
    double whole[1024]; /* rig time so far plus ETA after each point */
};

static void on_progress(void *user, const struct capture_progress *p)
{
    struct seen *s = user;
    s->prescan = p->prescan;
    if (p->done > 0 && p->done <= sizeof s->whole / sizeof *s->whole) {
        s->whole[p->done - 1] = p->rig_time_s + p->eta_s;
        s->n = p->done > s->n ? p->done : s->n;
    }
}

static void eta_holds(const char *material, double from_prescan, int k)
{
    char out[128];
    snprintf(out, sizeof out, "%s/%d", dir, k);
    static struct seen s;
    memset(&s, 0, sizeof s);
    struct capture_hooks hooks = {.on_progress = on_progress, .user = &s};
    struct capture_config cfg = {.plan = "ds1", .model = "abc", .out_dir = out, .quiet = 1,
                                 .material = material, .uncalibrated = 1,
                                 .assess_nodes = gonio_test_assess_nodes()};
    struct capture_summary sum;
    struct gonio_err err = {0};
    if (sim_source_capture(SCENE, &cfg, &hooks, &sum, &err) < 0) {
        print_error("%s: %s\n", material, err.msg);
        fail();
    }
    double t = sum.rig_time_s, worst = 0;
    assert_true(s.prescan > 0 && s.n == 912 && t > 0);
    for (size_t i = s.prescan - 1; i < s.n; i++)
        worst = fmax(worst, fabs(s.whole[i] / t - 1));
    double after = s.whole[s.prescan - 1] / t - 1;
    fprintf(stderr, "%s: rig time %.1f s, after the pre-scan %+.1f %%, worst from there %.1f %%\n",
            material, t, 100 * after, 100 * worst);
    assert_true(fabs(after) <= AT_PRESCAN);
    assert_true(worst <= from_prescan);
}

static void test_eta_after_the_prescan(void **state)
{
    (void)state;
    char path[4096];
    struct stat st;
    gonio_config_path(SCENE, "scenes", path, sizeof path);
    if (stat(path, &st) != 0) {
        gonio_test_skip("scene %s not in this build's configs", SCENE);
        return;
    }
    static const struct {
        const char *material;
        double from_prescan; /* the bound from the pre-scan on */
    } cases[] = {{"builtin:red-plastic", 0.06},
                 {"analytic:rough-diffuse", 0.05},
                 {"builtin:gray-plastic", 0.10},
                 {"builtin:gold-metallic-paint", 0.10}};
    int n = gonio_test_small() ? 1 : 4;
    for (int k = 0; k < n; k++)
        eta_holds(cases[k].material, cases[k].from_prescan, k);
}

static int setup(void **state)
{
    (void)state;
    return gonio_test_dir_make(dir, sizeof dir, "eta-ranging");
}

static int teardown(void **state)
{
    (void)state;
    return gonio_test_dir_remove(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_eta_after_the_prescan),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
