/* gonio's client of goniod's control socket (docs/protocol.md), shared by
 * the commands that talk to goniod (cmd_daemon.c, where it lives, and
 * cmd_bringup.c): connect and check the greeting, send a request and
 * read its reply, print a daemon error. */
#ifndef GONIO_CLI_DAEMON_CLIENT_H
#define GONIO_CLI_DAEMON_CLIENT_H

#include <stdio.h>

#include <jansson.h>

#define GONIO_SOCKET_DEFAULT "/run/goniod/goniod.sock"

struct conn {
    int fd;
    FILE *in;
    long next_id;
    const char *path;
};

/* --socket's value, else $GONIO_SOCKET, else GONIO_SOCKET_DEFAULT. */
const char *socket_path(const char *opt);
/* Connect and read the VERSION greeting; -1 with the reason on stderr. */
int conn_open(struct conn *c, const char *path);
void conn_close(struct conn *c);
/* The next document from goniod, NULL when the connection ends. */
json_t *conn_read(struct conn *c);
/* Send req (stolen) with the connection's next id: that id, or -1 (said
 * on stderr) when the connection was lost. */
long conn_send(struct conn *c, json_t *req);
/* Whether d ends the exchange of request id: its reply, or an error
 * without an id. */
int conn_is_reply(json_t *d, long id);
/* Send req (stolen) and return its reply (OK, STATUS or ERROR), NULL when
 * the connection was lost. */
json_t *conn_request(struct conn *c, json_t *req);
/* Print a daemon error as given: 0 if d is no error, 2 for a refusal of
 * bad input (bad-value), 1 for any other error or no reply. */
int reply_failed(json_t *d);
/* Connect to goniod at sock (socket_path's rules) and subscribe to its
 * stream: 0 with c open, else the exit code (reply_failed's, 1 when it
 * could not connect) with c closed. */
int conn_watch(struct conn *c, const char *sock);

#endif
