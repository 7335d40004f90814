#include "daemon/request.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "capture/capture.h"

enum arg_type { ARG_STRING, ARG_BOOL, ARG_INT, ARG_NUMBER };

/* A field a command takes. Numbers and integers have a range, checked
 * here so that a request out of it is refused before anything is looked
 * up or created: min..max, and 0 too when zero_none (0 then means none);
 * unit says what the number is, in the message. */
struct arg_spec {
    const char *name;
    enum arg_type type;
    double min, max;
    int zero_none;
    const char *unit;
};

#define STRING_ARG(n) {.name = (n), .type = ARG_STRING}
static const struct arg_spec capture_args[] = {
    STRING_ARG("plan"), STRING_ARG("scene"), STRING_ARG("material"),
    STRING_ARG("rig"),  STRING_ARG("model"), STRING_ARG("order"),
    STRING_ARG("stop"), STRING_ARG("name"),  STRING_ARG("truth"),
    STRING_ARG("sample"), STRING_ARG("operator"), STRING_ARG("note"),
    STRING_ARG("check"),
    /* From a few points' rig time to a week. */
    {.name = "budget", .type = ARG_NUMBER, .min = 0.1, .max = 10080, .zero_none = 1,
     .unit = "minutes of rig time"},
    /* The full-domain log errors of real fits lie around 0.01..0.1. */
    {.name = "stop_target", .type = ARG_NUMBER, .min = 1e-6, .max = 10, .zero_none = 1,
     .unit = "a full-domain log error"},
    {.name = "prescan", .type = ARG_INT, .min = 0, .max = CAPTURE_PRESCAN_MAX, .unit = "points"},
    {.name = "uncalibrated", .type = ARG_BOOL},
    {.name = "reference_after", .type = ARG_BOOL},
    /* The files the request carries (daemon/control_files.c): max is their
     * length in bytes. */
    {.name = "plan_text", .type = ARG_STRING, .max = CONTROL_FILE_MAX, .unit = "bytes"},
    {.name = "rig_text", .type = ARG_STRING, .max = CONTROL_FILE_MAX, .unit = "bytes"},
    {.name = "scene_text", .type = ARG_STRING, .max = CONTROL_FILE_MAX, .unit = "bytes"},
    STRING_ARG("calibration"),
    {.name = NULL},
};
/* gonio calibrate through goniod (docs/protocol.md, "calibrate") */
static const struct arg_spec calibrate_args[] = {
    STRING_ARG("kind"), STRING_ARG("name"), STRING_ARG("plan"), STRING_ARG("rig"),
    STRING_ARG("standard"), STRING_ARG("dark"), STRING_ARG("spot"), STRING_ARG("stray"),
    {.name = "frames", .type = ARG_INT, .min = 2, .max = 10000, .unit = "frames"},
    {.name = "repeats", .type = ARG_INT, .min = 2, .max = 1000, .unit = "readings a point"},
    {.name = "integration", .type = ARG_NUMBER, .min = 1e-6, .max = 60, .unit = "seconds"},
    {.name = "ladder", .type = ARG_BOOL},
    {.name = "valid", .type = ARG_NUMBER, .min = 0.01, .max = 525600, .unit = "minutes"},
    {.name = NULL},
};
static const struct arg_spec resume_args[] = {
    STRING_ARG("capture_id"), {.name = "refit", .type = ARG_BOOL}, {.name = NULL}};
static const struct arg_spec no_args[] = {{.name = NULL}};
/* bring-up: an axis (home: optional), a move's target in degrees */
static const struct arg_spec axis_args[] = {STRING_ARG("axis"), {.name = NULL}};
static const struct arg_spec move_args[] = {
    STRING_ARG("axis"),
    {.name = "deg", .type = ARG_NUMBER, .min = -360, .max = 360, .unit = "degrees"},
    {.name = NULL}};
static const struct arg_spec watch_args[] = {STRING_ARG("format"), {.name = NULL}};

/* The fields each command takes besides cmd and id, indexed by enum control_cmd. */
static const struct {
    const char *name;
    const struct arg_spec *args;
} commands[CONTROL_CMD_COUNT] = {
    [CONTROL_CMD_CAPTURE] = {"capture", capture_args},
    [CONTROL_CMD_STATUS] = {"status", no_args},
    [CONTROL_CMD_WATCH] = {"watch", watch_args},
    [CONTROL_CMD_PAUSE] = {"pause", no_args},
    [CONTROL_CMD_RESUME] = {"resume", resume_args},
    [CONTROL_CMD_ABORT] = {"abort", no_args},
    [CONTROL_CMD_SHUTDOWN] = {"shutdown", no_args},
    [CONTROL_CMD_HOME] = {"home", axis_args},
    [CONTROL_CMD_MOVE] = {"move", move_args},
    [CONTROL_CMD_WHERE] = {"where", no_args},
    [CONTROL_CMD_LIMITS] = {"limits", axis_args},
    [CONTROL_CMD_LIST] = {"list", no_args},
    [CONTROL_CMD_CALIBRATE] = {"calibrate", calibrate_args},
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

static int in_range(const struct arg_spec *a, json_t *v)
{
    if (a->type == ARG_STRING) /* a string's max: its length in bytes, 0 none */
        return a->max == 0 || (double)json_string_length(v) <= a->max;
    if (a->type == ARG_INT) {
        json_int_t i = json_integer_value(v);
        return (a->zero_none && i == 0) || ((double)i >= a->min && (double)i <= a->max);
    }
    if (a->type == ARG_NUMBER) {
        double x = json_number_value(v);
        return (a->zero_none && x == 0) || (x >= a->min && x <= a->max);
    }
    return 1;
}

/* "capture: field 'budget' 1e+308 is out of range: 0 (none) or 0.1..10080
 * minutes of rig time". */
static void range_message(const char *cmd, const struct arg_spec *a, json_t *v, char *out,
                          size_t size)
{
    char value[64];
    if (json_is_string(v)) {
        snprintf(out, size, "%s: field '%s' of %zu bytes is too long: at most %g %s", cmd,
                 a->name, json_string_length(v), a->max, a->unit);
        return;
    }
    if (json_is_integer(v))
        snprintf(value, sizeof value, "%lld", (long long)json_integer_value(v));
    else if (snprintf(value, sizeof value, "%.15g", json_number_value(v)) > 0 &&
             strtod(value, NULL) != json_number_value(v))
        snprintf(value, sizeof value, "%.17g", json_number_value(v)); /* 15 digits hid it */
    snprintf(out, size, "%s: field '%s' %s is out of range: %s%g..%g %s", cmd, a->name, value,
             a->zero_none ? "0 (none) or " : "", a->min, a->max, a->unit);
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
        if (!in_range(a, val)) {
            range_message(req->name, a, val, why, sizeof why);
            return fail(code, "bad-value", msg, size, why);
        }
    }
    return 0;
}

void control_request_free(struct control_request *req)
{
    json_decref(req->doc);
    memset(req, 0, sizeof *req);
}
