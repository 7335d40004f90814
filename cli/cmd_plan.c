/* gonio plan: a dry run of a plan on a rig profile. Prints the pairs in
 * execution order with axis positions and the rig-time estimate, or the
 * stable JSON of DESIGN.md section 8 with --json. Nothing reaches stdout
 * unless the whole plan loaded. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "cli/commands.h"
#include "common/duration.h"
#include "common/err.h"
#include "common/paths.h"
#include "capture/capture.h"
#include "planner/planner.h"
#include "sim/scene.h"
#include "sim_source/sim_source.h"

static void plan_usage(FILE *out)
{
    fprintf(out, "usage: gonio plan NAME|FILE.yaml [--rig NAME|FILE] [--scene NAME|FILE]\n"
                 "                  [--order travel|progressive|as-written|greedy|adaptive]\n"
                 "                  [--summary | --json]\n"
                 "Dry run: a summary (plan, rig, count, time estimate), then the pairs in\n"
                 "execution order with their axis positions.\n"
                 "  --summary  the summary only\n"
                 "  --json     the plan document (DESIGN.md section 8) with its rig\n"
                 "  --scene    the estimate counts the integration the scene's detector will\n"
                 "             choose for its material (a noisy scene auto-exposes: longer\n"
                 "             where the material is dark), as a capture's ETA; a detector\n"
                 "             of counts: the fixed integration and the bound auto-ranging\n"
                 "             can reach (a dry run needs no calibration)\n"
                 "NAME resolves to <config>/plans/NAME.yaml; the rig defaults to the scene's,\n"
                 "else <config>/rigs/default.yaml.\n");
}

static int report_failure(const struct gonio_err *err, int rc)
{
    fprintf(stderr, "gonio plan: %s\n", err->msg[0] ? err->msg : gonio_strerror(rc));
    return gonio_exit_status(rc);
}

/* How the rig is named to the operator: a file by its path (a copied
 * profile keeps the name inside it, which would hide which file was read),
 * a name by its name. */
static const char *rig_label(const char *rig_arg, const struct rig_profile *rig)
{
    return gonio_ref_is_file(rig_arg) ? rig_arg : rig->name;
}

/* The design's document plus gonio plan's own keys: the rig (its name and
 * the file read) and, inside "estimate", the lower bound on the move time
 * of any order (null when the plan is too large to bound). Capture
 * directories keep plan_json_text as is. */
static int print_json(const struct plan *plan, const char *rig_arg, const struct rig_profile *rig,
                      const struct plan_estimate *est)
{
    char rig_file[4096];
    if (gonio_config_path(rig_arg, "rigs", rig_file, sizeof rig_file) < 0)
        return -ENAMETOOLONG;
    char *text = plan_json_text(plan, est);
    json_t *root = text ? json_loads(text, 0, NULL) : NULL;
    free(text);
    json_t *estimate = root ? json_object_get(root, "estimate") : NULL;
    double lb = plan_move_lower_bound(plan, rig);
    if (!estimate || json_object_set_new(estimate, "move_lower_bound_s",
                                         isnan(lb) ? json_null() : json_real(lb)) < 0 ||
        json_object_set_new(root, "rig", json_pack("{s:s, s:s}", "name", rig->name, "file",
                                                   rig_file)) < 0 ||
        !(text = json_dumps(root, JSON_REAL_PRECISION(10)))) {
        json_decref(root);
        return -ENOMEM;
    }
    json_decref(root);
    puts(text);
    free(text);
    return 0;
}

/* What the operator needs first: which plan on which rig, how many pairs
 * and how long; the table follows (912 rows for DS1). */
static void print_summary(const struct plan *plan, const char *rig_arg,
                          const struct rig_profile *rig, const struct plan_estimate *est)
{
    printf("plan %s (%s), rig %s, order %s\n", plan_name(plan), plan_path(plan),
           rig_label(rig_arg, rig), plan_order_name(plan_current_order(plan)));
    printf("count: %zu pairs\n", plan_count(plan));
    if (plan_dropped(plan))
        printf("(%zu pairs left out: in the rig's %g deg blind zone)\n", plan_dropped(plan),
               rig->blind_deg);
    char t[4][48];
    gonio_duration_words(est->total_s, t[0], sizeof t[0]);
    gonio_duration_words(est->move_s, t[1], sizeof t[1]);
    gonio_duration_words(est->settle_s, t[2], sizeof t[2]);
    gonio_duration_words(est->integration_s, t[3], sizeof t[3]);
    printf("estimate: total %s (%.1f s): move %s (%.1f s), settle %s (%.1f s), "
           "integration %s (%.1f s)\n",
           t[0], est->total_s, t[1], est->move_s, t[2], est->settle_s, t[3],
           est->integration_s);
    /* A detector of counts ranges each point: the estimate cannot know
     * the material, so it says how far ranging could take it. */
    double up = capture_ranging_bound_s(rig, plan_count(plan));
    if (up > 0) {
        gonio_duration_words(est->total_s + up, t[0], sizeof t[0]);
        printf("with auto-ranging (a detector of counts): up to %s (%.1f s), every point at "
               "the longest integration\n",
               t[0], est->total_s + up);
    }
    double lb = plan_move_lower_bound(plan, rig);
    if (!isnan(lb))
        printf("move time lower bound (any order): %.1f s\n", lb);
}

static void print_table(const struct plan *plan)
{
    int oop = plan_is_out_of_plane(plan);
    if (oop)
        printf("%5s %8s %8s %8s %8s %8s %8s %8s\n", "#", "theta_i", "phi_i", "theta_o",
               "phi_o", "s", "a", "az");
    else
        printf("%5s %8s %8s %8s %8s\n", "#", "theta_i", "theta_r", "s", "a");
    for (size_t i = 0; i < plan_count(plan); i++) {
        const struct plan_point *pt = plan_point(plan, i);
        if (oop)
            printf("%5zu %8g %8g %8g %8g %8g %8g %8g\n", i + 1, pt->theta_i, pt->phi_i,
                   pt->theta_o, pt->phi_o, pt->ax.s, pt->ax.a, pt->ax.az);
        else
            printf("%5zu %8g %8g %8g %8g\n", i + 1, pt->theta_i, pt->theta_r, pt->ax.s,
                   pt->ax.a);
    }
}

int cmd_plan(int argc, char **argv)
{
    const char *plan_arg = NULL, *rig_arg = NULL, *scene_arg = NULL;
    int order = -1, json = 0, summary = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            plan_usage(stdout);
            return 0;
        } else if (!strcmp(argv[i], "--json")) {
            json = 1;
        } else if (!strcmp(argv[i], "--summary")) {
            summary = 1;
        } else if (!strcmp(argv[i], "--rig") || !strcmp(argv[i], "--order") ||
                   !strcmp(argv[i], "--scene")) {
            if (i + 1 >= argc) {
                fprintf(stderr, "gonio plan: %s needs a value\n", argv[i]);
                return 2;
            }
            if (!strcmp(argv[i], "--rig")) {
                rig_arg = argv[++i];
            } else if (!strcmp(argv[i], "--scene")) {
                scene_arg = argv[++i];
            } else if ((order = plan_order_parse(argv[++i])) < 0) {
                fprintf(stderr,
                        "gonio plan: --order '%s': unknown (allowed travel, progressive, "
                        "as-written, greedy, adaptive)\n",
                        argv[i]);
                return 2;
            }
        } else if (argv[i][0] == '-') {
            fprintf(stderr, "gonio plan: unknown option '%s'\n", argv[i]);
            plan_usage(stderr);
            return 2;
        } else if (plan_arg) {
            fprintf(stderr, "gonio plan: one plan at a time ('%s' and '%s')\n", plan_arg,
                    argv[i]);
            return 2;
        } else {
            plan_arg = argv[i];
        }
    }
    if (json && summary) {
        fprintf(stderr, "gonio plan: --summary and --json exclude each other\n");
        return 2;
    }
    if (!plan_arg) {
        fprintf(stderr, "gonio plan: a plan NAME or FILE is required\n");
        plan_usage(stderr);
        return 2;
    }
    struct gonio_err err = {0};
    struct sim_scene scene;
    int rc = scene_arg ? sim_scene_load(scene_arg, &scene, &err) : 0;
    if (rc < 0)
        return report_failure(&err, rc);
    if (!rig_arg)
        rig_arg = scene_arg ? scene.rig : "default";
    struct rig_profile rig;
    rc = rig_profile_load(rig_arg, &rig, &err);
    if (rc < 0)
        return report_failure(&err, rc);
    struct plan *plan;
    rc = plan_load(plan_arg, &rig, &plan, &err);
    if (rc < 0)
        return report_failure(&err, rc);
    if (order >= 0 && (rc = plan_order(plan, (enum plan_order_mode)order, &rig)) < 0) {
        plan_free(plan);
        fprintf(stderr, "gonio plan: %s\n", gonio_strerror(rc));
        return 1;
    }
    /* With a scene, the estimate a capture of it makes (capture/capture.h). */
    struct plan_estimate est;
    struct capture_config cc = {.plan = plan_arg, .rig = rig_arg, .model = "abc",
                                .order = order >= 0 ? plan_order_name(order) : NULL,
                                .estimate_only = 1}; /* a dry run measures nothing */
    if (scene_arg && (rc = sim_source_check(scene_arg, &cc, &est, &err)) < 0) {
        plan_free(plan);
        return report_failure(&err, rc);
    }
    if (!scene_arg)
        plan_estimate(plan, &rig, &est);
    rc = 0;
    if (json) {
        rc = print_json(plan, rig_arg, &rig, &est);
    } else {
        print_summary(plan, rig_arg, &rig, &est);
        if (!summary)
            print_table(plan);
    }
    plan_free(plan);
    if (rc < 0) {
        fprintf(stderr, "gonio plan: %s\n", gonio_strerror(rc));
        return 1;
    }
    return 0;
}
