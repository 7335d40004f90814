/* The files gonio capture sends to goniod with its request (docs/protocol.md,
 * "Files sent with a request"): a plan or rig profile named as a file is read
 * here, where the operator can read it, and its text travels in the request
 * (plan_text, rig_text), since goniod may run as another user, in another
 * working directory, on another machine. */
#ifndef GONIO_CLI_REQUEST_FILE_H
#define GONIO_CLI_REQUEST_FILE_H

#include <jansson.h>

/* When value names a file (gonio_ref_is_file), set req's field to value
 * (the name messages use) and field_text to the file's text; a name is set
 * as it is. opt names the option in messages. 0, or 2 (the exit status)
 * with the reason on stderr: unreadable, larger than goniod takes, not
 * UTF-8 text. */
int request_file_attach(json_t *req, const char *field, const char *opt, const char *value);

/* Whether req, as one line, fits goniod's request line: 0, or 2 with the
 * reason on stderr. */
int request_file_fits(json_t *req);

#endif
