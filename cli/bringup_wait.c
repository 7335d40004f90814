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
    json_t *reply = NULL;
    long id = conn_send(c, req);
    if (id < 0)
        goto out;
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
        if (conn_is_reply(d, id)) {
            reply = d;
            goto out;
        }
        json_decref(d);
    }
out:
    sigprocmask(SIG_SETMASK, &old, NULL);
    return reply;
}
