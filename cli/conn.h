/* The gonio client's side of goniod's control socket (docs/protocol.md),
 * shared by the commands that talk to goniod (cmd_daemon.c, gonio live).
 * Messages go to stderr prefixed "gonio: ". */
#ifndef GONIO_CLI_CONN_H
#define GONIO_CLI_CONN_H
#include <stdio.h>

#include <jansson.h>

#define GONIO_SOCKET_DEFAULT "/run/goniod/goniod.sock"

struct conn {
    int fd;
    FILE *in;
    long next_id;
    const char *path;
};

/* The socket: opt when given, else $GONIO_SOCKET, else the default. */
const char *conn_socket_path(const char *opt);

/* Connect and check the greeting (protocol 1). 0, or -1 with a message. */
int conn_open(struct conn *c, const char *path);
void conn_close(struct conn *c);

/* The next document from the daemon, or NULL when the connection ends. */
json_t *conn_read(struct conn *c);

/* Send a request (stolen) and return its reply: OK, STATUS or ERROR
 * (watch documents before it are dropped); NULL when the connection is
 * lost. */
json_t *conn_request(struct conn *c, json_t *req);

/* Print a daemon error as given. 0 if d is no error; 2 if goniod refused
 * what was asked as bad input (bad-value), 1 for any other error or a
 * missing reply (d NULL). */
int conn_reply_failed(json_t *d);

#endif
