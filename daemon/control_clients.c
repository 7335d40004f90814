/* The control socket's connections: non-blocking, with bounded input and
 * output, a request rate limit and an idle timeout each, so that no client
 * can stall the loop or hold resources it does not use. */
#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "daemon/control_private.h"
#include "daemon/peer.h"

#ifndef GONIO_RELEASE
#define GONIO_RELEASE "0.0.0"
#endif

/* ---- output ---------------------------------------------------------- */

static void client_drop(struct control_client *cl, const char *why)
{
    if (!cl->dead && why)
        fprintf(stderr, "goniod: client %d dropped: %s\n", cl->fd, why);
    cl->dead = 1;
}

void control_client_try_write(struct control_client *cl)
{
    while (!cl->dead && cl->out_len > 0) {
        ssize_t n = send(cl->fd, cl->out, cl->out_len, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (n < 0) {
            if (errno == EINTR)
                continue;
            if (errno != EAGAIN && errno != EWOULDBLOCK)
                client_drop(cl, NULL); /* gone: a disconnect is not news */
            return;
        }
        memmove(cl->out, cl->out + n, cl->out_len - (size_t)n);
        cl->out_len -= (size_t)n;
    }
    if (!cl->dead && cl->closing && cl->out_len == 0)
        cl->dead = 1;
}

void control_client_send_text(struct control_client *cl, const char *text)
{
    if (cl->dead)
        return;
    size_t len = strlen(text);
    if (cl->out_len + len + 1 > cl->max_out) {
        client_drop(cl, "too slow to read its output");
        return;
    }
    if (cl->out_len + len + 1 > cl->out_cap) {
        size_t cap = cl->out_cap ? cl->out_cap : 4096;
        while (cap < cl->out_len + len + 1)
            cap *= 2;
        char *p = realloc(cl->out, cap);
        if (!p) {
            client_drop(cl, "out of memory");
            return;
        }
        cl->out = p;
        cl->out_cap = cap;
    }
    memcpy(cl->out + cl->out_len, text, len);
    cl->out[cl->out_len + len] = '\n';
    cl->out_len += len + 1;
    control_client_try_write(cl);
}

char *control_json_text(json_t *doc)
{
    char *s = json_dumps(doc, JSON_COMPACT | JSON_PRESERVE_ORDER);
    json_decref(doc);
    return s;
}

void control_client_send(struct control_client *cl, json_t *doc)
{
    char *s = control_json_text(doc);
    if (s)
        control_client_send_text(cl, s);
    else
        client_drop(cl, "out of memory");
    free(s);
}

static json_t *error_doc(const char *code, const char *msg, json_t *id)
{
    json_t *e = json_object();
    json_object_set_new(e, "class", json_string("ERROR"));
    if (id)
        json_object_set(e, "id", id);
    json_object_set_new(e, "code", json_string(code));
    /* Messages come from files and requests: make sure they are UTF-8. */
    json_t *m = json_string(msg);
    json_object_set_new(e, "message", m ? m : json_string("(message not valid UTF-8)"));
    return e;
}

void control_send_error(struct control_client *cl, const char *code, json_t *id,
                        const char *fmt, ...)
{
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    control_client_send(cl, error_doc(code, msg, id));
}

void control_broadcast_to(control *c, int format, const char *text)
{
    for (size_t i = 0; i < c->n_clients; i++)
        if (c->clients[i]->watching & format)
            control_client_send_text(c->clients[i], text);
}

void control_broadcast(control *c, const char *text)
{
    control_broadcast_to(c, CONTROL_WATCH_STREAM, text);
}

/* ---- input ----------------------------------------------------------- */

/* Token bucket: rate_per_s requests a second on average, bursts of up to
 * burst. A request beyond it is answered with an error and not run, so a
 * flooding client costs a parse and a short reply per line, and if it does
 * not read those either its output limit drops it. */
static int client_take_token(control *c, struct control_client *cl)
{
    double t = gonio_monotonic_s();
    cl->tokens += (t - cl->tokens_at) * c->cfg->rate_per_s;
    if (cl->tokens > c->cfg->burst)
        cl->tokens = c->cfg->burst;
    cl->tokens_at = t;
    if (cl->tokens < 1)
        return 0;
    cl->tokens -= 1;
    return 1;
}

static void refuse_rate(control *c, struct control_client *cl, const char *line, size_t len)
{
    /* Echo the id when there is one, so the client knows which request. */
    json_t *req = json_loadb(line, len, JSON_REJECT_DUPLICATES, NULL);
    json_t *id = json_object_get(req, "id");
    control_send_error(cl, "rate-limited", json_is_string(id) || json_is_integer(id) ? id : NULL,
                       "more than %g requests a second (bursts of %ld); request not run",
                       c->cfg->rate_per_s, c->cfg->burst);
    json_decref(req);
}

/* One recv per poll round: a client that writes without pause cannot keep
 * the loop away from the others or from the worker's messages. */
void control_client_read(control *c, struct control_client *cl)
{
    ssize_t n = recv(cl->fd, cl->in + cl->in_len, CONTROL_MAX_LINE + 1 - cl->in_len,
                     MSG_DONTWAIT);
    if (n == 0) {
        cl->dead = 1; /* the client closed its end */
        return;
    }
    if (n < 0) {
        if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)
            cl->dead = 1;
        return; /* EINTR, EAGAIN: poll says when to come back */
    }
    cl->in_len += (size_t)n;
    char *nl;
    size_t start = 0;
    while (!cl->dead && !cl->closing &&
           (nl = memchr(cl->in + start, '\n', cl->in_len - start))) {
        size_t len = (size_t)(nl - (cl->in + start));
        /* Every line spends a token, an empty one too, or "\n" in a loop
         * would cost a client nothing. Only a well-formed request counts
         * as activity: a client trickling bytes without ever finishing a
         * line, or sending empty or malformed lines, still times out. An
         * empty line gets no reply unless it is refused. */
        int empty = len == 0 || (len == 1 && cl->in[start] == '\r');
        if (!client_take_token(c, cl))
            refuse_rate(c, cl, cl->in + start, len);
        else if (!empty && control_handle_line(c, cl, cl->in + start, len))
            cl->last_active = gonio_monotonic_s();
        start += len + 1;
    }
    memmove(cl->in, cl->in + start, cl->in_len - start);
    cl->in_len -= start;
    if (cl->in_len > CONTROL_MAX_LINE) {
        control_send_error(cl, "line-too-long", NULL,
                           "a request line is at most %d bytes; closing the connection",
                           CONTROL_MAX_LINE);
        cl->closing = 1;
        cl->in_len = 0;
        control_client_try_write(cl);
    }
}

/* ---- connect, idle, close -------------------------------------------- */

void control_client_free(struct control_client *cl)
{
    close(cl->fd);
    free(cl->in);
    free(cl->out);
    free(cl);
}

/* With the socket opened to everyone by mistake, a stranger connecting in a
 * loop was measured to write ~95,000 refusal lines in 5 s. The first
 * REFUSED_LOGGED refusals of a REFUSED_WINDOW_S window are logged in full;
 * the others are counted, and the count is logged in one line when the
 * window ends (control_tick) or goniod stops. */
#define REFUSED_WINDOW_S 10.0
#define REFUSED_LOGGED 5

static void refusals_log_count(control *c, double t)
{
    if (c->refused_unlogged)
        fprintf(stderr, "goniod: ... and %lu more refused in the last %.0f s\n",
                c->refused_unlogged, t - c->refused_since);
    c->refused_logged = c->refused_unlogged = 0;
}

void control_refusals_flush(control *c)
{
    refusals_log_count(c, gonio_monotonic_s());
}

/* End the window when it is over; returns the seconds left in it while
 * refusals wait to be counted in the log (else -1). */
static double refusals_window(control *c, double t)
{
    if (c->refused_logged && t - c->refused_since >= REFUSED_WINDOW_S)
        refusals_log_count(c, t);
    return c->refused_unlogged ? c->refused_since + REFUSED_WINDOW_S - t : -1;
}

/* Log the refusal of client fd (prc and pc from peer_cred_get), or count it. */
static void log_refusal(control *c, int fd, int prc, const struct peer_cred *pc)
{
    double t = gonio_monotonic_s();
    refusals_window(c, t);
    if (!c->refused_logged)
        c->refused_since = t;
    if (c->refused_logged == REFUSED_LOGGED) {
        c->refused_unlogged++;
        return;
    }
    c->refused_logged++;
    if (prc < 0)
        fprintf(stderr, "goniod: refused client %d: no peer credentials: %s\n", fd,
                strerror(-prc));
    else
        fprintf(stderr,
                "goniod: refused client %d: pid %ld uid %ld gid %ld is not root, not goniod's "
                "user and not in group %ld\n",
                fd, (long)pc->pid, (long)pc->uid, (long)pc->gid, (long)c->allowed_gid);
}

void control_accept_clients(control *c)
{
    for (;;) {
        int fd = accept(c->listen_fd, NULL, NULL);
        if (fd < 0)
            return; /* EAGAIN, or a client that vanished */
        fcntl(fd, F_SETFL, O_NONBLOCK);
        fcntl(fd, F_SETFD, FD_CLOEXEC);
        struct control_client *cl = calloc(1, sizeof *cl);
        struct control_client **list = realloc(c->clients, (c->n_clients + 1) * sizeof *list);
        if (list)
            c->clients = list;
        if (cl)
            cl->in = malloc(CONTROL_MAX_LINE + 1);
        if (!cl || !list || !cl->in) {
            if (cl)
                free(cl->in);
            free(cl);
            close(fd);
            continue;
        }
        cl->fd = fd;
        cl->max_out = (size_t)c->cfg->max_queue_kib * 1024;
        cl->last_active = cl->tokens_at = gonio_monotonic_s();
        cl->tokens = (double)c->cfg->burst;
        c->clients[c->n_clients++] = cl;
        struct peer_cred pc;
        int prc = peer_cred_get(fd, &pc);
        if (prc < 0 || !peer_allowed(&pc, c->self_uid, c->allowed_gid)) {
            log_refusal(c, fd, prc, &pc);
            control_send_error(cl, "not-authorized", NULL,
                               "not allowed: the control socket serves root, goniod's user and "
                               "the members of group %ld",
                               (long)c->allowed_gid);
            cl->closing = 1;
            control_client_try_write(cl);
            continue;
        }
        if (c->n_clients > (size_t)c->cfg->max_clients) {
            control_send_error(cl, "too-many-clients", NULL,
                               "goniod serves at most %d connections", c->cfg->max_clients);
            cl->closing = 1;
            control_client_try_write(cl);
            continue;
        }
        control_client_send(cl, json_pack("{s:s, s:s, s:i, s:i}", "class", "VERSION", "release",
                                          GONIO_RELEASE, "proto_major", CONTROL_PROTO_MAJOR,
                                          "proto_minor", CONTROL_PROTO_MINOR));
    }
}

void control_reap(control *c)
{
    size_t k = 0;
    for (size_t i = 0; i < c->n_clients; i++) {
        if (c->clients[i]->dead && c->clients[i] == c->bringup_client)
            c->bringup_client = NULL; /* its bring-up goes on; nobody hears the end */
        if (c->clients[i]->dead)
            control_client_free(c->clients[i]);
        else
            c->clients[k++] = c->clients[i];
    }
    c->n_clients = k;
}

/* Watchers are exempt: they only listen, and the output limit is what
 * protects the daemon from one that stops reading. */
int control_tick(control *c)
{
    double t = gonio_monotonic_s(), next = c->cfg->idle_timeout_s;
    double window = refusals_window(c, t);
    if (window >= 0 && window < next)
        next = window;
    for (size_t i = 0; i < c->n_clients; i++) {
        struct control_client *cl = c->clients[i];
        if (cl->watching || cl->closing || cl->dead)
            continue;
        double idle = t - cl->last_active;
        if (idle >= c->cfg->idle_timeout_s) {
            control_send_error(cl, "idle-timeout", NULL,
                               "no request for %g s; closing the connection",
                               c->cfg->idle_timeout_s);
            cl->closing = 1;
            control_client_try_write(cl);
        } else if (c->cfg->idle_timeout_s - idle < next) {
            next = c->cfg->idle_timeout_s - idle;
        }
    }
    control_reap(c);
    int ms = (int)(next * 1000) + 1;
    return ms > 60000 ? 60000 : ms;
}
