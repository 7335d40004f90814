/* gonio live: a page in the browser that follows goniod's capture stream,
 * or shows a finished capture from its directory (docs/live.md). A shell
 * over cli/live_state.h and cli/live_http.h: it watches, never controls. */
#include <arpa/inet.h>
#include <errno.h>
#include <getopt.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli/commands.h"
#include "cli/daemon_client.h"
#include "cli/live_http.h"
#include "cli/live_state.h"

#define LIVE_LISTEN_DEFAULT "127.0.0.1:8080"

static volatile sig_atomic_t stopping;

static void on_signal(int sig)
{
    (void)sig;
    stopping = 1;
}

static void usage(FILE *out)
{
    fprintf(out,
            "usage: gonio live [--listen ADDR:PORT] [--socket PATH | --dir CAPTURE-DIR]\n"
            "  Serve a page that follows goniod's capture as it runs: progress, ETA, rig\n"
            "  state and alarms, the in-plane slice with each sample as it arrives and the\n"
            "  current fit through them, and the fit (or predicted) error against rig time.\n"
            "  Read-only: it watches goniod's stream and never controls the rig.\n"
            "  --listen: the address to serve on (default " LIVE_LISTEN_DEFAULT
            ", this machine\n"
            "  only; port 0 takes a free one); [::1]:PORT for IPv6.\n"
            "  --dir: show a finished capture from its directory instead (no goniod).\n"
            "  The socket is --socket, else $GONIO_SOCKET, else " GONIO_SOCKET_DEFAULT ".\n"
            "  Prints the page's URL on stdout; runs until SIGINT or SIGTERM.\n");
}

/* "HOST:PORT" or "[V6]:PORT" into host (size n) and port; -1 if malformed. */
static int parse_listen(const char *text, char *host, size_t n, unsigned *port)
{
    const char *colon = strrchr(text, ':');
    const char *h = text;
    size_t hl = colon ? (size_t)(colon - text) : 0;
    if (colon && text[0] == '[' && hl >= 2 && colon[-1] == ']') {
        h = text + 1;
        hl -= 2;
    }
    if (!colon || hl == 0 || hl >= n || !colon[1])
        return -1;
    unsigned char addr[16];
    char h0[64];
    snprintf(h0, sizeof h0, "%.*s", (int)hl, h);
    /* an address, not a name: what it binds to is then what was asked */
    if (inet_pton(AF_INET, h0, addr) != 1 && inet_pton(AF_INET6, h0, addr) != 1)
        return -1;
    char *end;
    errno = 0;
    unsigned long p = strtoul(colon + 1, &end, 10);
    if (*end || errno || p > 65535 || colon[1] == '-' || colon[1] == '+')
        return -1;
    memcpy(host, h, hl);
    host[hl] = '\0';
    *port = (unsigned)p;
    return 0;
}

/* Follow goniod's stream into st until it ends or a signal comes. */
static int follow(live_state *st, const char *sock)
{
    struct conn c;
    int rc = conn_watch(&c, sock);
    if (rc)
        return rc;
    while (!stopping) {
        json_t *d = conn_read(&c);
        if (!d) {
            if (!stopping) {
                fprintf(stderr, "gonio live: goniod closed the connection; the page keeps "
                                "what it showed\n");
                live_state_note(st, "goniod closed the connection");
            }
            break;
        }
        live_state_feed(st, d);
        json_decref(d);
    }
    conn_close(&c);
    return rc;
}

int cmd_live(int argc, char **argv)
{
    static const struct option opts[] = {
        {"listen", required_argument, NULL, 'l'}, {"socket", required_argument, NULL, 'S'},
        {"dir", required_argument, NULL, 'd'},    {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    const char *listen = LIVE_LISTEN_DEFAULT, *sock = NULL, *dir = NULL;
    int ch;
    optind = 1;
    while ((ch = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        switch (ch) {
        case 'l': listen = optarg; break;
        case 'S': sock = optarg; break;
        case 'd': dir = optarg; break;
        case 'h': usage(stdout); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (optind != argc) {
        fprintf(stderr, "gonio live: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    if (dir && sock) {
        fprintf(stderr, "gonio live: --dir shows a capture directory, --socket follows goniod: "
                        "give one\n");
        return 2;
    }
    char host[128];
    unsigned port;
    if (parse_listen(listen, host, sizeof host, &port) < 0) {
        fprintf(stderr, "gonio live: --listen '%s': use IP-ADDRESS:PORT (127.0.0.1:8080, "
                        "[::1]:8080), port 0..65535\n", listen);
        return 2;
    }
    live_state *st = live_state_new();
    if (!st)
        return 1;
    struct gonio_err err;
    if (dir && live_state_load_dir(st, dir, &err) < 0) {
        fprintf(stderr, "gonio live: %s\n", err.msg);
        live_state_free(st);
        return 2;
    }
    struct sigaction sa = {.sa_handler = on_signal}; /* no SA_RESTART: reads return */
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);
    live_http *h = live_http_start(host, port, st);
    if (!h) {
        live_state_free(st);
        return 1;
    }
    printf(strchr(host, ':') ? "gonio live: http://[%s]:%u/\n" : "gonio live: http://%s:%u/\n",
           host, live_http_port(h));
    fflush(stdout);
    int rc = dir ? 0 : follow(st, sock);
    while (!stopping && !rc)
        pause(); /* keep serving what was shown until told to stop */
    live_state_close(st);
    live_http_stop(h);
    live_state_free(st);
    return rc;
}
