/* gonio journal check DIR: what a resume of the capture in DIR would find
 * in its journal, without resuming: every record's format, chained checksum
 * and values (journal/journal.h), then each against its plan point in
 * DIR/plan.json, the axes within the rig's in-position band
 * (capture/journal_plan.h). */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "capture/journal_plan.h"
#include "cli/commands.h"
#include "journal/journal.h"
#include "rig/rig.h"

static void usage(FILE *out)
{
    fprintf(out,
            "usage: gonio journal check DIR [--rig NAME|PATH]\n"
            "  Check the journal DIR/samples.csv as a resume would, without resuming:\n"
            "  each record's fields, its checksum (chained to the record before it),\n"
            "  its values (finite, rig time never negative nor going back), and that it\n"
            "  names a point of DIR/plan.json, no point twice, measured at that point's\n"
            "  axes within the rig's in-position band. Exit 0 when a resume would take\n"
            "  the journal, 2 with the line and what is wrong otherwise.\n"
            "  --rig NAME|PATH: the rig profile whose in-position band applies (default:\n"
            "  the band setup.json recorded, else the profile it names, else the default)\n");
}

/* The rig profile for the band: --rig, else setup.json's rig (the band it
 * recorded, else its profile by name when such a profile exists), else the
 * default. *from says which. */
static int band_rig(const char *dir, const char *opt, struct rig_profile *rig, const char **from,
                    struct gonio_err *err)
{
    if (opt) {
        *from = "--rig";
        return rig_profile_load(opt, rig, err);
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/setup.json", dir);
    json_t *setup = json_load_file(path, 0, NULL);
    json_t *was = json_object_get(setup, "rig");
    const char *name = json_string_value(json_object_get(was, "name"));
    double band = json_number_value(json_object_get(was, "in_position_deg"));
    struct gonio_err ignored;
    int rc = name && !strchr(name, '/') ? rig_profile_load(name, rig, &ignored) : -1;
    if (band > 0) {
        if (rc < 0)
            rig_profile_default(rig);
        rig->mech.in_position_deg = band;
        rc = 0;
    }
    json_decref(setup);
    *from = "setup.json's rig";
    if (rc == 0)
        return 0;
    *from = "the default rig profile";
    rig_profile_default(rig);
    return 0;
}

static int check(const char *dir, const char *rig_opt)
{
    char journal_path[4096], plan_path[4096];
    snprintf(journal_path, sizeof journal_path, "%s/samples.csv", dir);
    snprintf(plan_path, sizeof plan_path, "%s/plan.json", dir);
    struct gonio_err err = {0};
    struct journal_sample *s = NULL;
    struct plan_point *points = NULL;
    size_t n = 0, count = 0;
    struct journal_info info;
    struct rig_profile rig;
    const char *from;
    int rc = journal_read_info(journal_path, &s, &n, &info, &err);
    if (rc == 0)
        rc = journal_plan_read(plan_path, &points, &count, &err);
    if (rc == 0)
        rc = band_rig(dir, rig_opt, &rig, &from, &err);
    if (rc == 0)
        rc = journal_plan_check(journal_path, s, n, &(struct journal_plan){.points = points,
                                .count = count}, rig.mech.in_position_deg, &err);
    if (rc == 0) {
        printf("%s: %zu records of %zu plan points, %s; each at its plan point within %g deg "
               "(%s), no point twice\n",
               journal_path, n, count, info.raw       ? "checksums chained"
               : info.chained ? "checksums chained, without raw columns"
                              : "unchained format",
               rig.mech.in_position_deg, from);
        if (info.torn_bytes)
            printf("%s: a torn last record (%zu bytes), which a resume cuts off\n", journal_path,
                   info.torn_bytes);
    } else {
        fprintf(stderr, "gonio journal check: %s\n", err.msg);
    }
    free(s);
    free(points);
    return rc < 0 ? gonio_exit_status(rc) : 0;
}

int cmd_journal(int argc, char **argv)
{
    static const struct option opts[] = {{"rig", required_argument, NULL, 'r'},
                                         {"help", no_argument, NULL, 'h'},
                                         {NULL, 0, NULL, 0}};
    const char *rig = NULL;
    int c;
    while ((c = getopt_long(argc, argv, "r:h", opts, NULL)) != -1) {
        switch (c) {
        case 'r': rig = optarg; break;
        case 'h': usage(stdout); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (argc - optind != 2 || strcmp(argv[optind], "check")) {
        fprintf(stderr, "%s: expected 'check DIR'\n", argv[0]);
        usage(stderr);
        return 2;
    }
    return check(argv[optind + 1], rig);
}
