/* One progress display for every long job gonio runs (an offline capture,
 * a capture followed through goniod, a study, training a decoder): on a
 * terminal one bar redrawn in place on stderr, with done/total, rig time,
 * the ETA and the live fit error where the job has one; plain lines when
 * stderr is not a terminal (logs, pipes: a line at the start, each tenth
 * and the end); nothing with quiet. The ETA comes from the job (a
 * capture's is the plan's estimate from the first line, refined as it
 * runs: capture/capture.h), so the first line already has one. */
#ifndef GONIO_CLI_PROGRESS_H
#define GONIO_CLI_PROGRESS_H

#include <stddef.h>

struct progress {
    const char *label; /* "capture", "study", ... */
    int quiet, tty;
    size_t last_tenth; /* plain lines: the last tenth printed, +1 (0: none yet; a
                          pool's: 1 once one is printed) */
    size_t drawn;      /* terminal: length of the bar line on screen, 0 when none */
};

/* A display for label; tty from stderr. */
void progress_init(struct progress *p, const char *label, int quiet);

/* Where the job stands. rig_time_s, eta_s, estimate_s and fit_error are
 * shown when finite (NAN: the job has none, or not yet). */
struct progress_state {
    size_t done, total;
    double rig_time_s, estimate_s, eta_s, fit_error;
    const char *unit; /* "points", "jobs", "epochs" */
    /* An adaptive capture (pool set): total is the size of the pool it
     * chooses from (no bar: it measures a few), estimate_s its budget; its
     * prediction "predicted error now 0.031, 0.025 in ~4 min" when finite,
     * marked "(rough: few samples)" while done is below
     * ADAPTIVE_CALIBRATED_SAMPLES (the fields are read only with pool set). */
    int pool;
    double predicted, predicted_next, predicted_next_s;
};

void progress_show(struct progress *p, const struct progress_state *s);

/* A line of its own (started, resuming, paused...): the bar, if drawn, is
 * ended first. Also printed when quiet is off only. */
void progress_note(struct progress *p, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

/* End the bar's line, if one is drawn, so that what follows starts clean. */
void progress_end(struct progress *p);

/* Seconds as h:mm:ss, or m:ss under an hour. */
void progress_hms(double s, char *buf, size_t size);

#endif
