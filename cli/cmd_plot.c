/* gonio plot KIND: one figure as SVG or PNG (report/, docs/report.md).
 *   slices: in-plane slices of any materials, models and a capture's samples
 *   pareto, bars: the study figures of a study directory */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli/commands.h"
#include "cli/output_path.h"
#include "common/paths.h"
#include "fit/model_file.h"
#include "report/raster.h"
#include "report/samples.h"
#include "report/slices.h"
#include "report/study_plots.h"

#define MAX_MODELS 16

static void usage(FILE *out)
{
    fprintf(out,
            "usage: gonio plot slices [--material SPEC] [--samples CAPTURE|samples.csv]\n"
            "                         [--model SPEC [--label TEXT]]... [--theta-i LIST]\n"
            "                         [--channel y|r|g|b] [--title TEXT] -o FILE.svg|FILE.png|DIR\n"
            "       gonio plot pareto|bars STUDY_DIR [--scene NAME] [--domain plan|inplane|full]\n"
            "                         [--metric log|rrmse] -o FILE.svg|FILE.png|DIR\n"
            "  -o DIR (an existing directory): DIR/FIGURE.svg (slices.svg, pareto.svg,\n"
            "        bars.svg)\n"
            "  SPEC: a material (nbrdf:NAME, abc:NAME, builtin:NAME, default, ...) or a\n"
            "        fitted model, model:FILE (gonio fit)\n"
            "  --theta-i: comma-separated incidence angles, one panel each (default: those\n"
            "        of the samples, else 0,15,...,75)\n"
            "  pareto defaults: --domain full --metric log; bars: --domain full --metric rrmse\n");
}

/* Write the document as SVG, or rasterised when the name ends in .png. */
static int write_figure(const char *out, char *svg, size_t len, struct gonio_err *err)
{
    size_t n = strlen(out);
    int rc;
    if (n > 4 && !strcmp(out + n - 4, ".png")) {
        unsigned char *png = NULL;
        size_t png_len = 0;
        rc = report_svg_to_png(svg, len, 1.5, &png, &png_len, err);
        if (!rc)
            rc = gonio_write_file_atomic(out, png, png_len, err);
        free(png);
    } else {
        rc = gonio_write_file_atomic(out, svg, len, err);
    }
    return rc < 0 ? rc : 0;
}

static int out_ok(const char *out)
{
    size_t n = out ? strlen(out) : 0;
    if (n > 4 && (!strcmp(out + n - 4, ".svg") || !strcmp(out + n - 4, ".png")))
        return 1;
    fprintf(stderr, "gonio plot: -o '%s': the output must end in .svg or .png\n",
            out ? out : "");
    return 0;
}

static int parse_theta_list(const char *text, double *out, size_t *n)
{
    *n = 0;
    const char *s = text;
    while (*s) {
        char *end;
        double v = strtod(s, &end);
        if (end == s || (*end && *end != ',') || *n >= REPORT_SLICES_MAX_PANELS)
            return -1;
        out[(*n)++] = v;
        s = *end ? end + 1 : end;
    }
    return *n ? 0 : -1;
}

static int parse_channel(const char *text, enum report_channel *out)
{
    static const struct {
        const char *name;
        enum report_channel channel;
    } channels[] = {{"y", REPORT_Y}, {"r", REPORT_R}, {"g", REPORT_G}, {"b", REPORT_B}};
    for (size_t i = 0; i < sizeof channels / sizeof *channels; i++)
        if (!strcmp(text, channels[i].name)) {
            *out = channels[i].channel;
            return 0;
        }
    return -1;
}

static int plot_slices(int argc, char **argv)
{
    static const struct option opts[] = {
        {"material", required_argument, NULL, 'm'}, {"samples", required_argument, NULL, 's'},
        {"model", required_argument, NULL, 'M'},    {"label", required_argument, NULL, 'l'},
        {"theta-i", required_argument, NULL, 't'},  {"channel", required_argument, NULL, 'c'},
        {"title", required_argument, NULL, 'T'},    {"output", required_argument, NULL, 'o'},
        {"help", no_argument, NULL, 'h'},           {NULL, 0, NULL, 0},
    };
    const char *material = NULL, *samples_path = NULL, *out = NULL, *title = NULL;
    const char *model_specs[MAX_MODELS], *labels[MAX_MODELS] = {0};
    size_t n_models = 0;
    double theta[REPORT_SLICES_MAX_PANELS];
    size_t n_theta = 0;
    enum report_channel channel = REPORT_Y;
    optind = 1;
    int c;
    while ((c = getopt_long(argc, argv, "o:h", opts, NULL)) != -1) {
        switch (c) {
        case 'm': material = optarg; break;
        case 's': samples_path = optarg; break;
        case 'M':
            if (n_models == MAX_MODELS) {
                fprintf(stderr, "gonio plot: at most %d --model\n", MAX_MODELS);
                return 2;
            }
            model_specs[n_models++] = optarg;
            break;
        case 'l':
            if (!n_models || labels[n_models - 1]) {
                fprintf(stderr, "gonio plot: --label '%s' must follow its --model\n", optarg);
                return 2;
            }
            labels[n_models - 1] = optarg;
            break;
        case 't':
            if (parse_theta_list(optarg, theta, &n_theta)) {
                fprintf(stderr, "gonio plot: --theta-i '%s' is not a list of 1..%d angles\n",
                        optarg, REPORT_SLICES_MAX_PANELS);
                return 2;
            }
            break;
        case 'c':
            if (parse_channel(optarg, &channel) < 0) {
                fprintf(stderr, "gonio plot: --channel '%s' is not y, r, g or b\n", optarg);
                return 2;
            }
            break;
        case 'T': title = optarg; break;
        case 'o': out = optarg; break;
        case 'h': usage(stdout); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (optind != argc) {
        fprintf(stderr, "gonio plot slices: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    char path[4200];
    if (out)
        out = output_path("gonio plot", out, NULL, "slices.svg", path, sizeof path);
    if (!out_ok(out))
        return 2;
    if (!material && !samples_path && !n_models) {
        fprintf(stderr, "gonio plot slices: give --material, --samples or --model\n");
        return 2;
    }
    struct gonio_err err = {0};
    brdf_material *truth = NULL, *models[MAX_MODELS] = {0};
    struct report_sample *samples = NULL;
    size_t n_samples = 0, oop = 0, no_value = 0;
    int rc = 0;
    if (material && !(truth = fit_material_open(material, &err)))
        rc = -1;
    for (size_t i = 0; !rc && i < n_models; i++)
        if (!(models[i] = fit_material_open(model_specs[i], &err)))
            rc = -1;
    if (!rc && samples_path)
        rc = report_samples_read(samples_path, &samples, &n_samples, &oop, &no_value, &err);
    if (!rc && oop)
        fprintf(stderr, "gonio plot: %zu out-of-plane samples of %s are not drawn\n", oop,
                samples_path);
    if (!rc && no_value)
        fprintf(stderr, "gonio plot: %zu records of %s without a BRDF value (dark frames, "
                        "counts not reduced) are not drawn\n", no_value, samples_path);
    if (!rc) {
        struct report_slices in = {.title = title,
                                   .truth = truth,
                                   .truth_label = material,
                                   .models = (const brdf_material *const *)models,
                                   .model_labels = labels,
                                   .n_models = n_models,
                                   .samples = samples,
                                   .n_samples = n_samples,
                                   .theta_i = theta,
                                   .n_theta_i = n_theta,
                                   .channel = channel};
        char *svg = NULL;
        size_t len = 0;
        rc = report_plot_slices(&in, "slices", &svg, &len, &err);
        if (!rc)
            rc = write_figure(out, svg, len, &err);
        free(svg);
    }
    brdf_material_free(truth);
    for (size_t i = 0; i < n_models; i++)
        brdf_material_free(models[i]);
    free(samples);
    if (rc < 0) {
        fprintf(stderr, "gonio plot: %s\n", err.msg);
        return gonio_exit_status(err.code);
    }
    printf("wrote %s\n", out);
    return 0;
}

static int plot_study(int argc, char **argv, int bars)
{
    static const struct option opts[] = {
        {"scene", required_argument, NULL, 's'},  {"domain", required_argument, NULL, 'd'},
        {"metric", required_argument, NULL, 'm'}, {"title", required_argument, NULL, 'T'},
        {"output", required_argument, NULL, 'o'}, {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    struct report_plot_opts po = {NULL, REPORT_FULL, bars ? REPORT_RRMSE : REPORT_LOG, NULL};
    const char *out = NULL;
    optind = 1;
    int c;
    while ((c = getopt_long(argc, argv, "o:h", opts, NULL)) != -1) {
        switch (c) {
        case 's': po.scene = optarg; break;
        case 'T': po.title = optarg; break;
        case 'o': out = optarg; break;
        case 'd':
            if (!strcmp(optarg, "plan"))
                po.domain = REPORT_PLAN;
            else if (!strcmp(optarg, "inplane"))
                po.domain = REPORT_INPLANE;
            else if (!strcmp(optarg, "full"))
                po.domain = REPORT_FULL;
            else {
                fprintf(stderr, "gonio plot: --domain '%s' is not plan, inplane or full\n",
                        optarg);
                return 2;
            }
            break;
        case 'm':
            if (!strcmp(optarg, "log"))
                po.metric = REPORT_LOG;
            else if (!strcmp(optarg, "rrmse"))
                po.metric = REPORT_RRMSE;
            else {
                fprintf(stderr, "gonio plot: --metric '%s' is not log or rrmse\n", optarg);
                return 2;
            }
            break;
        case 'h': usage(stdout); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (optind != argc - 1) {
        fprintf(stderr, "gonio plot: one study directory is required\n");
        return 2;
    }
    char path[4200];
    if (out)
        out = output_path("gonio plot", out, NULL, bars ? "bars.svg" : "pareto.svg", path,
                          sizeof path);
    if (!out_ok(out))
        return 2;
    struct gonio_err err = {0};
    struct report_results r;
    int rc = report_results_read(argv[optind], &r, &err);
    char *svg = NULL;
    size_t len = 0;
    if (!rc)
        rc = bars ? report_plot_bars(&r, &po, "bars", &svg, &len, &err)
                  : report_plot_pareto(&r, &po, "pareto", &svg, &len, &err);
    if (!rc)
        rc = write_figure(out, svg, len, &err);
    free(svg);
    report_results_free(&r); /* also after a failed read, which leaves it empty */
    if (rc < 0) {
        fprintf(stderr, "gonio plot: %s\n", err.msg);
        return gonio_exit_status(err.code);
    }
    printf("wrote %s\n", out);
    return 0;
}

int cmd_plot(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "gonio plot: a figure is required (slices, pareto or bars)\n");
        usage(stderr);
        return 2;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
        usage(stdout);
        return 0;
    }
    /* The figure's options are parsed from argv + 1: its argv[0] is the
     * program name getopt's messages start with. */
    const char *figure = argv[1];
    argv[1] = argv[0];
    if (!strcmp(figure, "slices"))
        return plot_slices(argc - 1, argv + 1);
    if (!strcmp(figure, "pareto"))
        return plot_study(argc - 1, argv + 1, 0);
    if (!strcmp(figure, "bars"))
        return plot_study(argc - 1, argv + 1, 1);
    fprintf(stderr, "gonio plot: unknown figure '%s' (slices, pareto or bars)\n", figure);
    usage(stderr);
    return 2;
}
