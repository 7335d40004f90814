/* gonio render: materials (ground truth or fitted models) on a lit sphere,
 * written as linear OpenEXR and sRGB PNG (docs/render.md). Everything is
 * checked (scene, every material) before the output directory is made. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/material.h"
#include "cli/commands.h"
#include "cli/progress.h"
#include "common/clock.h"
#include "fit/model_file.h"
#include "render/output.h"
#include "render/render.h"
#include "render/scene.h"
#include "render/study.h"

#define MAX_ITEMS 64

static void usage(FILE *out)
{
    fprintf(out,
            "usage: gonio render --material SPEC [--material SPEC ...] [OPTIONS] --out DIR\n"
            "       gonio render --grid --truth SPEC --model SPEC [--model SPEC ...]\n"
            "                    [--label TEXT ...] [--columns N] [OPTIONS] --out DIR\n"
            "       gonio render --study DIR [--study-scene NAME] [--columns N] [OPTIONS]\n"
            "                    (a grid per material in DIR/renders/MATERIAL/)\n"
            "  SPEC: nbrdf:NAME, abc:NAME, sgd:NAME, merl:FILE, builtin:NAME, spectral:NAME,\n"
            "        analytic:NAME, default or model:FILE (a fitted model)\n"
            "  --scene FILE|NAME  render scene (configs/render/NAME.yaml; default: 'default')\n"
            "  --size N           pixels per side of each image (%d..%d, default 256)\n"
            "  --label TEXT       with --grid: the label of the next --model (in order)\n"
            "  --quiet            no progress lines\n"
            "Writes DIR/NAME.exr (linear RGB), DIR/NAME.png (sRGB), DIR/render.json, and with\n"
            "--grid DIR/grid.exr and DIR/grid.png (truth first, then each model).\n",
            RENDER_MIN_SIZE, RENDER_MAX_SIZE);
}

/* The renders' progress: images done, and the wall time still to go at
 * the pace of those done. */
struct study_bar {
    struct progress bar;
    double t0;
};

static void study_progress(void *user, int done, int total)
{
    struct study_bar *b = user;
    double t = gonio_monotonic_s() - b->t0;
    progress_show(&b->bar, &(struct progress_state){
                               .done = (size_t)done, .total = (size_t)total, .unit = "images",
                               .rig_time_s = NAN, .estimate_s = NAN,
                               .eta_s = done > 0 ? t / done * (total - done) : NAN,
                               .fit_error = NAN});
}

/* --study DIR: one grid per material of the study's results (render/study.h),
 * with gonio's progress display. */
static int render_study(const char *dir, const char *study_scene, const struct render_scene *sc,
                        int size, int columns, int quiet)
{
    struct gonio_err err = {0};
    struct study_bar b = {.t0 = gonio_monotonic_s()};
    progress_init(&b.bar, "render", quiet);
    int rc = render_study_write(dir, study_scene, sc, size, columns, study_progress, &b, &err);
    progress_end(&b.bar);
    if (rc < 0) {
        fprintf(stderr, "gonio render: %s\n", err.msg);
        return gonio_exit_status(err.code);
    }
    printf("wrote %s/renders/: a grid per material\n", dir);
    return 0;
}

static int bad(const char *msg, const char *value)
{
    fprintf(stderr, "gonio render: %s%s%s\n", msg, value ? ": " : "", value ? value : "");
    usage(stderr);
    return 2;
}

/* The command line, as parsed: with --grid, specs and labels are filled
 * from --truth and the --model/--label pairs once the mode is checked. */
struct render_args {
    const char *specs[MAX_ITEMS], *labels[MAX_ITEMS];
    const char *models[MAX_ITEMS], *model_labels[MAX_ITEMS];
    const char *truth, *scene, *out, *study, *study_scene;
    int n_specs, n_models, n_labels, grid, quiet;
    long size, columns;
};

/* Parses the options into *a. Returns -1 to go on, or the exit status
 * (--help, or a usage error already reported). */
static int parse_args(int argc, char **argv, struct render_args *a)
{
    static const struct option opts[] = {
        {"material", required_argument, NULL, 'm'}, {"truth", required_argument, NULL, 't'},
        {"model", required_argument, NULL, 'M'},    {"label", required_argument, NULL, 'l'},
        {"grid", no_argument, NULL, 'g'},           {"columns", required_argument, NULL, 'c'},
        {"scene", required_argument, NULL, 's'},    {"size", required_argument, NULL, 'n'},
        {"out", required_argument, NULL, 'o'},      {"quiet", no_argument, NULL, 'q'},
        {"study", required_argument, NULL, 'S'},    {"study-scene", required_argument, NULL, 'C'},
        {"help", no_argument, NULL, 'h'},           {NULL, 0, NULL, 0},
    };
    char *end;
    optind = 1;
    int c;
    while ((c = getopt_long(argc, argv, "m:o:h", opts, NULL)) != -1) {
        switch (c) {
        case 'm':
            if (a->n_specs == MAX_ITEMS)
                return bad("too many --material (at most 64)", optarg);
            a->specs[a->n_specs++] = optarg;
            break;
        case 'M':
            if (a->n_models == MAX_ITEMS - 1)
                return bad("too many --model (at most 63)", optarg);
            a->models[a->n_models++] = optarg;
            break;
        case 'l':
            if (a->n_labels == MAX_ITEMS - 1)
                return bad("too many --label (at most 63)", optarg);
            a->model_labels[a->n_labels++] = optarg;
            break;
        case 't': a->truth = optarg; break;
        case 'S': a->study = optarg; break;
        case 'C': a->study_scene = optarg; break;
        case 'g': a->grid = 1; break;
        case 's': a->scene = optarg; break;
        case 'o': a->out = optarg; break;
        case 'q': a->quiet = 1; break;
        case 'n':
            a->size = strtol(optarg, &end, 10);
            if (*end || end == optarg || a->size < RENDER_MIN_SIZE || a->size > RENDER_MAX_SIZE)
                return bad("--size must be an integer in 8..4096, not", optarg);
            break;
        case 'c':
            a->columns = strtol(optarg, &end, 10);
            if (*end || end == optarg || a->columns < 1 || a->columns > MAX_ITEMS)
                return bad("--columns must be an integer in 1..64, not", optarg);
            break;
        case 'h': usage(stdout); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (optind != argc)
        return bad("unexpected argument", argv[optind]);
    return -1;
}

/* Checks that the options make one of the three modes (--material,
 * --grid, --study); for --grid, lists the truth then the models as the
 * images to draw. Returns 0, or 2 with the mistake reported. */
static int check_mode(struct render_args *a)
{
    if (a->study) {
        if (a->grid || a->truth || a->n_models || a->n_labels || a->n_specs || a->out)
            return bad("--study DIR goes alone (it writes DIR/renders/MATERIAL/)", NULL);
        return 0; /* the study's folder is checked with the scene */
    }
    if (a->study_scene)
        return bad("--study-scene needs --study", NULL);
    if (!a->out)
        return bad("--out DIR is required", NULL);
    if (a->grid) {
        if (!a->truth || !a->n_models)
            return bad("--grid needs --truth SPEC and at least one --model SPEC", NULL);
        if (a->n_specs)
            return bad("--material does not go with --grid (use --truth and --model)", NULL);
        if (a->n_labels > a->n_models)
            return bad("more --label than --model", a->model_labels[a->n_labels - 1]);
        a->specs[0] = a->truth;
        a->labels[0] = "truth";
        for (int i = 0; i < a->n_models; i++) {
            a->specs[1 + i] = a->models[i];
            a->labels[1 + i] = a->model_labels[i];
        }
        a->n_specs = 1 + a->n_models;
    } else {
        if (a->truth || a->n_models || a->n_labels || a->columns)
            return bad("--truth, --model, --label and --columns need --grid or --study", NULL);
        if (!a->n_specs)
            return bad("name at least one --material SPEC", NULL);
    }
    return 0;
}

/* Opens every material (all of them before anything is written) and
 * renders the set, with the grid if asked. Returns the exit status. */
static int render_materials(const struct render_args *a, const struct render_scene *sc)
{
    struct gonio_err err = {0};
    struct render_item items[MAX_ITEMS];
    brdf_material *mats[MAX_ITEMS] = {0};
    int status = 0;
    for (int i = 0; i < a->n_specs; i++) {
        mats[i] = fit_material_open(a->specs[i], &err); /* model:FILE too */
        if (!mats[i]) {
            fprintf(stderr, "gonio render: %s\n", err.msg);
            status = gonio_exit_status(err.code);
            goto done;
        }
        items[i] = (struct render_item){a->specs[i], a->labels[i], mats[i]};
    }
    struct render_set_options o = {(int)a->size, a->grid, (int)a->columns,
                                   a->quiet ? NULL : stderr};
    if (render_write_set(a->out, sc, items, a->n_specs, &o, &err) < 0) {
        fprintf(stderr, "gonio render: %s\n", err.msg);
        status = gonio_exit_status(err.code);
        goto done;
    }
    printf("wrote %d image%s%s to %s (scene %s)\n", a->n_specs, a->n_specs == 1 ? "" : "s",
           a->grid ? " and grid.exr/grid.png" : "", a->out, sc->name);
done:
    for (int i = 0; i < a->n_specs; i++)
        brdf_material_free(mats[i]);
    return status;
}

int cmd_render(int argc, char **argv)
{
    struct render_args a = {.size = 256};
    int rc = parse_args(argc, argv, &a);
    if (rc >= 0)
        return rc;
    if ((rc = check_mode(&a)) != 0)
        return rc;
    struct gonio_err err = {0};
    struct render_scene sc;
    if (render_scene_load(a.scene ? a.scene : "default", &sc, &err) < 0) {
        fprintf(stderr, "gonio render: %s\n", err.msg);
        return gonio_exit_status(err.code);
    }
    if (a.study)
        return render_study(a.study, a.study_scene, &sc, (int)a.size, (int)a.columns, a.quiet);
    return render_materials(&a, &sc);
}
