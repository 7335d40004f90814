/* One control-socket request line checked against the protocol's command
 * table (docs/protocol.md): JSON, an object, a string or integer id, a
 * known cmd, only that command's fields with their types, numbers within
 * their ranges. Kept apart from
 * the socket code so that the parser of what a local client sends can be
 * tested and fuzzed on its own (fuzz/fuzz_control.c). */
#ifndef GONIO_DAEMON_REQUEST_H
#define GONIO_DAEMON_REQUEST_H

#include <stddef.h>

#include <jansson.h>

#define CONTROL_MAX_LINE 65536 /* bytes of one request, newline excluded */

/* The most bytes of a file a capture request carries (plan_text, rig_text,
 * scene_text): shipped plans, rigs and scenes are under 2 KiB, and such
 * files escaped for JSON must fit in one request line (CONTROL_MAX_LINE;
 * gonio refuses a request that does not, cli/request_file.h). */
#define CONTROL_FILE_MAX 16384

enum control_cmd {
    CONTROL_CMD_CAPTURE,
    CONTROL_CMD_STATUS,
    CONTROL_CMD_WATCH,
    CONTROL_CMD_PAUSE,
    CONTROL_CMD_RESUME,
    CONTROL_CMD_ABORT,
    CONTROL_CMD_SHUTDOWN,
    /* bring-up (daemon/bringup.h) */
    CONTROL_CMD_HOME,
    CONTROL_CMD_MOVE,
    CONTROL_CMD_WHERE,
    CONTROL_CMD_LIMITS,
    CONTROL_CMD_LIST,
    /* a calibration measured on the rig (daemon/worker.h, worker_calibrate) */
    CONTROL_CMD_CALIBRATE,
    CONTROL_CMD_COUNT
};

struct control_request {
    json_t *doc;      /* the parsed line (owned; NULL when not JSON) */
    json_t *id;       /* borrowed from doc; NULL when absent or not usable */
    enum control_cmd cmd;
    const char *name; /* the command's name (static) */
};

/* Parse and check line[len] (no newline). Returns 0 with req filled, or -1
 * with *code the error class ("bad-json", "bad-request", "bad-type",
 * "unknown-command", "unknown-field", "bad-value" for a number out of its
 * field's range) and msg the reason, naming the field and the value; req->id is then
 * the id to echo (NULL when the id itself was bad). Call
 * control_request_free in both cases. */
int control_request_parse(const char *line, size_t len, struct control_request *req,
                          const char **code, char *msg, size_t size);
void control_request_free(struct control_request *req);

/* The command's name on the wire, NULL when out of range. */
const char *control_cmd_name(enum control_cmd cmd);

#endif
