/* The bring-up commands of the control socket (docs/protocol.md): home,
 * move, where, limits. Each is checked here, run by the worker's thread
 * (daemon/bringup.h) and answered when it ends: the reply waits, the
 * socket does not. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "daemon/bringup.h"
#include "daemon/control_private.h"
#include "rig/rig.h"

static json_t *state_flag(int v)
{
    return v < 0 ? json_null() : json_boolean(v);
}

static json_t *axes_doc(const struct bringup_result *r)
{
    json_t *a = json_array();
    for (int i = 0; i < r->n; i++) {
        const struct bringup_axis *b = &r->axes[i];
        json_array_append_new(
            a, json_pack("{s:s, s:i, s:o, s:o, s:o, s:o, s:o, s:i, s:s}", "axis", b->name,
                         "slave", b->slave, "position_deg", control_json_number(b->st.position_deg),
                         "ready", state_flag(b->st.ready), "moving", state_flag(b->st.moving),
                         "in_pos", state_flag(b->st.in_pos), "home_end",
                         state_flag(b->st.home_end), "alarm", (int)b->st.alarm, "alarm_name",
                         drv_alarm_name(b->st.alarm)));
    }
    return a;
}

int control_cmd_bringup(control *c, enum bringup_op op, json_t *req, const char **code,
                        struct gonio_err *err, struct control_client *cl)
{
    struct bringup_job job = {.op = op};
    const char *axis = json_string_value(json_object_get(req, "axis"));
    json_t *deg = json_object_get(req, "deg");
    *code = "bad-value";
    if (axis && strlen(axis) >= sizeof job.axis)
        return gonio_err_set(err, GONIO_EUSAGE, "%s: axis '%.40s': use sample, arm, azimuth or "
                             "rotation", bringup_op_name(op), axis);
    snprintf(job.axis, sizeof job.axis, "%s", axis ? axis : "");
    if (op == BRINGUP_MOVE && !deg)
        return gonio_err_set(err, GONIO_EUSAGE, "move: field 'deg' is required");
    job.deg = deg ? json_number_value(deg) : NAN;
    struct rig_profile rig;
    int rc = rig_profile_load(c->cfg->rig, &rig, err);
    if (rc < 0 || (rc = bringup_check(c->cfg, &rig, &job, err)) < 0)
        return rc;
    *code = "busy";
    unsigned long ticket = c->bringup_ticket + 1;
    if ((rc = worker_bringup(c->w, &job, ticket, err)) < 0)
        return rc;
    c->bringup_ticket = ticket;
    c->bringup_client = cl;
    json_decref(c->bringup_id);
    c->bringup_id = json_incref(json_object_get(req, "id"));
    if (op == BRINGUP_MOVE)
        fprintf(stderr, "goniod: bring-up move %s to %g deg\n", job.axis, job.deg);
    else
        fprintf(stderr, "goniod: bring-up %s %s\n", bringup_op_name(op), job.axis);
    return 1; /* answered by control_bringup_reply */
}

void control_bringup_reply(control *c, const struct worker_msg_bringup *m)
{
    const struct bringup_result *r = &m->result;
    const char *op = bringup_op_name(m->job.op);
    if (r->rc < 0)
        fprintf(stderr, "goniod: bring-up %s %s failed: %s\n", op, m->job.axis, r->err.msg);
    else
        fprintf(stderr, "goniod: bring-up %s %s done\n", op, m->job.axis);
    struct control_client *cl = m->ticket == c->bringup_ticket ? c->bringup_client : NULL;
    json_t *id = c->bringup_id;
    c->bringup_client = NULL;
    c->bringup_id = NULL;
    if (cl && r->aborted) {
        /* an error that still says where the axes came to rest */
        json_t *reply = json_pack("{s:s, s:s, s:s}", "class", "ERROR", "code", "aborted",
                                  "message", r->err.msg);
        if (id)
            json_object_set(reply, "id", id);
        json_object_set_new(reply, "axes", axes_doc(r));
        control_client_send(cl, reply);
    } else if (cl && r->rc < 0) {
        control_send_error(cl, "device", id, "%s: %s", op, r->err.msg);
    } else if (cl) {
        json_t *reply = json_pack("{s:s, s:s}", "class", "OK", "cmd", op);
        if (id)
            json_object_set(reply, "id", id);
        json_object_set_new(reply, "axes", axes_doc(r));
        if (m->job.op == BRINGUP_LIMITS)
            json_object_set_new(reply, "limits",
                                json_pack("{s:s, s:o, s:o, s:o}", "axis", m->job.axis,
                                          "reached_min_deg", control_json_number(r->reached_min),
                                          "reached_max_deg", control_json_number(r->reached_max),
                                          "back_at_deg", control_json_number(r->back_at)));
        control_client_send(cl, reply);
    }
    json_decref(id);
}
