/* gonio calibrate through goniod: the calibrate request sent (docs/
 * protocol.md, "calibrate"), then its stream followed to the stop, what
 * goniod asks of the operator on stderr as it asks it. */
#include <stdio.h>
#include <string.h>

#include <jansson.h>

#include "cli/commands.h"
#include "cli/daemon_client.h"

/* Follow the stream to calibration id's stop: 0 when it completed. */
static int follow(struct conn *c, const char *id)
{
    for (;;) {
        json_t *d = conn_read(c);
        if (!d) {
            fprintf(stderr, "gonio calibrate: goniod closed the connection; what was "
                            "measured is kept: gonio resume %s\n", id);
            return 1;
        }
        const char *cls = json_string_value(json_object_get(d, "class"));
        const char *cid = json_string_value(json_object_get(d, "capture_id"));
        int mine = cid && !strcmp(cid, id);
        const char *msg = json_string_value(json_object_get(d, "message"));
        if (cls && !strcmp(cls, "state") && mine) {
            const char *state = json_string_value(json_object_get(d, "state"));
            fprintf(stderr, "calibration %s %s%s%s\n", id, state ? state : "?",
                    msg ? ": " : "", msg ? msg : "");
        } else if (cls && !strcmp(cls, "stop") && mine) {
            const char *status = json_string_value(json_object_get(d, "exit_status"));
            const char *reason = json_string_value(json_object_get(d, "reason"));
            json_t *cal = json_object_get(d, "calibration");
            int ok = status && !strcmp(status, "success");
            if (ok) {
                printf("%s\n", id);
                fprintf(stderr, "calibration %s: %lld frames in %s\n", id,
                        (long long)json_integer_value(json_object_get(cal, "frames")),
                        json_string_value(json_object_get(d, "dir")));
            } else {
                fprintf(stderr, "calibration %s stopped: %s%s%s%s\n", id,
                        reason ? reason : "?", msg ? " (" : "", msg ? msg : "", msg ? ")" : "");
                if (reason && !strcmp(reason, "aborted"))
                    fprintf(stderr, "  what was measured is kept: gonio resume %s\n", id);
            }
            json_decref(d);
            return ok ? 0 : 1;
        } else if (cls && !strcmp(cls, "ERROR")) {
            int rc = reply_failed(d);
            json_decref(d);
            return rc;
        }
        json_decref(d);
    }
}

int cmd_calibrate_goniod(json_t *req, const char *sock)
{
    struct conn c;
    int rc = conn_watch(&c, sock); /* subscribed first: not even a short run's stop is missed */
    if (rc) {
        json_decref(req);
        return rc;
    }
    json_t *rep = conn_request(&c, req);
    rc = reply_failed(rep);
    if (!rc) {
        const char *id = json_string_value(json_object_get(rep, "capture_id"));
        fprintf(stderr, "calibration %s started on goniod\n", id ? id : "?");
        rc = id ? follow(&c, id) : 1;
    }
    json_decref(rep);
    conn_close(&c);
    return rc;
}
