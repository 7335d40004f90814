/* The HTTP side of `gonio live` (cli/live_http.h). A thread per
 * connection: an event stream's thread waits on the state (never the
 * other way round), so a slow page costs its own thread only. */
#include <arpa/inet.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>

#include <microhttpd.h>

#include "cli/live_http.h"

#define LIVE_MAX_PAGES 16       /* connections at once */
#define LIVE_KEEPALIVE_MS 15000 /* a comment line this often keeps proxies open */
#define LIVE_BATCH 400          /* samples per message */

struct live_http {
    struct MHD_Daemon *d;
    live_state *st;
};

/* One page's event stream. */
struct stream {
    live_state *st;
    struct live_cursor cur;
    char *buf;
    size_t len, off;
};

static ssize_t stream_read(void *cls, uint64_t pos, char *out, size_t max)
{
    (void)pos;
    struct stream *s = cls;
    if (s->off == s->len) {
        free(s->buf);
        s->off = 0;
        s->buf = live_state_next(s->st, &s->cur, LIVE_KEEPALIVE_MS, LIVE_BATCH, &s->len);
        if (!s->buf && s->len)
            return MHD_CONTENT_READER_END_OF_STREAM;
        if (!s->buf) {
            static const char ka[] = ": keepalive\n\n";
            s->buf = strdup(ka);
            s->len = s->buf ? sizeof ka - 1 : 0;
        }
        if (!s->buf)
            return MHD_CONTENT_READER_END_WITH_ERROR;
    }
    size_t n = s->len - s->off < max ? s->len - s->off : max;
    memcpy(out, s->buf + s->off, n);
    s->off += n;
    return (ssize_t)n;
}

static void stream_free(void *cls)
{
    struct stream *s = cls;
    free(s->buf);
    free(s);
}

static enum MHD_Result reply(struct MHD_Connection *conn, unsigned code, const char *type,
                             const char *body)
{
    struct MHD_Response *r =
        MHD_create_response_from_buffer(strlen(body), (void *)body, MHD_RESPMEM_PERSISTENT);
    if (!r)
        return MHD_NO;
    MHD_add_response_header(r, "Content-Type", type);
    MHD_add_response_header(r, "Cache-Control", "no-store");
    if (code == MHD_HTTP_METHOD_NOT_ALLOWED)
        MHD_add_response_header(r, "Allow", "GET, HEAD");
    enum MHD_Result rc = MHD_queue_response(conn, code, r);
    MHD_destroy_response(r);
    return rc;
}

static enum MHD_Result events(struct MHD_Connection *conn, live_state *st)
{
    struct stream *s = calloc(1, sizeof *s);
    if (!s)
        return MHD_NO;
    s->st = st;
    struct MHD_Response *r =
        MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, 16384, stream_read, s, stream_free);
    if (!r) {
        free(s);
        return MHD_NO;
    }
    MHD_add_response_header(r, "Content-Type", "text/event-stream");
    MHD_add_response_header(r, "Cache-Control", "no-store");
    enum MHD_Result rc = MHD_queue_response(conn, MHD_HTTP_OK, r);
    MHD_destroy_response(r);
    return rc;
}

static enum MHD_Result handle(void *cls, struct MHD_Connection *conn, const char *url,
                              const char *method, const char *version, const char *upload,
                              size_t *upload_size, void **con_cls)
{
    (void)version;
    (void)upload;
    live_http *h = cls;
    static int first;
    if (*con_cls == NULL) { /* the headers: refuse what is not a plain GET at once */
        *con_cls = &first;
        const char *cl = MHD_lookup_connection_value(conn, MHD_HEADER_KIND, "Content-Length");
        const char *te =
            MHD_lookup_connection_value(conn, MHD_HEADER_KIND, "Transfer-Encoding");
        if (strcmp(method, "GET") && strcmp(method, "HEAD"))
            return reply(conn, MHD_HTTP_METHOD_NOT_ALLOWED, "text/plain",
                         "gonio live is read-only: GET / or /events\n");
        if ((cl && strcmp(cl, "0")) || te)
            return reply(conn, MHD_HTTP_CONTENT_TOO_LARGE, "text/plain",
                         "gonio live takes no request bodies\n");
        return MHD_YES;
    }
    if (*upload_size) { /* a body its headers did not announce */
        *upload_size = 0;
        return MHD_YES;
    }
    if (!strcmp(url, "/"))
        return reply(conn, MHD_HTTP_OK, "text/html; charset=utf-8", live_page_html);
    if (!strcmp(url, "/events"))
        return events(conn, h->st);
    return reply(conn, MHD_HTTP_NOT_FOUND, "text/plain", "no such page: GET / or /events\n");
}

live_http *live_http_start(const char *host, unsigned port, live_state *st)
{
    struct sockaddr_storage ss = {0};
    struct sockaddr_in *a4 = (struct sockaddr_in *)&ss;
    struct sockaddr_in6 *a6 = (struct sockaddr_in6 *)&ss;
    unsigned flags = MHD_USE_THREAD_PER_CONNECTION | MHD_USE_INTERNAL_POLLING_THREAD |
                     MHD_USE_ERROR_LOG;
    if (inet_pton(AF_INET, host, &a4->sin_addr) == 1) {
        a4->sin_family = AF_INET;
        a4->sin_port = htons((uint16_t)port);
    } else if (inet_pton(AF_INET6, host, &a6->sin6_addr) == 1) {
        a6->sin6_family = AF_INET6;
        a6->sin6_port = htons((uint16_t)port);
        flags |= MHD_USE_IPv6;
    } else {
        fprintf(stderr, "gonio live: --listen '%s': not an IPv4 or IPv6 address\n", host);
        return NULL;
    }
    live_http *h = calloc(1, sizeof *h);
    if (!h)
        return NULL;
    h->st = st;
    h->d = MHD_start_daemon(flags, (uint16_t)port, NULL, NULL, handle, h, MHD_OPTION_SOCK_ADDR,
                            (struct sockaddr *)&ss, MHD_OPTION_CONNECTION_LIMIT,
                            (unsigned)LIVE_MAX_PAGES, MHD_OPTION_END);
    if (!h->d) {
        fprintf(stderr, "gonio live: cannot listen on %s port %u (in use?)\n", host, port);
        free(h);
        return NULL;
    }
    return h;
}

unsigned live_http_port(const live_http *h)
{
    const union MHD_DaemonInfo *i = MHD_get_daemon_info(h->d, MHD_DAEMON_INFO_BIND_PORT);
    return i ? i->port : 0;
}

void live_http_stop(live_http *h)
{
    if (!h)
        return;
    MHD_stop_daemon(h->d);
    free(h);
}
