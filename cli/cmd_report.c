/* gonio report DIR: the study's self-contained HTML page (report/page.h,
 * docs/report.md). */
#include <getopt.h>
#include <stdio.h>
#include <string.h>

#include "cli/commands.h"
#include "report/page.h"

static void usage(FILE *out)
{
    fprintf(out, "usage: gonio report DIR [--out FILE.html] [--plots PLOTDIR | --no-plots]\n"
                 "                    [--slices PLAN,...] [--quiet]\n"
                 "  DIR: a study directory (gonio study, docs/study.md)\n"
                 "  --out: default DIR/report.html\n"
                 "  --plots: also write every figure as NAME.svg and NAME.png (default "
                 "DIR/plots)\n"
                 "  --slices: plans drawn as in-plane slices (default ds2,ds4)\n");
}

int cmd_report(int argc, char **argv)
{
    static const struct option opts[] = {
        {"out", required_argument, NULL, 'o'},    {"plots", required_argument, NULL, 'p'},
        {"no-plots", no_argument, NULL, 'n'},     {"slices", required_argument, NULL, 's'},
        {"quiet", no_argument, NULL, 'q'},        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    struct report_page_opts o = {0};
    const char *plots = NULL;
    int no_plots = 0;
    optind = 1;
    int c;
    while ((c = getopt_long(argc, argv, "o:qh", opts, NULL)) != -1) {
        switch (c) {
        case 'o': o.out_html = optarg; break;
        case 'p': plots = optarg; break;
        case 'n': no_plots = 1; break;
        case 's': o.slices_plans = optarg; break;
        case 'q': o.quiet = 1; break;
        case 'h': usage(stdout); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (optind != argc - 1) {
        fprintf(stderr, "gonio report: one study directory is required\n");
        usage(stderr);
        return 2;
    }
    if (plots && no_plots) {
        fprintf(stderr, "gonio report: --plots and --no-plots exclude each other\n");
        return 2;
    }
    /* The page is HTML whatever the file is called; r.pdf would not open. */
    size_t n = o.out_html ? strlen(o.out_html) : 0;
    if (o.out_html && (n < 6 || strcmp(o.out_html + n - 5, ".html") != 0)) {
        fprintf(stderr, "gonio report: --out '%s': the report is HTML, FILE.html\n", o.out_html);
        return 2;
    }
    const char *dir = argv[optind];
    char plots_buf[4200];
    if (!no_plots) {
        if (!plots) {
            snprintf(plots_buf, sizeof plots_buf, "%.4000s/plots", dir);
            plots = plots_buf;
        }
        o.plots_dir = plots;
    }
    struct gonio_err err = {0};
    if (report_write_page(dir, &o, &err) < 0) {
        fprintf(stderr, "gonio report: %s\n", err.msg);
        return gonio_exit_status(err.code);
    }
    if (!o.quiet) {
        char out_buf[4200];
        snprintf(out_buf, sizeof out_buf, "%.4000s/report.html", dir);
        printf("wrote %s\n", o.out_html ? o.out_html : out_buf);
        if (o.plots_dir)
            printf("wrote figures to %s\n", o.plots_dir);
    }
    return 0;
}
