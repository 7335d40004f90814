/* gonio: the operator's command. A thin shell: each subcommand parses its
 * options and calls the libraries. */
#include <stdio.h>
#include <string.h>

#include <gsl/gsl_errno.h>

#include "cli/commands.h"
#include "common/version.h"

static const struct {
    const char *name;
    int (*run)(int argc, char **argv);
    const char *summary;
} commands[] = {
    {"plan", cmd_plan, "dry-run a plan: pairs, axis positions, time estimate"},
    {"capture", cmd_capture_any, "run a capture on goniod (--offline: in-process simulated rig)"},
    {"status", cmd_status, "goniod's state and the running capture's progress"},
    {"watch", cmd_watch, "follow the running capture: progress, ETA, results"},
    {"pause", cmd_pause, "pause the running capture at the next point"},
    {"resume", cmd_resume, "continue a paused capture, or resume an interrupted one by id"},
    {"abort", cmd_abort, "stop the running capture, keeping its samples"},
    {"shutdown", cmd_shutdown, "stop goniod"},
    {"home", cmd_home, "home the rig's axes, or one (bring-up, through goniod)"},
    {"move", cmd_move, "move an axis to an angle within its soft limits"},
    {"where", cmd_where, "the axes' encoder positions, drive status and alarms"},
    {"limits", cmd_limits, "drive an axis slowly to its soft limits and back"},
    {"list", cmd_list, "goniod's captures: state, samples, rig time, the resumable ones"},
    {"fit", cmd_fit, "fit a model to a capture's samples and write its model file"},
    {"export", cmd_export, "export a material as a MERL .binary table"},
    {"results", cmd_results, "tabulate the results of capture directories"},
    {"train-decoder", cmd_train_decoder, "train the latent model's decoder (docs/latent.md)"},
    {"report", cmd_report, "a study's self-contained HTML report (docs/report.md)"},
    {"plot", cmd_plot, "one figure as SVG or PNG: slices, pareto, bars (docs/report.md)"},
    {"render", cmd_render, "render materials and fitted models on a lit sphere (EXR, PNG)"},
    {"study", cmd_study, "accuracy against rig time: materials x plans x models x scenes"},
    {"journal", cmd_journal, "check a capture's journal as a resume would, without resuming"},
    {"live", cmd_live, "follow the capture in a browser: a page served on localhost"},
    {"calibrate", cmd_calibrate, "measure dark frames or a reference standard (docs/radiometry.md)"},
    {"recalibrate", cmd_recalibrate, "reduce a capture's raw counts again with another calibration"},
};

#define N_COMMANDS (sizeof commands / sizeof commands[0])

static void usage(FILE *out)
{
    fprintf(out, "usage: gonio COMMAND [OPTIONS]\n       gonio help COMMAND\n"
                 "       gonio --version\n\ncommands:\n");
    for (size_t i = 0; i < N_COMMANDS; i++)
        fprintf(out, "  %-14s %s\n", commands[i].name, commands[i].summary);
    fprintf(out, "\n'gonio COMMAND --help' (or 'gonio help COMMAND') describes a command.\n");
}

static int find(const char *name)
{
    for (size_t i = 0; i < N_COMMANDS; i++)
        if (!strcmp(name, commands[i].name))
            return (int)i;
    return -1;
}

/* Levenshtein distance, for "did you mean": names are short, so the
 * two-row table fits on the stack. */
static size_t distance(const char *a, const char *b)
{
    size_t nb = strlen(b), prev[64], cur[64];
    if (nb >= 64)
        return (size_t)-1;
    for (size_t j = 0; j <= nb; j++)
        prev[j] = j;
    for (size_t i = 1; a[i - 1]; i++) {
        cur[0] = i;
        for (size_t j = 1; j <= nb; j++) {
            size_t sub = prev[j - 1] + (a[i - 1] != b[j - 1]);
            size_t del = prev[j] + 1, ins = cur[j - 1] + 1;
            cur[j] = sub < del ? (sub < ins ? sub : ins) : (del < ins ? del : ins);
        }
        memcpy(prev, cur, (nb + 1) * sizeof cur[0]);
    }
    return prev[nb];
}

/* The unknown command's line, with the nearest command when it is within
 * two edits (a typo, not another word). */
static int unknown(const char *name)
{
    size_t best = 3;
    const char *guess = NULL;
    for (size_t i = 0; i < N_COMMANDS; i++) {
        size_t d = distance(name, commands[i].name);
        if (d < best) {
            best = d;
            guess = commands[i].name;
        }
    }
    if (guess)
        fprintf(stderr, "gonio: unknown command '%s'; did you mean '%s'?\n", name, guess);
    else
        fprintf(stderr, "gonio: unknown command '%s'\n", name);
    fprintf(stderr, "'gonio --help' lists the commands.\n");
    return 2;
}

/* Run command i with argv[0] = "gonio NAME", so that getopt's own messages
 * read "gonio NAME: unrecognized option ..." like every other error. */
static int run(int i, int argc, char **argv)
{
    char prog[64];
    snprintf(prog, sizeof prog, "gonio %s", commands[i].name);
    argv[0] = prog;
    return commands[i].run(argc, argv);
}

int main(int argc, char **argv)
{
    /* A fit that fails is a result to report, never an abort. */
    gsl_set_error_handler_off();
    if (argc < 2) {
        fprintf(stderr, "gonio: a command is required\n");
        usage(stderr);
        return 2;
    }
    if (!strcmp(argv[1], "--version")) {
        gonio_print_version(stdout, "gonio");
        return 0;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") ||
        (!strcmp(argv[1], "help") && argc == 2)) {
        usage(stdout);
        return 0;
    }
    if (!strcmp(argv[1], "help")) {
        /* gonio help CMD is gonio CMD --help, word for word. */
        int i = find(argv[2]);
        if (i < 0)
            return unknown(argv[2]);
        char *help_argv[] = {argv[2], "--help", NULL};
        return run(i, 2, help_argv);
    }
    int i = find(argv[1]);
    return i < 0 ? unknown(argv[1]) : run(i, argc - 1, argv + 1);
}
