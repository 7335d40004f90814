#include "daemon/request.h"

#include <stdio.h>
#include <string.h>

enum arg_type { ARG_STRING, ARG_BOOL, ARG_INT, ARG_NUMBER };

struct arg_spec {
    const char *name;
    enum arg_type type;
};

static const struct arg_spec capture_args[] = {
    {"plan", ARG_STRING},  {"scene", ARG_STRING}, {"material", ARG_STRING},
    {"rig", ARG_STRING},   {"model", ARG_STRING}, {"order", ARG_STRING},
    {"stop", ARG_STRING},  {"name", ARG_STRING},  {"truth", ARG_STRING},
    {"budget", ARG_NUMBER}, {"stop_target", ARG_NUMBER}, {"prescan", ARG_INT},
    {NULL, ARG_STRING},
};
static const struct arg_spec resume_args[] = {{"capture_id", ARG_STRING}, {NULL, ARG_STRING}};
static const struct arg_spec no_args[] = {{NULL, ARG_STRING}};

/* The fields each command takes besides cmd and id, indexed by enum control_cmd. */
static const struct {
    const char *name;
    const struct arg_spec *args;
} commands[CONTROL_CMD_COUNT] = {
    [CONTROL_CMD_CAPTURE] = {"capture", capture_args},
    [CONTROL_CMD_STATUS] = {"status", no_args},
    [CONTROL_CMD_WATCH] = {"watch", no_args},
    [CONTROL_CMD_PAUSE] = {"pause", no_args},
    [CONTROL_CMD_RESUME] = {"resume", resume_args},
    [CONTROL_CMD_ABORT] = {"abort", no_args},
    [CONTROL_CMD_SHUTDOWN] = {"shutdown", no_args},
};

const char *control_cmd_name(enum control_cmd cmd)
{
    return (unsigned)cmd < CONTROL_CMD_COUNT ? commands[cmd].name : NULL;
}

static const char *type_name(enum arg_type t)
{
    return t == ARG_STRING ? "a string"
           : t == ARG_BOOL ? "true or false"
           : t == ARG_INT  ? "an integer"
                           : "a number";
}

static int type_ok(enum arg_type t, json_t *v)
{
    return t == ARG_STRING ? json_is_string(v)
           : t == ARG_BOOL ? json_is_boolean(v)
           : t == ARG_INT  ? json_is_integer(v)
                           : json_is_number(v);
}

static int fail(const char **code, const char *what, char *msg, size_t size, const char *text)
{
    *code = what;
    snprintf(msg, size, "%s", text);
    return -1;
}

int control_request_parse(const char *line, size_t len, struct control_request *req,
                          const char **code, char *msg, size_t size)
{
    memset(req, 0, sizeof *req);
    char why[512];
    json_error_t je;
    req->doc = json_loadb(line, len, JSON_REJECT_DUPLICATES, &je);
    if (!req->doc) {
        snprintf(why, sizeof why, "not JSON at column %d: %s", je.column, je.text);
        return fail(code, "bad-json", msg, size, why);
    }
    if (!json_is_object(req->doc))
        return fail(code, "bad-request", msg, size, "a request is a JSON object");
    json_t *id = json_object_get(req->doc, "id");
    if (id && !json_is_string(id) && !json_is_integer(id))
        return fail(code, "bad-type", msg, size, "field 'id' must be a string or an integer");
    req->id = id;
    json_t *jcmd = json_object_get(req->doc, "cmd");
    if (!json_is_string(jcmd))
        return fail(code, "bad-request", msg, size, "field 'cmd' (a string) is required");
    const char *name = json_string_value(jcmd);
    int found = -1;
    for (int i = 0; i < CONTROL_CMD_COUNT; i++)
        if (!strcmp(commands[i].name, name))
            found = i;
    if (found < 0) {
        snprintf(why, sizeof why, "unknown command '%.100s'", name);
        return fail(code, "unknown-command", msg, size, why);
    }
    req->cmd = (enum control_cmd)found;
    req->name = commands[found].name;
    const char *key;
    json_t *val;
    json_object_foreach(req->doc, key, val)
    {
        if (!strcmp(key, "cmd") || !strcmp(key, "id"))
            continue;
        const struct arg_spec *a = commands[found].args;
        while (a->name && strcmp(a->name, key))
            a++;
        if (!a->name) {
            snprintf(why, sizeof why, "%s: unknown field '%.100s'", req->name, key);
            return fail(code, "unknown-field", msg, size, why);
        }
        if (!type_ok(a->type, val)) {
            snprintf(why, sizeof why, "%s: field '%s' must be %s", req->name, key,
                     type_name(a->type));
            return fail(code, "bad-type", msg, size, why);
        }
    }
    return 0;
}

void control_request_free(struct control_request *req)
{
    json_decref(req->doc);
    memset(req, 0, sizeof *req);
}
