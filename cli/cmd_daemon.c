/* The gonio commands that talk to goniod over its control socket
 * (docs/protocol.md): capture (without --offline), status, watch, pause,
 * resume, abort, shutdown. Errors from the daemon are printed as it gives
 * them; exit status 1 for a daemon error, 2 for bad usage. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "capture/capture.h"
#include "cli/calibration_list.h"
#include "cli/commands.h"
#include "cli/daemon_client.h"
#include "cli/progress.h"
#include "cli/request_file.h"
#include "fit/models.h"

/* ---- watching -------------------------------------------------------- */

static double jreal(json_t *d, const char *key)
{
    json_t *v = json_object_get(d, key);
    return json_is_number(v) ? json_number_value(v) : NAN;
}

static size_t jsize(json_t *d, const char *key)
{
    return (size_t)json_integer_value(json_object_get(d, key));
}

/* A capture's start: what it is, its estimate, whether it resumes. */
static void show_start(struct progress *p, json_t *d)
{
    char est[32] = "?";
    double e = jreal(d, "estimate_s");
    if (isfinite(e))
        progress_hms(e, est, sizeof est);
    printf("capture %s: plan %s, %zu points, estimated rig time %s\n", p->label,
           json_string_value(json_object_get(d, "plan")), jsize(d, "total"), est);
    fflush(stdout);
    if (jsize(d, "already_done"))
        progress_note(p, "resuming: %zu of %zu points in the journal", jsize(d, "already_done"),
                      jsize(d, "total"));
}

/* pool: the capture is adaptive (its start document says so). */
static void show_event(struct progress *p, json_t *d, double estimate_s, int pool)
{
    progress_show(p, &(struct progress_state){
                         .done = jsize(d, "done"), .total = jsize(d, "total"), .unit = "points",
                         .rig_time_s = jreal(d, "rig_time_s"), .estimate_s = estimate_s,
                         .eta_s = jreal(d, "eta_s"), .fit_error = jreal(d, "fit_log_error"),
                         .pool = pool,
                         .predicted = jreal(d, "predicted_error"),
                         .predicted_next = jreal(d, "predicted_next"),
                         .predicted_next_s = jreal(d, "predicted_next_s")});
}

static void show_stop(struct progress *p, json_t *d)
{
    progress_end(p);
    const char *reason = json_string_value(json_object_get(d, "reason"));
    const char *msg = json_string_value(json_object_get(d, "message"));
    json_t *res = json_object_get(d, "results");
    printf("capture %s stopped: %s", json_string_value(json_object_get(d, "capture_id")),
           reason ? reason : "?");
    if (msg)
        printf(" (%s)", msg);
    if (json_object_get(d, "samples"))
        printf(", %lld samples, rig time %.1f s",
               (long long)json_integer_value(json_object_get(d, "samples")),
               jreal(d, "rig_time_s"));
    printf("\n");
    if (res) {
        json_t *ep = json_object_get(res, "err_plan");
        /* the verdict first: an underdetermined fit's small error is no figure
         * to trust (an older goniod says only whether it converged) */
        const char *verdict = json_string_value(json_object_get(res, "fit_status"));
        printf("  fit %s: %s, plan log error %.4f, relative RMSE %.4f\n",
               json_string_value(json_object_get(res, "model")),
               verdict ? verdict
               : json_is_true(json_object_get(res, "converged")) ? "converged" : "not-converged",
               jreal(ep, "log_error"), jreal(ep, "rel_rmse"));
        json_t *ef = json_object_get(res, "err_full");
        const char *truth = json_string_value(json_object_get(res, "truth"));
        if (ef)
            printf("  against %s: full-domain log error %.4f\n", truth ? truth : "the material",
                   jreal(ef, "log_error"));
        json_t *ad = json_object_get(res, "adaptive");
        if (ad)
            printf("  adaptive: predicted full-domain log error of %s %.4f; decisions %.3f s "
                   "mean, %.3f s max\n",
                   json_string_value(json_object_get(ad, "model")),
                   jreal(ad, "predicted_error"), jreal(ad, "decision_mean_s"),
                   jreal(ad, "decision_max_s"));
    }
    json_t *iso = json_object_get(json_object_get(d, "checks"), "isotropy");
    if (iso)
        printf("  isotropy check: %s (%s; largest deviation %.3f, %.1f sigma against %.1f; "
               "%.0f s of rig time, %.1f%% of the capture's)\n",
               json_string_value(json_object_get(iso, "verdict")),
               json_string_value(json_object_get(iso, "why")), jreal(iso, "max_deviation"),
               jreal(iso, "significance"), jreal(iso, "threshold"), jreal(iso, "rig_time_s"),
               100.0 * jreal(iso, "rig_time_share"));
    json_t *oop = json_object_get(json_object_get(d, "checks"), "out_of_plane");
    if (oop)
        printf("  out-of-plane check: in-plane %s (%s; %.0f s of rig time, %.1f%% of the "
               "capture's)\n",
               json_string_value(json_object_get(oop, "verdict")),
               json_string_value(json_object_get(oop, "why")), jreal(oop, "rig_time_s"),
               100.0 * jreal(oop, "rig_time_share"));
    json_t *interval = json_object_get(oop, "error_full_interval");
    if (json_is_number(json_object_get(oop, "error_full")) && json_array_size(interval) == 2)
        printf("  full-domain log error estimated %.4f (95%%: %.4f-%.4f, %lld of %lld nodes "
               "read)\n",
               jreal(oop, "error_full"), json_number_value(json_array_get(interval, 0)),
               json_number_value(json_array_get(interval, 1)),
               (long long)json_integer_value(json_object_get(oop, "domain_pairs_used")),
               (long long)json_integer_value(json_object_get(oop, "domain_pairs")));
    json_t *choice = json_object_get(d, "auto"); /* --model auto: what it chose, and why */
    const char *why = json_string_value(json_object_get(choice, "why"));
    if (json_is_string(json_object_get(choice, "chosen")))
        printf("  auto: %s%s%s\n", json_string_value(json_object_get(choice, "chosen")),
               why && why[0] ? "; " : "", why ? why : "");
    fflush(stdout);
}

/* Follow the stream until the stop document of capture `id` (any capture
 * when id is NULL), its progress on stderr (cli/progress.h), what it gave
 * on stdout. Returns 0 for a complete capture, 1 otherwise. */
static int follow(struct conn *c, const char *id, int quiet)
{
    char cur[128] = "";
    double estimate_s = NAN;
    int pool = 0;
    struct progress p;
    progress_init(&p, cur, quiet);
    if (id)
        snprintf(cur, sizeof cur, "%s", id);
    for (;;) {
        json_t *d = conn_read(c);
        if (!d) {
            progress_end(&p);
            fprintf(stderr, "gonio: goniod closed the connection\n");
            return 1;
        }
        const char *cls = json_string_value(json_object_get(d, "class"));
        const char *cid = json_string_value(json_object_get(d, "capture_id"));
        int mine = !id || (cid && !strcmp(cid, id));
        if (!cls) {
        } else if (!strcmp(cls, "start") && mine) {
            snprintf(cur, sizeof cur, "%s", cid ? cid : "?");
            progress_init(&p, cur, quiet);
            estimate_s = jreal(d, "estimate_s");
            pool = json_is_true(json_object_get(d, "adaptive"));
            show_start(&p, d);
        } else if (!strcmp(cls, "event") && cur[0]) {
            show_event(&p, d, estimate_s, pool);
        } else if (!strcmp(cls, "state") && mine && cur[0]) {
            const char *state = json_string_value(json_object_get(d, "state"));
            progress_note(&p, "capture %s %s", cur,
                          state && !strcmp(state, "paused") ? "paused" : "resumed");
        } else if (!strcmp(cls, "stop") && mine) {
            show_stop(&p, d);
            const char *status = json_string_value(json_object_get(d, "exit_status"));
            int rc = !status || strcmp(status, "success") != 0;
            json_decref(d);
            return rc;
        } else if (!strcmp(cls, "ERROR")) {
            progress_end(&p);
            reply_failed(d);
            json_decref(d);
            return 1;
        }
        json_decref(d);
    }
}

/* ---- commands -------------------------------------------------------- */

/* status's line on the current or last capture: state, progress, rig time
 * against the estimate, ETA, and why it failed. */
static void show_capture(json_t *cap)
{
    if (!json_is_object(cap))
        return;
    const char *state = json_string_value(json_object_get(cap, "state"));
    char rig[32], est[64] = "", eta[48] = "";
    progress_hms(jreal(cap, "rig_time_s"), rig, sizeof rig);
    double e = jreal(cap, "estimate_s"), left = jreal(cap, "eta_s");
    if (isfinite(e)) {
        char t[24];
        progress_hms(e, t, sizeof t);
        snprintf(est, sizeof est, " of ~%s estimated", t);
    }
    if (isfinite(left) && state && (!strcmp(state, "running") || !strcmp(state, "paused"))) {
        char t[24];
        progress_hms(left, t, sizeof t);
        snprintf(eta, sizeof eta, ", ETA %s", t);
    }
    /* a calibration (minor addition): its kind, and frames for points */
    const char *kind = json_string_value(json_object_get(cap, "kind"));
    int cal = kind && strcmp(kind, "capture") != 0;
    printf("%s%s %s: %s, %zu/%zu %s, rig time %s%s%s\n", cal ? kind : "capture",
           cal ? " calibration" : "", json_string_value(json_object_get(cap, "capture_id")),
           state ? state : "?", jsize(cap, "points_done"), jsize(cap, "points_total"),
           cal ? "frames" : "points", rig, est, eta);
    const char *msg = json_string_value(json_object_get(cap, "message"));
    if (msg)
        printf("  %s\n", msg);
}

/* Options every daemon command takes. */
#define SOCKET_OPTS {"socket", required_argument, NULL, 'S'}, {"help", no_argument, NULL, 'h'}

/* The command that resumes capture id, as the operator would type it. */
static void print_resume_hint(const char *id, const char *sock)
{
    printf("  resume it with: gonio resume %s%s%s\n", id, sock ? " --socket " : "",
           sock ? sock : "");
}

/* The captures in goniod's capture root, newest first (NULL on error,
 * printed). */
static json_t *request_list(struct conn *c)
{
    json_t *rep = conn_request(c, json_pack("{s:s}", "cmd", "list"));
    if (reply_failed(rep)) {
        json_decref(rep);
        return NULL;
    }
    return rep;
}

/* status's line on the newest capture in the capture root, and the command
 * that resumes it when it was interrupted or aborted. */
static void show_newest(const char *sock, json_t *newest)
{
    if (!json_is_object(newest))
        return;
    const char *id = json_string_value(json_object_get(newest, "id"));
    const char *state = json_string_value(json_object_get(newest, "state"));
    char rig[32];
    progress_hms(jreal(newest, "rig_time_s"), rig, sizeof rig);
    printf("newest capture %s: %s, %zu/%zu samples, rig time %s, last change %s\n", id, state,
           jsize(newest, "samples_done"), jsize(newest, "samples_total"), rig,
           json_string_value(json_object_get(newest, "last_change")));
    const char *verdict = json_string_value(json_object_get(newest, "fit_status"));
    if (verdict)
        printf("  fit %s, plan log error %.4f\n", verdict, jreal(newest, "plan_log_error"));
    if (!strcmp(state, "interrupted") || !strcmp(state, "aborted"))
        print_resume_hint(id, sock);
}

static void show_status(json_t *rep, json_t *newest, json_t *newest_cal, const char *sock)
{
    const char *state = json_string_value(json_object_get(rep, "state"));
    const char *kind = json_string_value(json_object_get(json_object_get(rep, "capture"),
                                                         "kind"));
    int cal = kind && strcmp(kind, "capture") != 0;
    printf("goniod %s", state);
    if (strcmp(state, "idle"))
        printf(": %s %s, %lld/%lld %s, rig time %.1f s", cal ? "calibration" : "capture",
               json_string_value(json_object_get(rep, "capture_id")),
               (long long)json_integer_value(json_object_get(rep, "points_done")),
               (long long)json_integer_value(json_object_get(rep, "points_total")),
               cal ? "frames" : "points", jreal(rep, "rig_time_s"));
    printf("\n");
    show_capture(json_object_get(rep, "capture"));
    json_t *fe = json_object_get(rep, "fit_error");
    if (json_is_object(fe)) {
        const char *verdict = json_string_value(json_object_get(fe, "status"));
        printf("fit (%s, %lld samples): log error %.4f, relative RMSE %.4f%s%s\n",
               json_string_value(json_object_get(fe, "capture_id")),
               (long long)json_integer_value(json_object_get(fe, "samples")),
               jreal(fe, "log_error"), jreal(fe, "rel_rmse"), verdict ? ", " : "",
               verdict ? verdict : "");
    }
    show_newest(sock, newest);
    calibration_list_newest(newest_cal, sock);
    /* the daemon's release, as goniod --version prints it: the one that
     * answers may differ from this gonio's (an older one does not say) */
    const char *release = json_string_value(json_object_get(rep, "release"));
    if (release)
        printf("goniod %s\n", release);
}

/* gonio list's table: one line a capture, newest first. */
static void show_list(json_t *list)
{
    printf("%-34s %-12s %-11s %13s %9s  %-20s  %s\n", "ID", "PLAN", "STATE", "SAMPLES",
           "RIG TIME", "LAST CHANGE", "SAMPLE");
    size_t i;
    json_t *e;
    json_array_foreach(list, i, e) {
        char rig[32], samples[32];
        progress_hms(jreal(e, "rig_time_s"), rig, sizeof rig);
        snprintf(samples, sizeof samples, "%zu/%zu", jsize(e, "samples_done"),
                 jsize(e, "samples_total"));
        const char *sample = json_string_value(json_object_get(e, "sample"));
        printf("%-34s %-12s %-11s %13s %9s  %-20s  %s\n",
               json_string_value(json_object_get(e, "id")),
               json_string_value(json_object_get(e, "plan")),
               json_string_value(json_object_get(e, "state")), samples, rig,
               json_string_value(json_object_get(e, "last_change")), sample ? sample : "-");
    }
}

static void print_json(json_t *d)
{
    json_object_del(d, "id");
    char *s = json_dumps(d, JSON_COMPACT);
    printf("%s\n", s ? s : "null");
    free(s);
}

/* What a command prints of its OK reply. */
static int show_reply(struct conn *c, const char *cmd, json_t *rep, int json_out,
                      const char *sock)
{
    if (!strcmp(cmd, "status")) {
        json_t *list = request_list(c);
        if (!list)
            return 1;
        json_t *newest = json_array_get(json_object_get(list, "captures"), 0);
        json_t *cal = json_array_get(json_object_get(list, "calibrations"), 0);
        if (json_out) {
            json_object_set(rep, "newest_capture", newest ? newest : json_null());
            json_object_set(rep, "newest_calibration", cal ? cal : json_null());
            print_json(rep);
        } else {
            show_status(rep, newest, cal, sock);
        }
        json_decref(list);
    } else if (!strcmp(cmd, "list")) {
        if (json_out) {
            print_json(rep);
        } else {
            show_list(json_object_get(rep, "captures"));
            calibration_list_table(json_object_get(rep, "calibrations"), sock);
        }
    } else {
        const char *id = json_string_value(json_object_get(rep, "capture_id"));
        const char *bringup = json_string_value(json_object_get(rep, "bringup"));
        if (bringup)
            printf("goniod: %s bring-up '%s': its axes stop\n", cmd, bringup);
        else
            printf("goniod: %s%s%s\n", cmd, id ? " " : "", id ? id : "");
        if (id && !strcmp(cmd, "abort"))
            print_resume_hint(id, sock);
    }
    return 0;
}

static int simple(int argc, char **argv, const char *cmd, const char *usage_args,
                  const char *help)
{
    static const struct option opts[] = {SOCKET_OPTS, {"json", no_argument, NULL, 'j'},
                                         {"refit", no_argument, NULL, 'R'},
                                         {NULL, 0, NULL, 0}};
    const char *sock = NULL;
    int json_out = 0, refit = 0, ch;
    optind = 1;
    while ((ch = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        /* --json and --refit only where the usage names them */
        if ((ch == 'j' && !strstr(usage_args, "--json")) ||
            (ch == 'R' && !strstr(usage_args, "--refit")))
            ch = '?';
        switch (ch) {
        case 'S': sock = optarg; break;
        case 'j': json_out = 1; break;
        case 'R': refit = 1; break;
        case 'h': printf("usage: gonio %s %s[--socket PATH]\n  %s\n", cmd, usage_args, help);
                  return 0;
        default: fprintf(stderr, "usage: gonio %s %s[--socket PATH]\n", cmd, usage_args);
                 return 2;
        }
    }
    const char *arg = NULL;
    if (strstr(usage_args, "ID") && optind < argc)
        arg = argv[optind++];
    if (optind != argc) {
        fprintf(stderr, "gonio %s: unexpected argument '%s'\n", cmd, argv[optind]);
        return 2;
    }
    struct conn c;
    if (conn_open(&c, socket_path(sock)) < 0)
        return 1;
    json_t *req = json_pack("{s:s}", "cmd", cmd);
    if (arg)
        json_object_set_new(req, "capture_id", json_string(arg));
    if (refit)
        json_object_set_new(req, "refit", json_true());
    json_t *rep = conn_request(&c, req);
    int rc = reply_failed(rep);
    if (!rc)
        rc = show_reply(&c, cmd, rep, json_out, sock);
    json_decref(rep);
    conn_close(&c);
    return rc;
}

int cmd_status(int argc, char **argv)
{
    return simple(argc, argv, "status", "[--json] ",
                  "state (idle, running, paused), capture id, points done, rig time, last "
                  "fit error,\n  the newest capture in the capture root (and the command "
                  "that resumes it\n  when it was interrupted or aborted), the newest "
                  "calibration (the same), goniod's release");
}

int cmd_pause(int argc, char **argv)
{
    return simple(argc, argv, "pause", "", "pause the capture at the next point boundary");
}

int cmd_resume(int argc, char **argv)
{
    return simple(argc, argv, "resume", "[CAPTURE-ID] [--refit] ",
                  "continue the paused capture (or calibration, once the operator did what\n"
                  "  goniod asked), or (idle daemon) resume an interrupted or aborted capture\n"
                  "  or calibration from its journal. A complete capture is refused (exit 2,\n"
                  "  nothing changed) unless --refit: fit its samples again, rewrite results");
}

int cmd_list(int argc, char **argv)
{
    return simple(argc, argv, "list", "[--json] ",
                  "the captures in goniod's capture root, newest first: id, plan, state\n"
                  "  (running, paused, complete, interrupted, failed, aborted), samples done/"
                  "total,\n  rig time, last change (UTC); then the calibrations in its "
                  "calibration root: id,\n  kind, state (the same, or expired), frames, rig, "
                  "detector, created, expires,\n  and the command that resumes one "
                  "interrupted or aborted");
}

int cmd_abort(int argc, char **argv)
{
    return simple(argc, argv, "abort", "",
                  "stop the capture at the next point boundary; its samples are kept, and\n"
                  "  the command that resumes it is printed. A running bring-up command\n"
                  "  (home, move, limits) ends at once, its axes stopped where they are");
}

int cmd_shutdown(int argc, char **argv)
{
    return simple(argc, argv, "shutdown", "",
                  "stop goniod (a running capture is aborted, its samples kept)");
}

int cmd_watch(int argc, char **argv)
{
    static const struct option opts[] = {SOCKET_OPTS, {"quiet", no_argument, NULL, 'q'},
                                         {NULL, 0, NULL, 0}};
    const char *sock = NULL;
    int ch, quiet = 0;
    optind = 1;
    while ((ch = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        switch (ch) {
        case 'S': sock = optarg; break;
        case 'q': quiet = 1; break;
        case 'h': printf("usage: gonio watch [--quiet] [--socket PATH]\n  follow the running (or "
                         "next) capture until it stops: its progress on stderr (a bar on a\n"
                         "  terminal, pause and resume), its results on stdout; --quiet: the "
                         "results only\n");
                  return 0;
        default: fprintf(stderr, "usage: gonio watch [--quiet] [--socket PATH]\n"); return 2;
        }
    }
    if (optind != argc) {
        fprintf(stderr, "gonio watch: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    struct conn c;
    int rc = conn_watch(&c, sock);
    if (rc)
        return rc;
    rc = follow(&c, NULL, quiet);
    conn_close(&c);
    return rc;
}

static void capture_usage(FILE *out)
{
    fprintf(out,
            "usage: gonio capture --plan NAME|FILE [--scene NAME|FILE] [--material SPEC]\n"
            "                     [--rig NAME|FILE] [--model NAME] [--order ORDER]\n"
            "                     [--stop all|converge] [--budget MINUTES]\n"
            "                     [--stop-target LOG_ERR] [--truth SPEC] [--prescan N]\n"
            "                     [--name ID] [--sample NAME] [--operator NAME] [--note TEXT]\n"
            "                     [--uncalibrated] [--calibration ID|newest]\n"
            "                     [--reference-after]\n"
            "                     [--check CHECK[,CHECK]] [--wait] [--quiet] [--socket PATH]\n"
            "  Starts a capture on goniod (--offline runs one in-process instead; see\n"
            "  'gonio capture --offline --help'). A --plan, --rig or --scene FILE is read\n"
            "  here and sent with the request (at most 16384 bytes); goniod keeps a copy in\n"
            "  the capture directory, which a resume reads; a sent scene names its material\n"
            "  and rig, not files. merl: files are relative to goniod's capture root.\n"
            "  --model: the final fit's model, any RGB\n"
            "  model of 'gonio fit --help' (default abc). --truth SPEC: the reference\n"
            "  material of the in-plane and full-domain errors (on hardware there are none\n"
            "  without it; on the simulator the default is the material it measures). On a\n"
            "  hardware rig --material is a spec that must resolve (nbrdf:, merl:, ...), not\n"
            "  a label: name the sample with --sample. --sample, --operator, --note: kept\n"
            "  with the capture (request.json, setup.json, results.json, the start\n"
            "  document, gonio list). --wait follows the capture to its end, its progress\n"
            "  on stderr (--quiet: none): exit 0 when it completes.\n"
            "  --calibration ID|newest: reduce a counts detector's readings with reference\n"
            "  calibration ID in goniod's calibration root (gonio calibrate), or the newest\n"
            "  valid one for the rig and detector; refused (exit 2) before the first move\n"
            "  when it is missing, expired or of another rig or detector.\n"
            "  --reference-after: the standard read again after the last point (the rig's\n"
            "  sample changer mounts it, else goniod pauses for the operator; gonio resume\n"
            "  goes on) and the samples\n"
            "  reduced with the drift between it and the calibration.\n"
            "  --order adaptive, --budget, --stop-target: as 'gonio capture --offline --help'\n"
            "  says. --check isotropy: after the last point, the isotropy check on a rig\n"
            "  whose profile has a rotation axis (--rig rotating); its verdict is in the\n"
            "  stop document, results.json and --wait's output; a rig without one exits 2.\n"
            "  --check out-of-plane: after the final fit, the in-plane sufficiency check,\n"
            "  on a rig whose profile has an azimuth axis; reported alike.\n"
            PRESCAN_HELP
            "  (default on a Modbus or USB rig: " PRESCAN_STR(CAPTURE_PRESCAN_DEFAULT) ", or one in "
            PRESCAN_STR(CAPTURE_PRESCAN_SHARE) " of a smaller plan's points,\n"
            "  none below 2; none on goniod's simulated rig, which knows its material).\n"
            "  goniod checks the request before it starts anything: a bad plan, scene,\n"
            "  rig, material, model, order, stop, budget, target or truth exits 2 and\n"
            "  creates nothing.\n"
            "  The socket is --socket, else $GONIO_SOCKET, else " GONIO_SOCKET_DEFAULT ".\n");
}

/* Send the capture request req (taken) to goniod on sock and say where it
 * started; with wait, follow it to its end. The exit status. */
static int capture_send(const char *sock, json_t *req, int wait, int quiet)
{
    struct conn c;
    if (conn_open(&c, socket_path(sock)) < 0) {
        json_decref(req);
        return 1;
    }
    int rc = 0;
    if (wait) { /* subscribe first, so not even a quick capture's start is missed */
        json_t *rep = conn_request(&c, json_pack("{s:s}", "cmd", "watch"));
        rc = reply_failed(rep);
        json_decref(rep);
    }
    json_t *rep = NULL;
    if (!rc) {
        rep = conn_request(&c, req);
        rc = reply_failed(rep);
    } else {
        json_decref(req);
    }
    if (!rc) {
        char id[128];
        snprintf(id, sizeof id, "%s", json_string_value(json_object_get(rep, "capture_id")));
        printf("capture %s started in %s\n", id, json_string_value(json_object_get(rep, "dir")));
        fflush(stdout);
        if (wait)
            rc = follow(&c, id, quiet);
    }
    json_decref(rep);
    conn_close(&c);
    return rc;
}

int cmd_capture_daemon(int argc, char **argv)
{
    static const struct option opts[] = {
        SOCKET_OPTS,
        {"plan", required_argument, NULL, 'p'},  {"scene", required_argument, NULL, 's'},
        {"material", required_argument, NULL, 'm'}, {"rig", required_argument, NULL, 'r'},
        {"model", required_argument, NULL, 'M'}, {"order", required_argument, NULL, 'o'},
        {"stop", required_argument, NULL, 'x'},  {"name", required_argument, NULL, 'n'},
        {"truth", required_argument, NULL, 't'}, {"wait", no_argument, NULL, 'w'},
        {"quiet", no_argument, NULL, 'q'},       {"budget", required_argument, NULL, 'B'},
        {"stop-target", required_argument, NULL, 'T'},
        {"prescan", required_argument, NULL, 'P'}, {"sample", required_argument, NULL, 'A'},
        {"operator", required_argument, NULL, 'O'}, {"note", required_argument, NULL, 'N'},
        {"uncalibrated", no_argument, NULL, 'U'}, {"check", required_argument, NULL, 'K'},
        {"calibration", required_argument, NULL, 'C'},
        {"reference-after", no_argument, NULL, 'R'},
        {NULL, 0, NULL, 0},
    };
    static const char *const keys[] = {"plan",  "scene",  "material", "rig",      "model",
                                       "order", "stop",   "name",     "truth",    "sample",
                                       "operator", "note", "check", "calibration"};
    static const char letters[] = "psmrMoxntAONKC";
    enum { N_KEYS = sizeof keys / sizeof keys[0] };
    const char *vals[N_KEYS] = {0}, *sock = NULL;
    double budget = 0, target = 0;
    long long prescan = -1; /* -1: not given, goniod's default */
    int wait = 0, quiet = 0, uncalibrated = 0, reference_after = 0, ch, ignored;
    optind = 1;
    while ((ch = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        const char *at = ch ? strchr(letters, ch) : NULL;
        if (at) {
            vals[at - letters] = optarg;
            continue;
        }
        switch (ch) {
        case 'S': sock = optarg; break;
        case 'w': wait = 1; break;
        case 'q': quiet = 1; break;
        case 'U': uncalibrated = 1; break;
        case 'R': reference_after = 1; break;
        case 'P':
            if (cmd_capture_prescan(optarg, &prescan, &ignored) < 0)
                return 2;
            break;
        case 'B':
        case 'T':
            if (cmd_capture_number(ch == 'B' ? "--budget" : "--stop-target", optarg,
                                   ch == 'B' ? &budget : &target) < 0)
                return 2;
            break;
        case 'h': capture_usage(stdout); return 0;
        default: capture_usage(stderr); return 2;
        }
    }
    if (optind != argc || !vals[0]) {
        fprintf(stderr, optind != argc ? "gonio capture: unexpected argument\n"
                                       : "gonio capture: --plan is required\n");
        capture_usage(stderr);
        return 2;
    }
    struct gonio_err merr = {0};
    if (vals[4] && !fit_model_find_rgb(vals[4], "--model", &merr)) {
        fprintf(stderr, "gonio capture: %s\n", merr.msg);
        return 2;
    }
    if (vals[6] && strcmp(vals[6], "all") && strcmp(vals[6], "converge")) {
        fprintf(stderr, "gonio capture: --stop '%s': use all or converge\n", vals[6]);
        return 2;
    }
    /* A plan, rig or scene named as a file is read here and travels with
     * the request (cli/request_file.h); the rest are names or values. */
    json_t *req = json_pack("{s:s}", "cmd", "capture");
    int rc = 0;
    for (int i = 0; i < N_KEYS && !rc; i++) {
        if (!vals[i])
            continue;
        if (!strcmp(keys[i], "plan") || !strcmp(keys[i], "rig") || !strcmp(keys[i], "scene")) {
            char opt[16];
            snprintf(opt, sizeof opt, "--%s", keys[i]);
            rc = request_file_attach(req, keys[i], opt, vals[i]);
        } else {
            json_object_set_new(req, keys[i], json_string(vals[i]));
        }
    }
    if (budget > 0)
        json_object_set_new(req, "budget", json_real(budget));
    if (target > 0)
        json_object_set_new(req, "stop_target", json_real(target));
    if (prescan >= 0)
        json_object_set_new(req, "prescan", json_integer((json_int_t)prescan));
    if (uncalibrated)
        json_object_set_new(req, "uncalibrated", json_true());
    if (reference_after)
        json_object_set_new(req, "reference_after", json_true());
    if (rc || (rc = request_file_fits(req)) != 0) {
        json_decref(req);
        return rc;
    }
    return capture_send(sock, req, wait, quiet);
}

int cmd_capture_any(int argc, char **argv)
{
    for (int i = 1; i < argc && strcmp(argv[i], "--"); i++)
        if (!strcmp(argv[i], "--offline"))
            return cmd_capture(argc, argv);
    return cmd_capture_daemon(argc, argv);
}
