/* gonio capture --offline: a capture against the in-process simulated rig,
 * with the same engine goniod runs. */
#include <getopt.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "cli/interrupt.h"
#include "cli/progress.h"
#include "capture/capture.h"
#include "fit/models.h"
#include "sim_source/sim_source.h"

static void usage(FILE *out)
{
    fprintf(out,
            "usage: gonio capture --offline --scene NAME|FILE --plan NAME|FILE --out DIR\n"
            "                     [--material SPEC] [--model NAME] [--rig NAME|FILE]\n"
            "                     [--order travel|progressive|as-written|greedy|adaptive]\n"
            "                     [--stop all|converge] [--budget MINUTES]\n"
            "                     [--stop-target LOG_ERR] [--truth SPEC] [--prescan N]\n"
            "                     [--calibration ID|newest --calibrations ROOT]\n"
            "                     [--uncalibrated] [--check CHECK[,CHECK]] [--quiet]\n"
            "                     [--reference-after]\n"
            "                     [--sample NAME] [--operator NAME] [--note TEXT]\n"
            "  --sample, --operator, --note: the sample's name, who ran the capture and a\n"
            "  note, recorded in setup.json and results.json (a resume keeps the first).\n"
            "  --uncalibrated: a detector that gives counts is captured without a\n"
            "  calibration: the counts are journalled, nothing is fitted (without it such\n"
            "  a capture is refused, exit 2, before the first move).\n"
            "  --material overrides the scene's material: nbrdf:NAME, merl:FILE, abc:NAME,\n"
            "  sgd:NAME, builtin:NAME, spectral:NAME, analytic:NAME, standard:NAME (a\n"
            "  reflectance standard, docs/radiometry.md) or default. DIR receives\n"
            "  plan.json, setup.json, samples.csv and results.json; running again on the same\n"
            "  DIR resumes the capture (of the same plan, scene, material and rig only).\n"
            "  --truth: the reference of the in-plane and full-domain errors (default: the\n"
            "  material the simulated rig measures).\n"
            "  --model: the final fit's model, any RGB model of 'gonio fit --help' (default\n"
            "  abc); every model also writes DIR/NAME.model (gonio fit's model file).\n"
            "  --stop converge ends the capture once the streaming ABC fit has converged\n"
            "  (the plan's stop tolerances, or the defaults of docs/fitting.md); --stop all\n"
            "  measures every point whatever the plan says.\n"
            "  --order adaptive: the plan's pairs are a pool the capture chooses from, each\n"
            "  next pair where the samples so far say it pays most (docs/adaptive.md; plan\n"
            "  inplane-1deg is such a pool). It stops at --budget MINUTES of rig time, once\n"
            "  its predicted full-domain log error of the model is at most --stop-target,\n"
            "  with --stop converge once more rig time would buy too little, or when the\n"
            "  pool is exhausted. A resume keeps the model, budget, target and stop rule.\n"
            "  --calibrations ROOT: reduce a counts detector's readings to BRDF with an\n"
            "  uncertainty as they are measured, with the reference calibration\n"
            "  --calibration ID (default newest: the newest valid one for the rig and\n"
            "  detector) in ROOT (gonio calibrate, docs/radiometry.md); a calibration\n"
            "  that is missing, expired, of another rig or detector, or without the\n"
            "  rig's integration is refused before the first move (exit 2).\n"
            "  --reference-after: after the last point the standard is read again (the\n"
            "  simulated rig's sample changer mounts it) and the samples are reduced with\n"
            "  the drift interpolated in rig time between it and the calibration\n"
            "  (docs/radiometry.md, \"Drift\").\n"
            "  --check isotropy: after the last point, re-measure a few glossy pairs with\n"
            "  the sample turned about its normal and say whether it is isotropic, as the\n"
            "  in-plane premise assumes (docs/checks.md); needs a rig profile with a\n"
            "  rotation axis (--rig rotating). --check out-of-plane: after the final fit,\n"
            "  measure a few pairs out of the plane of incidence and their in-plane\n"
            "  counterparts and say whether the model fitted in the plane predicts them\n"
            "  (docs/checks.md); needs a rig profile with an azimuth axis.\n"
            PRESCAN_HELP
            "  (default here: none, the scene's estimate knows its material).\n"
            "  Progress goes to stderr (a bar on a terminal) unless --quiet. SIGINT or\n"
            "  SIGTERM ends the capture after the point in progress: the journal is kept,\n"
            "  the same command resumes it, the exit status is 130.\n");
}

/* The offline capture's display and its interrupt. */
struct offline {
    struct progress bar;
    size_t done, total;
    int pool; /* adaptive: total is the pool's size */
};

static void on_progress(void *user, const struct capture_progress *p)
{
    struct offline *o = user;
    if (p->done == p->already_done && p->already_done > 0 && o->total == 0)
        progress_note(&o->bar, "resuming: %zu of %zu points in the journal", p->already_done,
                      p->total);
    o->done = p->done;
    o->total = p->total;
    o->pool = p->policy != NULL;
    const struct adaptive_status *a = p->policy;
    progress_show(&o->bar, &(struct progress_state){
                               .done = p->done, .total = p->total, .unit = "points",
                               .rig_time_s = p->rig_time_s, .estimate_s = p->estimate_s,
                               .eta_s = p->eta_s, .fit_error = p->fit_log_error,
                               .pool = a != NULL,
                               .predicted = a ? a->predicted_error : NAN,
                               .predicted_next = a ? a->predicted_next : NAN,
                               .predicted_next_s = a ? a->predicted_next_s : NAN});
}

static enum capture_control on_control(void *user)
{
    (void)user;
    return interrupt_signal() ? CAPTURE_ABORT : CAPTURE_GO;
}

static void print_errors(const char *domain, const struct brdf_errors *e)
{
    printf("  %-8s log error %.4f   relative RMSE %.4f   (%zu pairs)\n", domain, e->log,
           e->rel_rmse, e->n_used);
}

int cmd_capture_prescan(const char *text, long long *points, int *prescan)
{
    char *end;
    struct gonio_err err = {0};
    *points = strtoll(text, &end, 10);
    if (end == text || *end) {
        fprintf(stderr, "gonio capture: --prescan '%s': a number of points\n", text);
        return -1;
    }
    if (capture_prescan_option("--prescan", *points, prescan, &err) < 0) {
        fprintf(stderr, "gonio capture: %s\n", err.msg);
        return -1;
    }
    return 0;
}

int cmd_capture_number(const char *opt, const char *text, double *out)
{
    char *end;
    *out = strtod(text, &end);
    if (end == text || *end || !isfinite(*out) || *out <= 0) {
        fprintf(stderr, "gonio capture: %s '%s': a positive number\n", opt, text);
        return -1;
    }
    return 0;
}

/* The adaptive order: why it stopped, what it predicts, what deciding cost. */
static void print_policy(const struct capture_summary *s)
{
    printf("  adaptive: stopped (%s) after %zu samples; predicted full-domain log error of "
           "%s %.4f\n",
           s->stop_reason, s->samples, s->policy.model, s->policy.predicted_error);
    printf("  decisions %zu, %.3f s mean, %.3f s max; the rig waited %.3f s for them\n",
           s->decisions, s->decision_mean_s, s->decision_max_s, s->decision_wait_s);
}

/* What the capture measured, how the fit went and what the checks said. */
static void print_summary(const char *out_dir, const struct capture_summary *s)
{
    printf("capture %s: plan %s, material %s, model %s\n", out_dir, s->plan, s->material,
           s->model);
    if (s->not_fitted[0]) { /* --uncalibrated: counts journalled, no fit to show */
        printf("  %zu samples, rig time %.1f s (move %.1f, settle %.1f, integration %.1f)\n"
               "  auto-ranging: %zu readings taken again, %zu dark frames\n"
               "  not fitted: %s\n",
               s->samples, s->rig_time_s, s->move_s, s->settle_s, s->integration_s, s->retakes,
               s->darks, s->not_fitted);
        return;
    }
    printf("  %zu samples, rig time %.1f s (move %.1f, settle %.1f, integration %.1f), fit "
           "%.3f s%s\n",
           s->samples, s->rig_time_s, s->move_s, s->settle_s, s->integration_s, s->fit_time_s,
           s->converged ? "" : " (fit did not converge)");
    if (s->paused_s > 0)
        printf("  paused %.1f s of rig clock (not in the rig time)\n", s->paused_s);
    char status[400];
    fit_status_line(&s->status, status, sizeof status);
    printf("  fit status: %s\n", status);
    const struct fit_model_kind *kind = fit_model_find(s->model);
    if (s->saturated)
        printf("  %zu saturated readings, fitted %s\n", s->saturated,
               kind && fit_model_censors(kind, FIT_SATURATED_DEFAULT)
                   ? "as lower bounds (censored)"
                   : "at their clipped values (lower bounds of the truth)");
    if (s->adaptive)
        print_policy(s);
    else if (!strcmp(s->stop_reason, "converged"))
        printf("  stopped on convergence after %zu samples\n", s->samples);
    if (s->model_file[0])
        printf("  model file %s/%s\n", out_dir, s->model_file);
    if (s->warning[0]) /* abc-prior: too few samples to pin the lobe */
        printf("  %s\n", s->warning);
    print_errors("plan", &s->err_plan);
    if (s->has_truth) {
        printf("  against %s:\n", s->truth);
        print_errors("in-plane", &s->err_inplane);
        print_errors("full", &s->err_full);
    }
    if (s->has_isotropy)
        printf("  isotropy check: %s (%s; %zu pairs, %.0f s of rig time, %.1f%% of the "
               "capture's)\n",
               s->isotropy.verdict, s->isotropy.why, s->isotropy.pairs, s->isotropy.rig_time_s,
               s->rig_time_s > 0 ? 100.0 * s->isotropy.rig_time_s / s->rig_time_s : 0.0);
    if (s->has_oop)
        printf("  out-of-plane check: in-plane %s (%s; %zu pairs, %.0f s of rig time, %.1f%% "
               "of the capture's)\n",
               s->oop.verdict, s->oop.why, s->oop.pairs, s->oop.rig_time_s,
               s->rig_time_s > 0 ? 100.0 * s->oop.rig_time_s / s->rig_time_s : 0.0);
    if (s->auto_chosen[0]) /* --model auto: what it chose, and what the checks decided */
        printf("  auto: %s%s%s\n", s->auto_chosen, s->auto_why[0] ? "; " : "", s->auto_why);
}

int cmd_capture(int argc, char **argv)
{
    static const struct option opts[] = {
        {"offline", no_argument, NULL, 'O'},  {"scene", required_argument, NULL, 's'},
        {"plan", required_argument, NULL, 'p'}, {"material", required_argument, NULL, 'm'},
        {"model", required_argument, NULL, 'M'}, {"rig", required_argument, NULL, 'r'},
        {"order", required_argument, NULL, 'o'}, {"out", required_argument, NULL, 'd'},
        {"quiet", no_argument, NULL, 'q'},     {"help", no_argument, NULL, 'h'},
        {"stop", required_argument, NULL, 'S'}, {"truth", required_argument, NULL, 't'},
        {"budget", required_argument, NULL, 'B'}, {"stop-target", required_argument, NULL, 'T'},
        {"prescan", required_argument, NULL, 'P'},
        {"uncalibrated", no_argument, NULL, 'U'},
        {"calibration", required_argument, NULL, 'C'},
        {"calibrations", required_argument, NULL, 'R'}, {"check", required_argument, NULL, 'K'},
        {"sample", required_argument, NULL, 'n'}, {"operator", required_argument, NULL, 'w'},
        {"note", required_argument, NULL, 'N'},
        {"reference-after", no_argument, NULL, 'A'},
        {NULL, 0, NULL, 0},
    };
    struct capture_config cfg = {.model = "abc"};
    long long points;
    const char *scene = NULL;
    struct gonio_err check_err = {0};
    int offline = 0, cal_named = 0, c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        switch (c) {
        case 'O': offline = 1; break;
        case 's': scene = optarg; break;
        case 'p': cfg.plan = optarg; break;
        case 'm': cfg.material = optarg; break;
        case 'M': cfg.model = optarg; break;
        case 'r': cfg.rig = optarg; break;
        case 'o': cfg.order = optarg; break;
        case 'd': cfg.out_dir = optarg; break;
        case 'S': cfg.stop = optarg; break;
        case 't': cfg.truth = optarg; break;
        case 'q': cfg.quiet = 1; break;
        case 'U': cfg.uncalibrated = 1; break;
        case 'A': cfg.reference_after = 1; break;
        case 'n': cfg.sample = optarg; break;
        case 'w': cfg.operator_name = optarg; break;
        case 'N': cfg.note = optarg; break;
        case 'C':
            cfg.calibration = strcmp(optarg, "newest") ? optarg : NULL;
            cal_named = 1;
            break;
        case 'R': cfg.calibrations = optarg; break;
        case 'P':
            if (cmd_capture_prescan(optarg, &points, &cfg.prescan) < 0)
                return 2;
            break;
        case 'B':
        case 'T':
            if (cmd_capture_number(c == 'B' ? "--budget" : "--stop-target", optarg,
                             c == 'B' ? &cfg.budget_min : &cfg.stop_target) < 0)
                return 2;
            break;
        case 'K':
            if (capture_checks_parse("--check", optarg, &cfg.checks, &check_err) < 0) {
                fprintf(stderr, "gonio capture: %s\n", check_err.msg);
                return 2;
            }
            break;
        case 'h': usage(stdout); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (optind != argc || !scene || !cfg.plan || !cfg.out_dir) {
        fprintf(stderr, "gonio capture: --scene, --plan and --out are required\n");
        usage(stderr);
        return 2;
    }
    if (cal_named && !cfg.calibrations) {
        fprintf(stderr, "gonio capture: --calibration needs --calibrations ROOT, the folder "
                        "gonio calibrate wrote it to\n");
        return 2;
    }
    if (!offline) {
        fprintf(stderr, "gonio capture: only --offline captures exist in this build "
                        "(no goniod to talk to yet)\n");
        return 2;
    }
    struct capture_summary s;
    struct gonio_err err = {0};
    struct offline o = {.total = 0};
    progress_init(&o.bar, "capture", cfg.quiet);
    struct capture_hooks hooks = {.on_progress = on_progress, .control = on_control, .user = &o};
    cfg.progress_fit = !cfg.quiet; /* the live fit error on the bar */
    interrupt_catch();
    int rc = sim_source_capture(scene, &cfg, &hooks, &s, &err);
    progress_end(&o.bar);
    if (rc < 0) {
        fprintf(stderr, "gonio capture: %s\n", err.msg[0] ? err.msg : gonio_strerror(rc));
        return gonio_exit_status(rc);
    }
    if (!strcmp(s.stop_reason, "aborted")) {
        const char *sig = interrupt_signal() == SIGTERM ? "SIGTERM" : "SIGINT";
        if (o.total == 0)
            fprintf(stderr, "gonio capture: %s before the first point; nothing written\n", sig);
        else
            fprintf(stderr,
                    "gonio capture: %s: stopped after %zu %s %zu%s, all in %s/samples.csv; "
                    "run the same command again to resume\n",
                    sig, o.done, o.pool ? "points from a pool of" : "of", o.total,
                    o.pool ? "" : " points", cfg.out_dir);
        return INTERRUPT_EXIT;
    }
    print_summary(cfg.out_dir, &s);
    return 0;
}
