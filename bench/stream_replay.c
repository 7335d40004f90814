/* Replay a capture's journal through the streaming fit and show, round by
 * round, what the stop rule sees (model change, held-out and in-sample
 * errors) beside what it cannot see: the full-domain log error of the
 * round's model against the true material. Used to choose the stop
 * defaults of docs/fitting.md.
 *
 *   stream_replay DIR MATERIAL [tol holdout_tol rounds every min_points]
 *
 * DIR is a capture directory (its samples.csv, in journal order). Level
 * ends are not marked, so rounds fall every `every` samples only; with
 * REPLAY_ROWS=N in the environment, every theta_i row that ends after
 * sample N also ends a level (to try rounds on whole rows). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/domain.h"
#include "brdf/material.h"
#include "brdf/metrics.h"
#include "fit/journal_samples.h"
#include "journal/journal.h"
#include "fit/stream.h"

int main(int argc, char **argv)
{
    if (argc != 3 && argc != 8) {
        fprintf(stderr, "usage: stream_replay DIR MATERIAL [tol holdout_tol rounds every "
                        "min_points]\n");
        return 2;
    }
    struct gonio_err err = {0};
    struct fit_stream_options so = fit_stream_default_options();
    so.converge = 0; /* replay to the end: show every round */
    if (argc == 8) {
        so.tol = atof(argv[3]);
        so.holdout_tol = atof(argv[4]);
        so.rounds = atol(argv[5]);
        so.every = atol(argv[6]);
        so.min_points = atol(argv[7]);
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/samples.csv", argv[1]);
    struct journal_sample *js = NULL;
    size_t n = 0;
    journal *j = journal_open(path, &js, &n, &err);
    brdf_material *truth = brdf_material_open(argv[2], &err);
    struct brdf_domain full = {0};
    fit_stream *fs = NULL;
    if (!j || !truth || brdf_domain_full(&full, &err) < 0 || fit_stream_new(&so, &fs, &err) < 0) {
        fprintf(stderr, "stream_replay: %s\n", err.msg);
        return 1;
    }
    journal_close(j);
    printf("%6s %9s %9s %9s %9s %5s %9s\n", "n", "rig_s", "change", "holdout", "fit", "calm",
           "full_log");
    int rounds = 0, calm_run = 0;
    for (size_t i = 0; i < n; i++) {
        struct fit_sample s = {0};
        fit_journal_samples(&js[i], 1, &s);
        /* ends: theta_i rows (whole-row sub-levels of progressive order) */
        int end = getenv("REPLAY_ROWS") && i >= (size_t)atol(getenv("REPLAY_ROWS")) &&
                  (i + 1 == n || js[i + 1].theta_i != js[i].theta_i);
        /* REPLAY_LEVELS=52,176: samples that end a level (counts) */
        for (const char *l = getenv("REPLAY_LEVELS"); l && *l; l = strchr(l, ',') ? strchr(l, ',') + 1 : "")
            if ((size_t)atol(l) == i + 1)
                end = 1;
        if (fit_stream_add(fs, &s, end, &err) < 0)
            return 1;
        struct fit_stream_status st;
        fit_stream_status(fs, &st);
        if (st.rounds == rounds)
            continue;
        rounds = st.rounds;
        double full_log = NAN;
        const struct brdf_abc *p = fit_stream_params(fs);
        if (p) {
            brdf_material *m = brdf_abc_material(p, "abc");
            struct brdf_errors e;
            if (m && brdf_errors_material(truth, m, &full, &e, NULL) == 0)
                full_log = e.log;
            brdf_material_free(m);
        }
        int would = st.calm >= so.rounds && (long)st.samples >= so.min_points;
        printf("%6zu %9.1f %9.5f %9.4f %9.4f %5d %9.4f%s\n", st.samples, js[i].rig_time_s,
               st.change, st.holdout, st.fit_error, st.calm, full_log,
               would && !calm_run ? "   <- converged" : "");
        if (would)
            calm_run = 1;
    }
    fit_stream_free(fs);
    brdf_domain_free(&full);
    brdf_material_free(truth);
    free(js);
    return 0;
}
