/* The HTTP side of `gonio live` (docs/live.md), on libmicrohttpd: GET /
 * is the page (embedded, self-contained), GET /events the server-sent
 * events of a live_state. Anything else is refused with a 4xx: another
 * method 405, another path 404, a request with a body 413. Read-only: no
 * request reaches goniod. */
#ifndef GONIO_CLI_LIVE_HTTP_H
#define GONIO_CLI_LIVE_HTTP_H

#include "cli/live_state.h"

typedef struct live_http live_http;

/* Listen on host:port (an IPv4 or IPv6 address, port 0: any free one) and
 * serve st (not owned). NULL with a message on stderr when it cannot. */
live_http *live_http_start(const char *host, unsigned port, live_state *st);

/* The port it listens on. */
unsigned live_http_port(const live_http *h);

/* Stop serving (close st first so that event streams end). */
void live_http_stop(live_http *h);

/* The page (cli/live_page.html), NUL-terminated. */
extern const char live_page_html[];

#endif
