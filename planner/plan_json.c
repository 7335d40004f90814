/* The stable JSON form of a plan (DESIGN.md section 8), shared by
 * `gonio plan --json` and the resolved plan of a capture directory. */
#include <stdlib.h>

#include <jansson.h>

#include "planner/planner.h"

static json_t *point_json(const struct plan_point *pt, int oop, int turns)
{
    if (turns) /* in-plane, the sample turned about its normal */
        return json_pack("{s:f,s:f,s:f,s:f,s:f}", "theta_i", pt->theta_i, "theta_r",
                         pt->theta_r, "s", pt->ax.s, "a", pt->ax.a, "rotation", pt->rotation);
    if (oop)
        return json_pack("{s:f,s:f,s:f,s:f,s:f,s:f,s:f}", "theta_i", pt->theta_i, "phi_i",
                         pt->phi_i, "theta_o", pt->theta_o, "phi_o", pt->phi_o, "s", pt->ax.s,
                         "a", pt->ax.a, "az", pt->ax.az);
    return json_pack("{s:f,s:f,s:f,s:f}", "theta_i", pt->theta_i, "theta_r", pt->theta_r, "s",
                     pt->ax.s, "a", pt->ax.a);
}

char *plan_json_text(const struct plan *plan, const struct plan_estimate *est)
{
    json_t *pairs = json_array();
    if (!pairs)
        return NULL;
    int oop = plan_is_out_of_plane(plan);
    for (size_t i = 0; i < plan_count(plan); i++) {
        if (json_array_append_new(pairs, point_json(plan_point(plan, i), oop, plan_sample_azimuths(plan) > 0)) < 0) {
            json_decref(pairs);
            return NULL;
        }
    }
    /* "o" steals the reference to pairs, also when json_pack fails. */
    json_t *root = json_pack("{s:s,s:I,s:s,s:o,s:{s:f,s:f,s:f,s:f}}", "plan", plan_name(plan),
                             "count", (json_int_t)plan_count(plan), "order",
                             plan_order_name(plan_current_order(plan)), "pairs", pairs,
                             "estimate", "total_s", est->total_s, "move_s", est->move_s,
                             "settle_s", est->settle_s, "integration_s", est->integration_s);
    if (!root)
        return NULL;
    /* An order from where a capture found the axes says so: a resume orders
     * the plan from there again, and the file reads true. */
    struct rig_axes at;
    plan_order_start(plan, &at);
    if ((at.s != 0 || at.a != 0 || at.az != 0) &&
        json_object_set_new(root, "start", json_pack("{s:f,s:f,s:f}", "s", at.s, "a", at.a,
                                                     "az", at.az)) < 0) {
        json_decref(root);
        return NULL;
    }
    char *text = json_dumps(root, JSON_REAL_PRECISION(10));
    json_decref(root);
    return text;
}
