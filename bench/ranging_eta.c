/* How well the capture's estimate and ETA hold with auto-ranging: a DS1
 * capture --uncalibrated on the lab scene per material, the estimate
 * before the first move, and the rig time so far plus the ETA once the
 * pre-scan is done and at a quarter and a half of the points, against the
 * rig time the capture took (docs/plans.md, "Auto-ranging"). Reported,
 * never asserted. Usage: ranging_eta OUTDIR [MATERIAL...] */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "capture/capture.h"
#include "common/err.h"
#include "sim_source/sim_source.h"

#define SEEN_MAX 100000

struct seen {
    double estimate, at_prescan, at_quarter, at_half;
    size_t n, total, prescan;
    double whole[SEEN_MAX]; /* rig time so far plus ETA, after each point */
};

static void on_progress(void *user, const struct capture_progress *p)
{
    struct seen *s = user;
    double whole = p->rig_time_s + p->eta_s;
    if (p->done == 0)
        s->estimate = p->estimate_s;
    if (p->prescan && p->done == p->prescan)
        s->at_prescan = whole;
    if (p->done == p->total / 4)
        s->at_quarter = whole;
    if (p->done == p->total / 2)
        s->at_half = whole;
    if (p->done > 0 && p->done <= SEEN_MAX && p->done >= s->n) {
        s->whole[p->done - 1] = whole;
        s->n = p->done;
        s->total = p->total;
        s->prescan = p->prescan;
    }
}

/* The largest |rig time so far + ETA - t| / t from point `from` on. */
static double worst_from(const struct seen *s, size_t from, double t)
{
    double w = 0;
    for (size_t i = from; i < s->n; i++)
        w = fmax(w, fabs(s->whole[i] / t - 1));
    return w;
}

int main(int argc, char **argv)
{
    static const char *const fallback[] = {"builtin:gray-plastic", "builtin:red-plastic",
                                           "builtin:gold-metallic-paint"};
    if (argc < 2) {
        fprintf(stderr, "usage: ranging_eta OUTDIR [MATERIAL...]\n");
        return 2;
    }
    int n = argc > 2 ? argc - 2 : 3;
    printf("%-30s %9s %9s %9s %9s %9s %9s %9s %8s %6s\n", "material", "rig_s", "estimate",
           "prescan", "quarter", "half", "worst>pre", "worst>1/4", "retakes", "darks");
    for (int m = 0; m < n; m++) {
        const char *mat = argc > 2 ? argv[m + 2] : fallback[m];
        char out[4200];
        snprintf(out, sizeof out, "%s/%d", argv[1], m);
        static struct seen s;
        memset(&s, 0, sizeof s);
        struct capture_hooks hooks = {.on_progress = on_progress, .user = &s};
        struct capture_config cfg = {.plan = "ds1", .model = "abc", .out_dir = out,
                                     .quiet = 1, .material = mat, .uncalibrated = 1};
        struct capture_summary sum;
        struct gonio_err err = {0};
        if (sim_source_capture("lab", &cfg, &hooks, &sum, &err) < 0) {
            fprintf(stderr, "%s: %s\n", mat, err.msg);
            return 1;
        }
        double t = sum.rig_time_s;
        if (getenv("RANGING_ETA_TRACE")) /* rig time so far plus ETA, every 20th point */
            for (size_t i = 0; i < s.n; i += (i < 60 ? 2 : 20))
                fprintf(stderr, "%s %zu %+.1f%%\n", mat, i + 1, 100 * (s.whole[i] / t - 1));
        printf("%-30s %9.1f %+8.1f%% %+8.1f%% %+8.1f%% %+8.1f%% %8.1f%% %8.1f%% %8zu %6zu\n",
               mat, t, 100 * (s.estimate / t - 1), 100 * (s.at_prescan / t - 1),
               100 * (s.at_quarter / t - 1), 100 * (s.at_half / t - 1),
               100 * worst_from(&s, s.prescan, t), 100 * worst_from(&s, s.total / 4, t),
               sum.retakes, sum.darks);
    }
    return 0;
}
