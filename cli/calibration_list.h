/* What gonio list and gonio status print of goniod's calibrations: the
 * list reply's "calibrations" (docs/protocol.md, "list"), with the command
 * that resumes one a crash, a shutdown or an abort cut short. */
#ifndef GONIO_CLI_CALIBRATION_LIST_H
#define GONIO_CLI_CALIBRATION_LIST_H

#include <jansson.h>

/* gonio list's calibrations section: a blank line, then one line a
 * calibration, newest first; nothing when there are none. sock: the
 * --socket given, for the resume command (NULL: the default). */
void calibration_list_table(json_t *calibrations, const char *sock);

/* gonio status's line on the newest calibration (nothing when there is
 * none), and the command that resumes it when it was interrupted or
 * aborted. */
void calibration_list_newest(json_t *newest, const char *sock);

#endif
