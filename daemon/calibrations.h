/* The calibrations in goniod's calibration root, as an operator finds them
 * (docs/protocol.md, "list"): each one's kind, state, rig, detector, time
 * and frames, for the control socket's list command beside the captures.
 *
 * A calibration is complete when its calibration.json is written (and
 * expired once its validity has passed); until then goniod's record of the
 * request (request.json) and the journal of frames stand for it. A run
 * that stops short records its end as a capture's does (stop.json, through
 * daemon/captures.h: failed, aborted, or interrupted by goniod's shutdown);
 * a record with neither calibration.json, nor stop.json, nor a run was
 * interrupted by a crash or a kill: `gonio resume ID` continues it. */
#ifndef GONIO_DAEMON_CALIBRATIONS_H
#define GONIO_DAEMON_CALIBRATIONS_H

#include <time.h>

#include <jansson.h>

#include "daemon/captures.h"

/* Every calibration under root, newest change first: an array of objects
 * {id, kind, state, reason, message, rig, detector, created, expires,
 * frames_done, frames_total, last_change} (docs/protocol.md, "list"), the
 * state one of running, paused, complete, expired, interrupted, aborted,
 * failed as of now. live names the run goniod has (a calibration when its
 * id is one of root's). NULL when out of memory; a root that does not
 * exist yet lists nothing. */
json_t *calibrations_list(const char *root, const struct captures_live *live, time_t now);

#endif
