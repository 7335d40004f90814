/* gonio calibrate dark|stray|reference|beam: a calibration measured on goniod's rig
 * (cmd_calibrate_daemon.c), or with --offline on the in-process simulated
 * rig, and written as ROOT/ID (capture/calibration.h, docs/radiometry.md
 * "Calibrations"). */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <jansson.h>

#include "capture/cal_documents.h"
#include "capture/calibration.h"
#include "capture/calibration_beam.h"
#include "cli/commands.h"
#include "common/paths.h"
#include "sim_source/sim_source.h"

static void usage(FILE *out)
{
    fprintf(out,
            "usage: gonio calibrate dark|stray|reference [--name ID] [--socket PATH] [options]\n"
            "       gonio calibrate dark --offline --scene NAME|FILE --out ROOT [--rig NAME|FILE]\n"
            "                       [--integration SECONDS]... [--ladder] [--frames N]\n"
            "                       [--valid MINUTES]\n"
            "       gonio calibrate reference --offline --scene NAME|FILE --plan NAME|FILE\n"
            "                       --out ROOT [--standard NAME|FILE] [--repeats N] [--dark ID]\n"
            "                       [--rig NAME|FILE] [--valid MINUTES]\n"
            "                       [--spot overfilled|underfilled] [--stray ID|newest]\n"
            "       gonio calibrate stray --offline --scene NAME|FILE --plan NAME|FILE\n"
            "                       --out ROOT [--repeats N] [--dark ID] [--rig NAME|FILE]\n"
            "       gonio calibrate beam --offline --scene NAME|FILE --out ROOT [--repeats N]\n"
            "                       [--integration SECONDS] [--dark ID] [--stray ID|newest]\n"
            "                       [--rig NAME|FILE]\n"
            "  dark: the shutter closed, N frames (default 16) at the rig profile's\n"
            "  integration and at each --integration, with --ladder at every rung of its\n"
            "  auto-ranging ladder too (a capture with it ranges; without, it stays at\n"
            "  the fixed integration); valid 60 minutes by default.\n"
            "  reference: the standard (default spectralon-99, configs/standards/) in the\n"
            "  sample's place, read --repeats times (default 4) at each of the plan's\n"
            "  points, with the dark --dark ID or the newest valid one in ROOT; valid 480\n"
            "  minutes by default; --stray: the stray light it and the captures with it\n"
            "  subtract (taken with the same dark).\n"
            "  stray: the sample removed (on the simulated rig a light trap, the material\n"
            "  'trap'), read as the reference is, before it.\n"
            "  beam (the absolute method): the sample removed, the arm facing the source\n"
            "  (the rig profile's beam section: aperture, distance, attenuator), the\n"
            "  direct beam read --repeats times (default 16) at --integration (default\n"
            "  the rig profile's), which the dark must cover; valid 480 minutes.\n"
            "  Writes ROOT/ID (calibration.json, frames.csv) and prints the id, by\n"
            "  which a capture names it. --spot: how the detector\n"
            "  sees the lit spot, for a reference interpolated between its geometries\n"
            "  (default overfilled: the simulated rig's signal goes with cos theta_i).\n"
            "  Without --offline goniod measures it on its rig into its calibration root\n"
            "  (--scene and --out are the offline rig's; one --integration at most),\n"
            "  where a capture names it (gonio capture --calibration ID|newest): a rig\n"
            "  without a shutter, and a reference or stray light on a rig without a\n"
            "  sample changer, pause for the operator (cover the detector, mount the\n"
            "  standard, remove the sample), who continues with gonio resume (a\n"
            "  changer swaps the standard or the light trap in, the sample back after);\n"
            "  it prints\n"
            "  what goniod asks on stderr and the id on stdout once complete. A run\n"
            "  stopped early (abort, goniod killed) keeps its frames: gonio resume ID.\n");
}

struct opts {
    const char *scene, *rig, *root, *plan, *standard, *dark, *name, *sock, *stray;
    int standard_given;
    double integrations[CAL_MAX_INTEGRATIONS];
    size_t n_int;
    long frames, repeats;
    int frames_given, repeats_given;
    double valid_min;
    int offline;
    int underfilled;
    int ladder;
};

static int parse(int argc, char **argv, struct opts *o)
{
    static const struct option longopts[] = {
        {"offline", no_argument, NULL, 'O'},   {"scene", required_argument, NULL, 's'},
        {"rig", required_argument, NULL, 'r'}, {"out", required_argument, NULL, 'd'},
        {"plan", required_argument, NULL, 'p'}, {"standard", required_argument, NULL, 'S'},
        {"dark", required_argument, NULL, 'D'}, {"integration", required_argument, NULL, 'i'},
        {"frames", required_argument, NULL, 'f'}, {"repeats", required_argument, NULL, 'n'},
        {"valid", required_argument, NULL, 'v'}, {"help", no_argument, NULL, 'h'},
        {"spot", required_argument, NULL, 'F'}, {"name", required_argument, NULL, 'N'},
        {"socket", required_argument, NULL, 'K'}, {"ladder", no_argument, NULL, 'L'},
        {"stray", required_argument, NULL, 'T'},
        {NULL, 0, NULL, 0},
    };
    int c;
    optind = 1;
    while ((c = getopt_long(argc, argv, "", longopts, NULL)) != -1) {
        char *end = NULL;
        double x = 0;
        if (c == 'i' || c == 'f' || c == 'n' || c == 'v') {
            errno = 0;
            x = strtod(optarg, &end);
            if (errno || end == optarg || *end || !(x > 0) || !isfinite(x)) {
                fprintf(stderr, "gonio calibrate: %s: not a positive number: '%s'\n",
                        c == 'i' ? "--integration" : c == 'f' ? "--frames"
                        : c == 'n' ? "--repeats" : "--valid", optarg);
                return -1;
            }
        }
        switch (c) {
        case 'O': o->offline = 1; break;
        case 'L': o->ladder = 1; break;
        case 's': o->scene = optarg; break;
        case 'r': o->rig = optarg; break;
        case 'd': o->root = optarg; break;
        case 'p': o->plan = optarg; break;
        case 'S': o->standard = optarg, o->standard_given = 1; break;
        case 'N': o->name = optarg; break;
        case 'K': o->sock = optarg; break;
        case 'D': o->dark = optarg; break;
        case 'T': o->stray = optarg; break;
        case 'i':
            if (o->n_int + 1 >= CAL_MAX_INTEGRATIONS) {
                fprintf(stderr, "gonio calibrate: at most %d integrations\n",
                        CAL_MAX_INTEGRATIONS - 1);
                return -1;
            }
            o->integrations[o->n_int++] = x;
            break;
        case 'f': o->frames = (long)x, o->frames_given = 1; break;
        case 'n': o->repeats = (long)x, o->repeats_given = 1; break;
        case 'v': o->valid_min = x; break;
        case 'F':
            if (strcmp(optarg, "overfilled") != 0 && strcmp(optarg, "underfilled") != 0) {
                fprintf(stderr, "gonio calibrate: --spot: overfilled or underfilled, not "
                                "'%s'\n", optarg);
                return -1;
            }
            o->underfilled = strcmp(optarg, "underfilled") == 0;
            break;
        case 'h': usage(stdout); return 1;
        default: usage(stderr); return -1;
        }
    }
    return 0;
}

/* Measure on the in-process simulated rig; frames are malloc'd. */
static int measure(const struct opts *o, enum cal_kind kind, struct cal_meta *m,
                   struct cal_frame **frames, size_t *n, struct gonio_err *err)
{
    char material[256];
    snprintf(material, sizeof material, "%s%s", kind == CAL_STRAY ? "trap"
                                                : kind == CAL_BEAM ? "beam" : "standard:",
             kind == CAL_REFERENCE ? o->standard : "");
    sim_source *src = sim_source_new(o->scene, kind != CAL_DARK ? material : NULL, o->rig,
                                     err);
    if (!src)
        return -abs(err->code ? err->code : EINVAL);
    struct capture_rig crig;
    sim_source_rig(src, &crig);
    struct rig_profile prof;
    memset(&prof, 0, sizeof prof);
    struct plan *plan = NULL;
    int rc = rig_profile_load(o->rig ? o->rig : crig.profile, &prof, err);
    if (rc >= 0 && kind != CAL_DARK && kind != CAL_BEAM &&
        (rc = plan_load(o->plan, &prof, &plan, err)) > 0)
        rc = 0;
    if (rc >= 0 && kind == CAL_BEAM)
        rc = cal_beam_meta(m, &prof, err);
    snprintf(m->rig, sizeof m->rig, "%s", prof.name);
    snprintf(m->detector, sizeof m->detector, "%s", crig.detector ? crig.detector : "unknown");
    m->in_position_deg = prof.mech.in_position_deg;
    m->integrations[0] = prof.integration_s;
    m->n_integrations = 1;
    for (size_t k = 0; k < o->n_int; k++)
        m->integrations[m->n_integrations++] = o->integrations[k];
    if (rc >= 0 && o->ladder)
        cal_add_ladder(m, &prof);
    /* The beam at its own integration, the first one the dark covers. */
    double at = kind == CAL_BEAM && o->n_int ? o->integrations[0] : prof.integration_s;
    if (rc >= 0 && kind != CAL_DARK) {
        struct cal_need need = {.rig = m->rig, .detector = m->detector,
                                .integration_s = at, .now = m->created};
        struct cal_meta dark, stray;
        if ((rc = cal_select_dark(o->root, o->dark, &need, &dark, err)) >= 0)
            snprintf(m->dark, sizeof m->dark, "%s", dark.id);
        struct cal_need at_rig = need; /* the stray light is read at the rig's */
        at_rig.integration_s = prof.integration_s;
        if (rc >= 0 && kind != CAL_STRAY && o->stray &&
            (rc = cal_select_stray(o->root, o->stray, m->dark, &at_rig, &stray, err)) >= 0)
            snprintf(m->stray, sizeof m->stray, "%s", stray.id);
        m->integrations[0] = at;
        m->n_integrations = 1;
        /* A beam serves a capture at any integration its dark covers. */
        for (size_t k = 0; rc >= 0 && kind == CAL_BEAM && k < dark.n_integrations; k++)
            if (fabs(dark.integrations[k] - at) > 1e-9 * at)
                m->integrations[m->n_integrations++] = dark.integrations[k];
    }
    struct plan_point beam_pt;
    cal_beam_point(&prof, &beam_pt);
    struct capture_devices dev;
    if (rc >= 0 && (rc = crig.open(crig.user, &prof, o->root, &dev, err)) >= 0) {
        /* The in-process rig mounts its standard itself: nobody to ask. */
        struct cal_run run = {.root = o->root, .meta = m, .rig = &prof, .plan = plan,
                              .per_point = (int)(kind == CAL_DARK ? o->frames : o->repeats)};
        if (kind == CAL_BEAM)
            run.points = &beam_pt, run.n_points = 1;
        struct cal_hooks hooks = {0};
        int aborted = 0;
        cal_new_id(o->root, kind, m->created, m->id, sizeof m->id);
        rc = cal_run_measure(&dev, &run, &hooks, frames, n, &aborted, err);
        crig.close(crig.user, &dev);
        if (rc < 0) /* nothing to resume offline: no directory left behind */
            cal_discard(o->root, m->id);
    }
    /* The gain state the detector read at: what a capture must match. */
    if (rc >= 0 && *n > 0)
        m->gain_state = (*frames)[0].gain_state;
    plan_free(plan);
    sim_source_free(src);
    return rc;
}

/* The request goniod takes (docs/protocol.md, "calibrate"): the options
 * given, goniod's defaults for the rest. */
static int through_goniod(const struct opts *o, enum cal_kind kind, const char *what)
{
    if (o->scene || o->root || o->n_int > 1) {
        fprintf(stderr, "gonio calibrate: %s: goniod calibrates its own rig into its "
                        "calibration root (--scene and --out are --offline's, and it takes "
                        "one --integration)\n", o->scene ? "--scene" : o->root ? "--out"
                                                                             : "--integration");
        return 2;
    }
    if (kind != CAL_DARK && !o->plan) {
        fprintf(stderr, "gonio calibrate: a %s needs --plan\n", what);
        return 2;
    }
    json_t *req = json_pack("{s:s, s:s}", "cmd", "calibrate", "kind", what);
    const char *keys[] = {"plan", "rig", "standard", "dark", "name", "stray"};
    const char *vals[] = {o->plan, o->rig, o->standard_given ? o->standard : NULL, o->dark,
                          o->name, o->stray};
    for (int k = 0; k < 6; k++)
        if (vals[k])
            json_object_set_new(req, keys[k], json_string(vals[k]));
    if (o->underfilled)
        json_object_set_new(req, "spot", json_string("underfilled"));
    if (o->frames_given)
        json_object_set_new(req, "frames", json_integer(o->frames));
    if (o->repeats_given)
        json_object_set_new(req, "repeats", json_integer(o->repeats));
    if (o->n_int)
        json_object_set_new(req, "integration", json_real(o->integrations[0]));
    if (o->ladder)
        json_object_set_new(req, "ladder", json_true());
    if (o->valid_min > 0)
        json_object_set_new(req, "valid", json_real(o->valid_min));
    return cmd_calibrate_goniod(req, o->sock);
}

int cmd_calibrate(int argc, char **argv)
{
    if (argc < 2 || cal_kind_parse(argv[1]) < 0) {
        if (argc >= 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
            usage(stdout);
            return 0;
        }
        fprintf(stderr, "gonio calibrate: say what to calibrate: dark, stray or reference, "
                        "or beam\n");
        usage(stderr);
        return 2;
    }
    enum cal_kind kind = (enum cal_kind)cal_kind_parse(argv[1]);
    struct opts o = {.standard = "spectralon-99", .frames = 16, .repeats = 4};
    int prc = parse(argc - 1, argv + 1, &o);
    if (prc)
        return prc > 0 ? 0 : 2;
    if (optind != argc - 1) {
        fprintf(stderr, "gonio calibrate: unexpected argument '%s'\n", argv[optind + 1]);
        return 2;
    }
    if (kind != CAL_REFERENCE && kind != CAL_BEAM && o.stray) {
        fprintf(stderr, "gonio calibrate: --stray is a reference's or a beam's\n");
        return 2;
    }
    if (kind == CAL_BEAM && !o.offline) {
        fprintf(stderr, "gonio calibrate: beam: offline only (--offline): goniod does not "
                "take a beam calibration\n");
        return 2;
    }
    if (kind == CAL_BEAM && o.n_int > 1) {
        fprintf(stderr, "gonio calibrate: beam: one --integration (the beam is read at one), "
                "%zu given\n", o.n_int);
        return 2;
    }
    if (kind == CAL_BEAM && !o.repeats_given)
        o.repeats = 16;
    if (!o.offline)
        return through_goniod(&o, kind, argv[1]);
    if (!o.scene || !o.root || (kind != CAL_DARK && kind != CAL_BEAM && !o.plan)) {
        fprintf(stderr, "gonio calibrate: --offline needs --scene and --out (reference, "
                        "stray: and --plan)\n");
        usage(stderr);
        return 2;
    }
    if (o.repeats < 2 && kind != CAL_DARK) {
        fprintf(stderr, "gonio calibrate: --repeats must be at least 2 (the photon-transfer "
                        "gain comes from their spread)\n");
        return 2;
    }
    struct cal_meta m = {.kind = kind, .created = time(NULL)};
    m.spot = o.underfilled ? RAD_SPOT_UNDERFILLED : RAD_SPOT_OVERFILLED;
    m.valid_s = 60 * (o.valid_min > 0 ? o.valid_min : kind == CAL_DARK ? 60 : 480);
    snprintf(m.standard, sizeof m.standard, "%s", kind == CAL_REFERENCE ? o.standard : "");
    struct gonio_err err = {0};
    struct cal_frame *frames = NULL;
    size_t n = 0;
    double t_start = cal_documents_now();
    int rc = gonio_mkdir_p(o.root, &err);
    if (rc >= 0)
        rc = measure(&o, kind, &m, &frames, &n, &err);
    if (rc >= 0)
        rc = cal_write(o.root, &m, frames, n, &err);
    if (rc >= 0) { /* its run as event-model documents, beside its frames */
        char source[300];
        snprintf(source, sizeof source, "in-process simulated detector (scene %s)", o.scene);
        struct cal_doc_run r = {.meta = &m, .frames = frames, .n = n, .total = n,
                                .plan = kind != CAL_DARK && kind != CAL_BEAM ? o.plan : NULL,
                                .per_point = (int)(kind == CAL_DARK ? o.frames : o.repeats),
                                .source = source, .exit_status = "success",
                                .reason = "complete", .t_start = t_start,
                                .t_stop = cal_documents_now()};
        rc = cal_documents(o.root, &r, NULL, NULL, &err);
    }
    free(frames);
    if (rc < 0) {
        fprintf(stderr, "gonio calibrate: %s\n", err.msg[0] ? err.msg : gonio_strerror(rc));
        return gonio_exit_status(rc);
    }
    printf("%s\n", m.id);
    fprintf(stderr, "calibration %s: %zu frames, rig %s, detector %s%s%s, valid %g min\n",
            m.id, n, m.rig, m.detector, kind != CAL_DARK ? ", dark " : "",
            kind != CAL_DARK ? m.dark : "", m.valid_s / 60);
    return 0;
}
