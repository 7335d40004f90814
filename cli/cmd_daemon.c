/* The gonio commands that talk to goniod over its control socket
 * (docs/protocol.md): capture (without --offline), status, watch, pause,
 * resume, abort, shutdown. Errors from the daemon are printed as it gives
 * them; exit status 1 for a daemon error, 2 for bad usage. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <jansson.h>

#include "capture/capture.h"
#include "cli/commands.h"
#include "cli/conn.h"
#include "cli/progress.h"
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
        printf("  fit %s%s: plan log error %.4f, relative RMSE %.4f\n",
               json_string_value(json_object_get(res, "model")),
               json_is_true(json_object_get(res, "converged")) ? "" : " (did not converge)",
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
            conn_reply_failed(d);
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
    printf("capture %s: %s, %zu/%zu points, rig time %s%s%s\n",
           json_string_value(json_object_get(cap, "capture_id")), state ? state : "?",
           jsize(cap, "points_done"), jsize(cap, "points_total"), rig, est, eta);
    const char *msg = json_string_value(json_object_get(cap, "message"));
    if (msg)
        printf("  %s\n", msg);
}

/* Options every daemon command takes. */
#define SOCKET_OPTS {"socket", required_argument, NULL, 'S'}, {"help", no_argument, NULL, 'h'}

static int simple(int argc, char **argv, const char *cmd, const char *usage_args,
                  const char *help)
{
    static const struct option opts[] = {SOCKET_OPTS, {"json", no_argument, NULL, 'j'},
                                         {NULL, 0, NULL, 0}};
    const char *sock = NULL;
    int json_out = 0, ch;
    optind = 1;
    while ((ch = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        switch (ch) {
        case 'S': sock = optarg; break;
        case 'j': json_out = 1; break;
        case 'h': printf("usage: gonio %s %s[--socket PATH]\n  %s\n", cmd, usage_args, help);
                  return 0;
        default: fprintf(stderr, "usage: gonio %s %s[--socket PATH]\n", cmd, usage_args);
                 return 2;
        }
    }
    const char *arg = NULL;
    int takes_arg = usage_args[0] != '\0' && strcmp(usage_args, "[--json] ");
    if (takes_arg && optind < argc)
        arg = argv[optind++];
    if (optind != argc) {
        fprintf(stderr, "gonio %s: unexpected argument '%s'\n", cmd, argv[optind]);
        return 2;
    }
    struct conn c;
    if (conn_open(&c, conn_socket_path(sock)) < 0)
        return 1;
    json_t *req = json_pack("{s:s}", "cmd", cmd);
    if (arg)
        json_object_set_new(req, "capture_id", json_string(arg));
    json_t *rep = conn_request(&c, req);
    int rc = conn_reply_failed(rep);
    if (!rc && !strcmp(cmd, "status")) {
        if (json_out) {
            json_object_del(rep, "id");
            char *s = json_dumps(rep, JSON_COMPACT);
            printf("%s\n", s);
            free(s);
        } else {
            const char *state = json_string_value(json_object_get(rep, "state"));
            printf("goniod %s", state);
            if (strcmp(state, "idle"))
                printf(": capture %s, %lld/%lld points, rig time %.1f s",
                       json_string_value(json_object_get(rep, "capture_id")),
                       (long long)json_integer_value(json_object_get(rep, "points_done")),
                       (long long)json_integer_value(json_object_get(rep, "points_total")),
                       jreal(rep, "rig_time_s"));
            printf("\n");
            show_capture(json_object_get(rep, "capture"));
            json_t *fe = json_object_get(rep, "fit_error");
            if (json_is_object(fe))
                printf("fit (%s, %lld samples): log error %.4f, relative RMSE %.4f\n",
                       json_string_value(json_object_get(fe, "capture_id")),
                       (long long)json_integer_value(json_object_get(fe, "samples")),
                       jreal(fe, "log_error"), jreal(fe, "rel_rmse"));
            /* the daemon's release, as goniod --version prints it: the
             * one that answers may differ from this gonio's (an older one
             * does not say) */
            const char *release = json_string_value(json_object_get(rep, "release"));
            if (release)
                printf("goniod %s\n", release);
        }
    } else if (!rc) {
        const char *id = json_string_value(json_object_get(rep, "capture_id"));
        printf("goniod: %s%s%s\n", cmd, id ? " " : "", id ? id : "");
    }
    json_decref(rep);
    conn_close(&c);
    return rc;
}

int cmd_status(int argc, char **argv)
{
    return simple(argc, argv, "status", "[--json] ",
                  "state (idle, running, paused), capture id, points done, rig time, last "
                  "fit error, goniod's release");
}

int cmd_pause(int argc, char **argv)
{
    return simple(argc, argv, "pause", "", "pause the capture at the next point boundary");
}

int cmd_resume(int argc, char **argv)
{
    return simple(argc, argv, "resume", "[CAPTURE-ID] ",
                  "continue the paused capture, or (idle daemon) resume an interrupted "
                  "capture from its journal");
}

int cmd_abort(int argc, char **argv)
{
    return simple(argc, argv, "abort", "",
                  "stop the capture at the next point boundary; its samples are kept");
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
    if (conn_open(&c, conn_socket_path(sock)) < 0)
        return 1;
    json_t *rep = conn_request(&c, json_pack("{s:s}", "cmd", "watch"));
    int rc = conn_reply_failed(rep);
    json_decref(rep);
    if (!rc)
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
            "                     [--name ID] [--wait] [--quiet] [--socket PATH]\n"
            "  Starts a capture on goniod (--offline runs one in-process instead; see\n"
            "  'gonio capture --offline --help'). Files are relative to goniod's capture\n"
            "  root. --model: the final fit's model, any RGB model of 'gonio fit --help'\n"
            "  (default abc). --truth SPEC: the reference material of the in-plane and\n"
            "  full-domain errors (on hardware there are none without it; on the simulator\n"
            "  the default is the material it measures). --wait follows the capture to its\n"
            "  end, its progress on stderr (--quiet: none): exit 0 when it completes.\n"
            "  --order adaptive, --budget, --stop-target: as 'gonio capture --offline --help'\n"
            "  says.\n"
            PRESCAN_HELP
            "  (default on a Modbus or USB rig: " PRESCAN_STR(CAPTURE_PRESCAN_DEFAULT) ", or one in "
            PRESCAN_STR(CAPTURE_PRESCAN_SHARE) " of a smaller plan's points,\n"
            "  none below 2; none on goniod's simulated rig, which knows its material).\n"
            "  goniod checks the request before it starts anything: a bad plan, scene,\n"
            "  rig, material, model, order, stop, budget, target or truth exits 2 and\n"
            "  creates nothing.\n"
            "  The socket is --socket, else $GONIO_SOCKET, else " GONIO_SOCKET_DEFAULT ".\n");
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
        {"prescan", required_argument, NULL, 'P'}, {NULL, 0, NULL, 0},
    };
    static const char *const keys[] = {"plan", "scene", "material", "rig",
                                       "model", "order", "stop", "name", "truth"};
    static const char letters[] = "psmrMoxnt";
    const char *vals[9] = {0}, *sock = NULL;
    double budget = 0, target = 0;
    long long prescan = -1; /* -1: not given, goniod's default */
    int wait = 0, quiet = 0, ch, ignored;
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
    struct conn c;
    if (conn_open(&c, conn_socket_path(sock)) < 0)
        return 1;
    int rc = 0;
    if (wait) { /* subscribe first, so not even a quick capture's start is missed */
        json_t *rep = conn_request(&c, json_pack("{s:s}", "cmd", "watch"));
        rc = conn_reply_failed(rep);
        json_decref(rep);
    }
    json_t *rep = NULL;
    if (!rc) {
        json_t *req = json_pack("{s:s}", "cmd", "capture");
        for (int i = 0; i < 9; i++)
            if (vals[i])
                json_object_set_new(req, keys[i], json_string(vals[i]));
        if (budget > 0)
            json_object_set_new(req, "budget", json_real(budget));
        if (target > 0)
            json_object_set_new(req, "stop_target", json_real(target));
        if (prescan >= 0)
            json_object_set_new(req, "prescan", json_integer((json_int_t)prescan));
        rep = conn_request(&c, req);
        rc = conn_reply_failed(rep);
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

int cmd_capture_any(int argc, char **argv)
{
    for (int i = 1; i < argc && strcmp(argv[i], "--"); i++)
        if (!strcmp(argv[i], "--offline"))
            return cmd_capture(argc, argv);
    return cmd_capture_daemon(argc, argv);
}
