/* gonio recalibrate DIR --calibration ID: a capture's raw counts reduced
 * again with another calibration and refitted, into a new directory
 * (capture_recalibrate, docs/radiometry.md "Recalibration"). */
#include <getopt.h>
#include <stdio.h>
#include <string.h>

#include "capture/capture.h"
#include "cli/commands.h"

static void usage(FILE *out)
{
    fprintf(out,
            "usage: gonio recalibrate DIR --calibration ID [--calibrations ROOT] [-o OUT]\n"
            "  Reduce the raw counts journalled in capture DIR again with reference\n"
            "  calibration ID of ROOT (default: calibrations) and refit with the capture's\n"
            "  model, into OUT (default DIR/recalibrated-ID): samples and model equal those\n"
            "  of the same capture taken with that calibration. DIR is only read.\n");
}

int cmd_recalibrate(int argc, char **argv)
{
    static const struct option longopts[] = {
        {"calibration", required_argument, NULL, 'c'},
        {"calibrations", required_argument, NULL, 'C'},
        {"out", required_argument, NULL, 'o'},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    const char *id = NULL, *root = "calibrations", *out = NULL;
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "o:h", longopts, NULL)) != -1) {
        switch (c) {
        case 'c': id = optarg; break;
        case 'C': root = optarg; break;
        case 'o': out = optarg; break;
        case 'h': usage(stdout); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (optind != argc - 1 || !id) {
        fprintf(stderr, "gonio recalibrate: a capture DIR and --calibration ID are required\n");
        usage(stderr);
        return 2;
    }
    const char *dir = argv[optind];
    char def[4200];
    if (!out) {
        snprintf(def, sizeof def, "%s/recalibrated-%s", dir, id);
        out = def;
    }
    struct gonio_err err = {0};
    int rc = capture_recalibrate(dir, root, id, out, &err);
    if (rc < 0) {
        fprintf(stderr, "gonio recalibrate: %s\n", err.msg[0] ? err.msg : gonio_strerror(rc));
        return gonio_exit_status(rc);
    }
    printf("%s\n", out);
    return 0;
}
