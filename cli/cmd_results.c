/* gonio results DIR...: one row per capture directory, read from its
 * results.json (plan, material, model, samples, rig and fit time, fit
 * status, errors by domain, the premise checks' verdicts, evidence, rig
 * time and full-domain estimate, --model auto's choice and why) and
 * setup.json (the scene), as an aligned
 * table, --json, --csv or a --format line. A value the capture did not
 * record (no truth errors without a reference, no fit status from an older
 * capture, no scene on a hardware rig) is "-" in the table, null in JSON
 * and empty in CSV. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <jansson.h>

#include "cli/commands.h"
#include "common/duration.h"

enum col_kind { COL_TEXT, COL_INT, COL_TIME, COL_REAL };

/* One column: its --format placeholder, JSON key and CSV header (name), its
 * table title, and how a number is shown in the table. */
static const struct column {
    const char *name, *title;
    enum col_kind kind;
} columns[] = {
    {"dir", "directory", COL_TEXT},        {"plan", "plan", COL_TEXT},
    {"scene", "scene", COL_TEXT},          {"material", "material", COL_TEXT},
    {"model", "model", COL_TEXT},          {"samples", "samples", COL_INT},
    {"rig", "rig time", COL_TIME},         {"fit", "fit s", COL_REAL},
    {"status", "fit status", COL_TEXT},    {"truth", "truth", COL_TEXT},
    {"plan_log", "plan log", COL_REAL},    {"plan_rel", "plan rRMSE", COL_REAL},
    {"inplane_log", "in-plane log", COL_REAL}, {"inplane_rel", "in-plane rRMSE", COL_REAL},
    {"full_log", "full log", COL_REAL},    {"full_rel", "full rRMSE", COL_REAL},
    /* the checks' verdicts and their rig time (docs/checks.md) */
    {"isotropy", "isotropy", COL_TEXT},    {"isotropy_s", "isotropy s", COL_REAL},
    {"oop", "in-plane", COL_TEXT},         {"oop_s", "in-plane check s", COL_REAL},
    /* their evidence, the out-of-plane check's full-domain estimate with its
     * 95% interval, and --model auto's choice and why */
    {"isotropy_sigma", "isotropy sigma", COL_REAL}, {"oop_ratio", "in-plane ratio", COL_REAL},
    {"oop_full", "est. full log", COL_REAL},       {"oop_full_low", "est. low", COL_REAL},
    {"oop_full_high", "est. high", COL_REAL},      {"auto", "auto", COL_TEXT},
    {"auto_why", "auto why", COL_TEXT},
};
#define NCOL (sizeof columns / sizeof columns[0])
/* The table leaves out the reference's name (a long spec, the material
 * column's twin on a simulated rig) and the plan-domain relative RMSE, but
 * keeps the plan-domain log error: on hardware without a reference it is
 * the only error there is. --json, --csv and --format have every column. */
static int in_table(size_t c)
{
    return strcmp(columns[c].name, "truth") && strcmp(columns[c].name, "plan_rel") &&
           strcmp(columns[c].name, "isotropy_s") && strcmp(columns[c].name, "oop_s") &&
           strcmp(columns[c].name, "isotropy_sigma") && strcmp(columns[c].name, "oop_ratio") &&
           strcmp(columns[c].name, "oop_full_low") && strcmp(columns[c].name, "oop_full_high") &&
           strcmp(columns[c].name, "auto_why");
}

static int column_find(const char *name, size_t len)
{
    for (size_t c = 0; c < NCOL; c++)
        if (strlen(columns[c].name) == len && !strncmp(columns[c].name, name, len))
            return (int)c;
    return -1;
}

static json_t *error_value(json_t *results, const char *domain, const char *key)
{
    json_t *v = json_object_get(json_object_get(json_object_get(results, "errors"), domain), key);
    return json_is_number(v) ? json_incref(v) : json_null();
}

/* A string or null. */
static json_t *text_value(json_t *v)
{
    return json_is_string(v) ? json_incref(v) : json_null();
}

/* The fit status (fit/fit_status.h) is an object with a "status"; older
 * captures have none. */
static json_t *status_value(json_t *results)
{
    json_t *st = json_object_get(results, "fit_status");
    return text_value(json_is_object(st) ? json_object_get(st, "status") : st);
}

/* A number or null. */
static json_t *number_value(json_t *v)
{
    return json_is_number(v) ? json_incref(v) : json_null();
}

/* The checks' evidence and estimate, and auto's choice (capture/verdicts.h). */
static void verdict_values(json_t *root, json_t *row)
{
    json_t *checks = json_object_get(root, "checks");
    json_t *iso = json_object_get(checks, "isotropy"), *oop = json_object_get(checks, "out_of_plane");
    json_t *interval = json_object_get(oop, "error_full_interval");
    json_object_set_new(row, "isotropy_sigma", number_value(json_object_get(iso, "significance")));
    json_object_set_new(row, "oop_ratio", number_value(json_object_get(oop, "ratio")));
    json_object_set_new(row, "oop_full", number_value(json_object_get(oop, "error_full")));
    json_object_set_new(row, "oop_full_low", number_value(json_array_get(interval, 0)));
    json_object_set_new(row, "oop_full_high", number_value(json_array_get(interval, 1)));
    json_t *choice = json_object_get(root, "auto");
    json_object_set_new(row, "auto", text_value(json_object_get(choice, "chosen")));
    json_object_set_new(row, "auto_why", text_value(json_object_get(choice, "why")));
}

/* One capture's row as a JSON object in column order; NULL (and a message)
 * when results.json is missing or lacks what every capture writes. */
static json_t *row_read(const char *dir)
{
    char path[4096], setup_path[4096];
    snprintf(path, sizeof path, "%s/results.json", dir);
    snprintf(setup_path, sizeof setup_path, "%s/setup.json", dir);
    FILE *f = fopen(path, "r");
    if (!f) {
        fprintf(stderr, "gonio results: %s: no such file\n", path);
        return NULL;
    }
    json_error_t jerr;
    json_t *root = json_loadf(f, 0, &jerr);
    fclose(f);
    if (!root) {
        fprintf(stderr, "gonio results: %s:%d:%d: %s\n", path, jerr.line, jerr.column,
                jerr.text);
        return NULL;
    }
    json_t *samples = json_object_get(root, "samples");
    if (!json_is_string(json_object_get(root, "plan")) ||
        !json_is_integer(samples) ||
        !json_is_number(json_object_get(root, "rig_time_s")) ||
        !json_is_number(json_object_get(root, "fit_time_s"))) {
        fprintf(stderr, "gonio results: %s: missing plan, samples, rig_time_s or "
                        "fit_time_s\n",
                path);
        json_decref(root);
        return NULL;
    }
    json_t *setup = json_load_file(setup_path, 0, NULL); /* absent: no scene column */
    json_t *scene = json_object_get(setup, "scene");
    json_t *row = json_object();
    json_object_set_new(row, "dir", json_string(dir));
    json_object_set(row, "plan", json_object_get(root, "plan"));
    json_object_set_new(row, "scene",
                        text_value(json_is_object(scene) ? json_object_get(scene, "name") : scene));
    /* null on hardware where the request named no material */
    json_object_set_new(row, "material", text_value(json_object_get(root, "material")));
    json_object_set_new(row, "model", text_value(json_object_get(root, "model")));
    json_object_set(row, "samples", samples);
    json_object_set(row, "rig", json_object_get(root, "rig_time_s"));
    json_object_set(row, "fit", json_object_get(root, "fit_time_s"));
    json_object_set_new(row, "status", status_value(root));
    json_object_set_new(row, "truth", text_value(json_object_get(root, "truth")));
    static const char *const domains[] = {"plan", "inplane", "full"};
    for (size_t d = 0; d < 3; d++) {
        char log_key[32], rel_key[32];
        snprintf(log_key, sizeof log_key, "%s_log", domains[d]);
        snprintf(rel_key, sizeof rel_key, "%s_rel", domains[d]);
        json_object_set_new(row, log_key, error_value(root, domains[d], "log"));
        json_object_set_new(row, rel_key, error_value(root, domains[d], "rel_rmse"));
    }
    static const char *const checks[][3] = {{"isotropy", "isotropy", "isotropy_s"},
                                            {"out_of_plane", "oop", "oop_s"}};
    for (size_t k = 0; k < 2; k++) {
        json_t *c = json_object_get(json_object_get(root, "checks"), checks[k][0]);
        json_object_set_new(row, checks[k][1], text_value(json_object_get(c, "verdict")));
        json_t *s = json_object_get(c, "rig_time_s");
        json_object_set_new(row, checks[k][2], json_is_number(s) ? json_incref(s) : json_null());
    }
    verdict_values(root, row);
    json_decref(setup);
    json_decref(root);
    return row;
}

/* A cell as the table and --format show it: "-" when absent. */
static void cell_text(json_t *row, size_t c, char *buf, size_t size)
{
    json_t *v = json_object_get(row, columns[c].name);
    if (json_is_string(v))
        snprintf(buf, size, "%s", json_string_value(v));
    else if (json_is_integer(v) && columns[c].kind == COL_INT)
        snprintf(buf, size, "%lld", (long long)json_integer_value(v));
    else if (json_is_number(v) && columns[c].kind == COL_TIME)
        gonio_duration_hms(json_number_value(v), buf, size);
    else if (json_is_number(v))
        snprintf(buf, size, "%.4f", json_number_value(v));
    else
        snprintf(buf, size, "-");
}

/* A cell as CSV holds it: numbers in full, text quoted when it must be. */
static void csv_cell(json_t *v)
{
    if (json_is_string(v)) {
        const char *s = json_string_value(v);
        if (!strpbrk(s, ",\"\n")) {
            fputs(s, stdout);
            return;
        }
        putchar('"');
        for (; *s; s++) {
            if (*s == '"')
                putchar('"');
            putchar(*s);
        }
        putchar('"');
    } else if (json_is_integer(v)) {
        printf("%lld", (long long)json_integer_value(v));
    } else if (json_is_number(v)) {
        printf("%.10g", json_number_value(v));
    }
}

static void print_table(json_t *rows)
{
    int width[NCOL];
    char buf[4096];
    for (size_t c = 0; c < NCOL; c++)
        width[c] = (int)strlen(columns[c].title);
    /* A column no capture recorded (the truth errors and the scene of
     * hardware captures) is left out rather than shown as a column of "-". */
    int shown[NCOL] = {0};
    size_t i;
    json_t *row;
    json_array_foreach(rows, i, row) {
        for (size_t c = 0; c < NCOL; c++) {
            cell_text(row, c, buf, sizeof buf);
            if ((int)strlen(buf) > width[c])
                width[c] = (int)strlen(buf);
            shown[c] |= in_table(c) && strcmp(buf, "-");
        }
    }
    /* Text to the left, numbers to the right; two spaces between. */
    for (int header = 1; header >= 0; header--) {
        size_t n = header ? 1 : json_array_size(rows);
        for (size_t r = 0; r < n; r++) {
            const char *sep = "";
            for (size_t c = 0; c < NCOL; c++) {
                if (!shown[c])
                    continue;
                if (header)
                    snprintf(buf, sizeof buf, "%s", columns[c].title);
                else
                    cell_text(json_array_get(rows, r), c, buf, sizeof buf);
                int left = columns[c].kind == COL_TEXT;
                printf("%s%*s", sep, left ? -width[c] : width[c], buf);
                sep = "  ";
            }
            putchar('\n');
        }
    }
}

static void print_csv(json_t *rows)
{
    for (size_t c = 0; c < NCOL; c++)
        printf("%s%s", c ? "," : "", columns[c].name);
    putchar('\n');
    size_t i;
    json_t *row;
    json_array_foreach(rows, i, row) {
        for (size_t c = 0; c < NCOL; c++) {
            if (c)
                putchar(',');
            csv_cell(json_object_get(row, columns[c].name));
        }
        putchar('\n');
    }
}

/* Every %name of fmt must be a column: checked before anything is read, so
 * a typo is one error line, not rows with the typo printed in them. */
static int format_check(const char *fmt)
{
    for (const char *p = strchr(fmt, '%'); p; p = strchr(p + 1, '%')) {
        if (p[1] == '%') {
            p++;
            continue;
        }
        size_t len = strspn(p + 1, "abcdefghijklmnopqrstuvwxyz_");
        if (column_find(p + 1, len) < 0) {
            fprintf(stderr,
                    "gonio results: --format: unknown placeholder '%%%.*s' (use %%%%, %%dir, "
                    "%%plan, %%scene, %%material, %%model, %%samples, %%rig, %%fit, %%status, "
                    "%%truth, %%<domain>_log, %%<domain>_rel for plan, inplane, full)\n",
                    (int)(len ? len : strcspn(p + 1, " ")), p + 1);
            return -1;
        }
    }
    return 0;
}

/* --format: one line per directory; %rig and %fit in seconds. */
static void print_format(const char *fmt, json_t *row)
{
    char buf[4096];
    for (const char *p = fmt; *p; p++) {
        if (*p != '%') {
            putchar(*p);
            continue;
        }
        if (p[1] == '%') {
            putchar(*++p);
            continue;
        }
        size_t len = strspn(p + 1, "abcdefghijklmnopqrstuvwxyz_");
        size_t c = (size_t)column_find(p + 1, len);
        json_t *v = json_object_get(row, columns[c].name);
        if ((columns[c].kind == COL_TIME || columns[c].kind == COL_REAL) && json_is_number(v)) {
            printf("%.6g", json_number_value(v));
        } else {
            cell_text(row, c, buf, sizeof buf);
            fputs(buf, stdout);
        }
        p += len;
    }
    putchar('\n');
}

static void usage(FILE *out)
{
    fprintf(out,
            "usage: gonio results [--json | --csv | --format FMT] CAPTURE_DIR...\n"
            "One row per capture: directory, plan, scene, material, model, samples, rig time\n"
            "(h:mm:ss), fit time (s), fit status, the plan-domain log error, and the log error\n"
            "and relative RMSE on the in-plane and full domains ('-' when the capture has no\n"
            "reference material; a column no capture has is left out).\n"
            "  --json    an array of objects, one per capture (absent values null)\n"
            "  --csv     a header and one line per capture (absent values empty)\n"
            "  --format  one line per capture with %%dir %%plan %%scene %%material %%model\n"
            "            %%samples %%rig %%fit (seconds) %%status %%truth and %%<domain>_log,\n"
            "            %%<domain>_rel for the domains plan, inplane and full; %%%% is a %%\n");
}

int cmd_results(int argc, char **argv)
{
    static const struct option opts[] = {
        {"format", required_argument, NULL, 'f'},
        {"json", no_argument, NULL, 'j'},
        {"csv", no_argument, NULL, 'c'},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0},
    };
    const char *fmt = NULL;
    int mode = 0; /* 'j', 'c', 'f' or 0: the table */
    optind = 1;
    opterr = 0;
    int ch;
    while ((ch = getopt_long(argc, argv, "+h", opts, NULL)) != -1) {
        switch (ch) {
        case 'h': usage(stdout); return 0;
        case 'f':
        case 'j':
        case 'c':
            if (mode && mode != ch) {
                fprintf(stderr, "gonio results: --json, --csv and --format exclude each other\n");
                return 2;
            }
            mode = ch;
            fmt = ch == 'f' ? optarg : fmt;
            break;
        default:
            if (optopt == 'f')
                fprintf(stderr, "gonio results: --format needs a value\n");
            else
                fprintf(stderr, "gonio results: unknown option '%s'\n", argv[optind - 1]);
            usage(stderr);
            return 2;
        }
    }
    if (optind >= argc) {
        fprintf(stderr, "gonio results: at least one capture directory is required\n");
        usage(stderr);
        return 2;
    }
    if (fmt && format_check(fmt) < 0)
        return 2;
    json_t *rows = json_array();
    int status = 0;
    for (int i = optind; i < argc; i++) {
        json_t *row = row_read(argv[i]);
        if (row)
            json_array_append_new(rows, row);
        else
            status = 2;
    }
    size_t i;
    json_t *row;
    if (mode == 'j') {
        json_dumpf(rows, stdout, JSON_INDENT(1) | JSON_REAL_PRECISION(10));
        putchar('\n');
    } else if (mode == 'c') {
        print_csv(rows);
    } else if (mode == 'f') {
        json_array_foreach(rows, i, row)
            print_format(fmt, row);
    } else if (json_array_size(rows)) {
        print_table(rows);
    }
    json_decref(rows);
    return status;
}
