/* Ctrl-C during a bring-up move (bringup_wait.h). The signals are blocked
 * except inside pselect, so a signal never cuts a reply's read short and
 * never comes between the check and the wait. */
#include "cli/bringup_wait.h"
#include "cli/interrupt.h"

#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/select.h>
#include <sys/socket.h>

static int send_line(struct conn *c, json_t *req, long id)
{
    json_object_set_new(req, "id", json_integer(id));
    char *text = json_dumps(req, JSON_COMPACT);
    json_decref(req);
    if (!text)
        return -1;
    size_t len = strlen(text);
    int ok = send(c->fd, text, len, MSG_NOSIGNAL) == (ssize_t)len &&
             send(c->fd, "\n", 1, MSG_NOSIGNAL) == 1;
    free(text);
    return ok ? 0 : -1;
}

/* goniod's abort, over a connection of its own (the bring-up's waits for
 * its reply): what goniod answered goes to stderr. */
static void send_abort(const struct conn *c, const char *cmd, int sig)
{
    struct conn ab;
    fprintf(stderr, "gonio %s: %s: asking goniod to abort; waiting for the axes to stop "
            "(again to stop waiting)\n", cmd, sig == SIGTERM ? "SIGTERM" : "SIGINT");
    if (conn_open(&ab, c->path) < 0)
        return;
    json_t *rep = conn_request(&ab, json_pack("{s:s}", "cmd", "abort"));
    const char *cls = json_string_value(json_object_get(rep, "class"));
    if (cls && !strcmp(cls, "ERROR")) /* it ended meanwhile: its reply says how */
        fprintf(stderr, "gonio %s: abort: %s\n", cmd,
                json_string_value(json_object_get(rep, "message")));
    json_decref(rep);
    conn_close(&ab);
}

json_t *bringup_request(struct conn *c, json_t *req, const char *cmd, int *sig)
{
    sigset_t block, old;
    sigemptyset(&block);
    sigaddset(&block, SIGINT);
    sigaddset(&block, SIGTERM);
    sigprocmask(SIG_BLOCK, &block, &old);
    interrupt_catch();
    *sig = 0;
    long id = c->next_id++;
    json_t *reply = NULL;
    if (send_line(c, req, id) < 0) {
        fprintf(stderr, "gonio: lost goniod at %s\n", c->path);
        goto out;
    }
    for (;;) {
        int caught = interrupt_signal();
        if (caught && *sig) { /* asked twice: the axes are goniod's now */
            fprintf(stderr, "gonio %s: not waiting for the abort; gonio where shows where "
                    "the axes are\n", cmd);
            goto out;
        }
        if (caught) {
            *sig = caught;
            send_abort(c, cmd, caught);
            /* a second signal from now on is a new one */
            interrupt_reset();
        }
        fd_set in;
        FD_ZERO(&in);
        FD_SET(c->fd, &in);
        int n = pselect(c->fd + 1, &in, NULL, NULL, NULL, &old);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0)
            goto out;
        json_t *d = conn_read(c);
        if (!d) {
            fprintf(stderr, "gonio: goniod closed the connection\n");
            goto out;
        }
        json_t *rid = json_object_get(d, "id");
        const char *cls = json_string_value(json_object_get(d, "class"));
        if ((json_is_integer(rid) && json_integer_value(rid) == id) ||
            (!rid && cls && !strcmp(cls, "ERROR"))) {
            reply = d;
            goto out;
        }
        json_decref(d);
    }
out:
    sigprocmask(SIG_SETMASK, &old, NULL);
    return reply;
}
