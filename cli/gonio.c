/* gonio: the operator's command. A thin shell: each subcommand parses its
 * options and calls the libraries. */
#include <stdio.h>
#include <string.h>

#include <gsl/gsl_errno.h>

#include "cli/commands.h"

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
    {"fit", cmd_fit, "fit a model to a capture's samples and write its model file"},
    {"export", cmd_export, "export a material as a MERL .binary table"},
    {"results", cmd_results, "tabulate the results of capture directories"},
    {"train-decoder", cmd_train_decoder, "train the latent model's decoder (docs/latent.md)"},
    {"report", cmd_report, "a study's self-contained HTML report (docs/report.md)"},
    {"plot", cmd_plot, "one figure as SVG or PNG: slices, pareto, bars (docs/report.md)"},
    {"render", cmd_render, "render materials and fitted models on a lit sphere (EXR, PNG)"},
    {"study", cmd_study, "accuracy against rig time: materials x plans x models x scenes"},
};

static void usage(FILE *out)
{
    fprintf(out, "usage: gonio COMMAND [OPTIONS]\n\ncommands:\n");
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        fprintf(out, "  %-14s %s\n", commands[i].name, commands[i].summary);
    fprintf(out, "\n'gonio COMMAND --help' describes a command.\n");
}

int main(int argc, char **argv)
{
    /* A fit that fails is a result to report, never an abort. */
    gsl_set_error_handler_off();
    if (argc < 2) {
        usage(stderr);
        return 2;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h") || !strcmp(argv[1], "help")) {
        usage(stdout);
        return 0;
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (!strcmp(argv[1], commands[i].name))
            return commands[i].run(argc - 1, argv + 1);
    fprintf(stderr, "gonio: unknown command '%s'\n", argv[1]);
    usage(stderr);
    return 2;
}
