/* The gonio side of goniod's control socket (daemon_client.h): connect,
 * send a request, read its reply past the stream's documents. */
#include "cli/daemon_client.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

const char *socket_path(const char *opt)
{
    const char *env = getenv("GONIO_SOCKET");
    return opt ? opt : env && env[0] ? env : GONIO_SOCKET_DEFAULT;
}

/* The next document from the daemon, or NULL when the connection ends. */
json_t *conn_read(struct conn *c)
{
    char *line = NULL;
    size_t cap = 0;
    ssize_t n = getline(&line, &cap, c->in);
    if (n <= 0) {
        free(line);
        return NULL;
    }
    json_error_t je;
    json_t *d = json_loadb(line, (size_t)n, 0, &je);
    free(line);
    if (!json_is_object(d)) {
        json_decref(d);
        fprintf(stderr, "gonio: goniod sent something that is not a JSON object\n");
        return NULL;
    }
    return d;
}

int conn_open(struct conn *c, const char *path)
{
    memset(c, 0, sizeof *c);
    c->path = path;
    c->next_id = 1;
    struct sockaddr_un sa = {.sun_family = AF_UNIX};
    if (strlen(path) >= sizeof sa.sun_path) {
        fprintf(stderr, "gonio: %s: socket path too long\n", path);
        return -1;
    }
    memcpy(sa.sun_path, path, strlen(path) + 1);
    c->fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (c->fd < 0 || connect(c->fd, (struct sockaddr *)&sa, sizeof sa) < 0) {
        fprintf(stderr, "gonio: cannot reach goniod at %s: %s (is goniod running? --socket "
                        "or GONIO_SOCKET name another socket)\n",
                path, strerror(errno));
        if (c->fd >= 0)
            close(c->fd);
        return -1;
    }
    c->in = fdopen(dup(c->fd), "r");
    json_t *v = c->in ? conn_read(c) : NULL;
    const char *cls = json_string_value(json_object_get(v, "class"));
    json_int_t major = json_integer_value(json_object_get(v, "proto_major"));
    int ok = cls && !strcmp(cls, "VERSION") && major == 1;
    if (!ok) {
        if (cls && !strcmp(cls, "ERROR"))
            fprintf(stderr, "gonio: goniod: %s\n",
                    json_string_value(json_object_get(v, "message")));
        else
            fprintf(stderr, "gonio: %s: not a goniod speaking protocol 1\n", path);
    }
    json_decref(v);
    if (!ok) {
        if (c->in)
            fclose(c->in);
        close(c->fd);
        return -1;
    }
    return 0;
}

void conn_close(struct conn *c)
{
    fclose(c->in);
    close(c->fd);
}

long conn_send(struct conn *c, json_t *req)
{
    long id = c->next_id++;
    json_object_set_new(req, "id", json_integer(id));
    char *text = json_dumps(req, JSON_COMPACT);
    json_decref(req);
    if (!text)
        return -1;
    size_t len = strlen(text);
    int ok = send(c->fd, text, len, MSG_NOSIGNAL) == (ssize_t)len &&
             send(c->fd, "\n", 1, MSG_NOSIGNAL) == 1;
    free(text);
    if (!ok)
        fprintf(stderr, "gonio: lost goniod at %s\n", c->path);
    return ok ? id : -1;
}

int conn_is_reply(json_t *d, long id)
{
    json_t *rid = json_object_get(d, "id");
    const char *cls = json_string_value(json_object_get(d, "class"));
    /* Unsolicited errors (no id) end the exchange too. */
    return (json_is_integer(rid) && json_integer_value(rid) == id) ||
           (!rid && cls && !strcmp(cls, "ERROR"));
}

/* Send a request (stolen) and return its reply: OK, STATUS or ERROR. */
json_t *conn_request(struct conn *c, json_t *req)
{
    long id = conn_send(c, req);
    if (id < 0)
        return NULL;
    for (;;) {
        json_t *d = conn_read(c);
        if (!d) {
            fprintf(stderr, "gonio: goniod closed the connection\n");
            return NULL;
        }
        if (conn_is_reply(d, id))
            return d;
        json_decref(d); /* a watch document before the reply */
    }
}

/* Print a daemon error as given. 0 if d is no error; 2 if goniod refused
 * what was asked as bad input (bad-value: an unknown plan, a name outside
 * the capture root...), 1 for any other error or a missing reply. */
int conn_watch(struct conn *c, const char *sock)
{
    if (conn_open(c, socket_path(sock)) < 0)
        return 1;
    json_t *rep = conn_request(c, json_pack("{s:s}", "cmd", "watch"));
    int rc = reply_failed(rep);
    json_decref(rep);
    if (rc)
        conn_close(c);
    return rc;
}

int reply_failed(json_t *d)
{
    if (!d)
        return 1;
    const char *cls = json_string_value(json_object_get(d, "class"));
    if (cls && !strcmp(cls, "ERROR")) {
        const char *code = json_string_value(json_object_get(d, "code"));
        fprintf(stderr, "gonio: goniod: %s\n", json_string_value(json_object_get(d, "message")));
        /* complete: a resume that would change a finished capture */
        return code && (!strcmp(code, "bad-value") || !strcmp(code, "complete")) ? 2 : 1;
    }
    return 0;
}
