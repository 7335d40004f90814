/* A bring-up request that moves the axes (gonio home, move, limits), sent
 * and waited for so that Ctrl-C stops the axes: a SIGINT or SIGTERM while
 * goniod runs it sends goniod `abort` (docs/protocol.md) and waits for the
 * reply, which then says where the axes stopped. Closing the connection
 * alone would leave goniod driving them. */
#ifndef GONIO_CLI_BRINGUP_WAIT_H
#define GONIO_CLI_BRINGUP_WAIT_H

#include <jansson.h>

#include "cli/daemon_client.h"

/* Send req (stolen) on c and return its reply (NULL: the connection was
 * lost, said on stderr). *sig: the signal that asked for the abort, 0 when
 * none came. A second signal after the abort was sent stops waiting:
 * NULL, with *sig set and the reason on stderr. cmd names the command in
 * what it says. */
json_t *bringup_request(struct conn *c, json_t *req, const char *cmd, int *sig);

#endif
