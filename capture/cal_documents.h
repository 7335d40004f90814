/* A calibration run as Bluesky event-model documents (docs/protocol.md,
 * "Calibrations as event-model documents"): a calibration is a capture, so
 * its run is described as one, whether goniod or gonio calibrate --offline
 * measured it. run_start names the calibration (id, kind, rig, detector,
 * validity, the dark and stray light it was taken with and their runs),
 * the primary stream has an event per raw frame, the results stream an
 * event per integration (dark) or geometry (reference, stray light) with
 * the frames' means and spreads, and run_stop says how it ended.
 *
 * The documents are appended to ROOT/ID/documents.jsonl, one [name, doc]
 * pair a line, and the run's uid to ROOT/ID/run-uids.txt, so that the runs
 * of a resumed calibration form a chain and a capture's run_start can name
 * the run of the calibration it is reduced with (cal_documents_last_uid). */
#ifndef GONIO_CAPTURE_CAL_DOCUMENTS_H
#define GONIO_CAPTURE_CAL_DOCUMENTS_H

#include <jansson.h>
#include <stddef.h>

#include "capture/calibration.h"
#include "common/err.h"

#define CAL_DOCUMENTS_FILE "documents.jsonl"
#define CAL_RUN_UIDS_FILE "run-uids.txt"

struct cal_doc_run {
    const struct cal_meta *meta;
    const struct cal_frame *frames; /* every frame of the calibration so far */
    size_t n;
    size_t total;             /* the frames the run takes (cal_run_total) */
    const char *plan;         /* reference, stray: the plan's name or file; else NULL */
    int per_point;            /* dark: frames per integration; else repeats */
    const char *source;       /* the detector's registers or device, for data_keys */
    const char *exit_status;  /* "success", "abort" or "fail" */
    const char *reason;       /* "complete", "aborted", a failure's message */
    double t_start, t_stop;   /* Unix time, fractional */
};

/* Build the run's documents, append them to ROOT/ID (meta->id) and call
 * emit (NULL: none) with each line ("[name, doc]", no newline), in order.
 * A failure to write is returned (err says which file); the documents are
 * emitted all the same. */
int cal_documents(const char *root, const struct cal_doc_run *r,
                  void (*emit)(void *user, const char *line), void *user,
                  struct gonio_err *err);

/* The uid of calibration ID's last run in ROOT ("" when it has none: a
 * calibration written before its runs were recorded). */
void cal_documents_last_uid(const char *root, const char *id, char out[37]);

/* The last run uid recorded in DIR/run-uids.txt, a capture's directory or
 * a calibration's ("" when none). */
void run_uids_last(const char *dir, char out[37]);

/* Unix time now, fractional. */
double cal_documents_now(void);

/* A new random uid, lower-case hex with dashes, as the event model's. */
void cal_documents_uid(char out[37]);

/* An event of descriptor's stream: data (taken), sequence number seq, and
 * the same timestamp t for every field (the values were learnt together). */
json_t *cal_documents_event(const char *descriptor, unsigned long long seq, json_t *data,
                            double t);

#endif
