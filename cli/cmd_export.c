/* gonio export merl --material SPEC -o FILE: a MERL .binary table of any
 * material source (ground truth or fitted model). */
#include <getopt.h>
#include <stdio.h>
#include <string.h>

#include "brdf/material.h"
#include "brdf/merl.h"
#include "cli/commands.h"
#include "cli/output_path.h"
#include "fit/model_file.h"

static void usage(FILE *out)
{
    fprintf(out, "usage: gonio export merl --material SPEC -o FILE.binary|DIR\n"
                 "  SPEC: nbrdf:NAME, merl:FILE, abc:NAME, sgd:NAME, builtin:NAME, spectral:NAME,\n"
                 "        analytic:NAME, default or model:FILE\n"
                 "  -o DIR (an existing directory): DIR/NAME.binary, NAME the spec's last\n"
                 "        part without its extension (model:c1/abc.model: abc.binary)\n");
}

/* A table's file name from its spec: the last part, without extension. */
static const char *table_name(const char *spec, char *buf, size_t size)
{
    const char *base = spec;
    for (const char *c = spec; *c; c++)
        if (*c == ':' || *c == '/')
            base = c + 1;
    const char *dot = strrchr(base, '.');
    int len = dot && dot != base ? (int)(dot - base) : (int)strlen(base);
    if (!*base)
        snprintf(buf, size, "table.binary");
    else
        snprintf(buf, size, "%.*s.binary", len > 200 ? 200 : len, base);
    return buf;
}

int cmd_export(int argc, char **argv)
{
    static const struct option opts[] = {
        {"material", required_argument, NULL, 'm'},
        {"output", required_argument, NULL, 'o'},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    if (argc < 2 || strcmp(argv[1], "merl") != 0) {
        if (argc >= 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
            usage(stdout);
            return 0;
        }
        fprintf(stderr, "gonio export: the only format is 'merl'\n");
        usage(stderr);
        return 2;
    }
    const char *spec = NULL, *out = NULL;
    argv[1] = argv[0]; /* getopt's messages name the program: "gonio export: ..." */
    optind = 1;
    int c;
    while ((c = getopt_long(argc - 1, argv + 1, "m:o:h", opts, NULL)) != -1) {
        switch (c) {
        case 'm': spec = optarg; break;
        case 'o': out = optarg; break;
        case 'h': usage(stdout); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (!spec || !out || optind != argc - 1) {
        fprintf(stderr, "gonio export merl: --material and -o are required\n");
        usage(stderr);
        return 2;
    }
    char path[4200], name[256];
    out = output_path("gonio export", out, NULL, table_name(spec, name, sizeof name), path,
                      sizeof path);
    /* The file is the MERL binary format whatever its name; a name that
     * says otherwise (x.txt) would mislead whoever opens it next. */
    size_t n = strlen(out);
    if (n < 8 || strcmp(out + n - 7, ".binary") != 0) {
        fprintf(stderr, "gonio export: -o '%s': a MERL table is written to FILE.binary\n", out);
        return 2;
    }
    struct gonio_err err = {0};
    brdf_material *m = fit_material_open(spec, &err); /* model:FILE too */
    if (!m) {
        fprintf(stderr, "gonio export: %s\n", err.msg);
        return gonio_exit_status(err.code);
    }
    int rc = brdf_merl_export(m, out, &err);
    brdf_material_free(m);
    if (rc < 0) {
        fprintf(stderr, "gonio export: %s\n", err.msg);
        return gonio_exit_status(err.code);
    }
    printf("wrote %s (MERL table of %s)\n", out, spec);
    return 0;
}
