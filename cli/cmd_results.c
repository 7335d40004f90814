/* gonio results DIR...: one table row per capture directory, read from its
 * results.json (plan, samples, rig and fit time, errors by domain). A
 * capture of unknown material (hardware) shows "-" for it, and one without
 * a reference "-" for its in-plane and full-domain errors. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include <jansson.h>

#include "cli/commands.h"

static double number(json_t *root, const char *domain, const char *key)
{
    json_t *v = json_object_get(json_object_get(json_object_get(root, "errors"), domain), key);
    return json_is_number(v) ? json_number_value(v) : NAN;
}

static int has_domain(json_t *root, const char *domain)
{
    return json_object_get(json_object_get(root, "errors"), domain) != NULL;
}

/* --format: %plan %material %samples %rig %fit and %<domain>_log,
 * %<domain>_rel for domain plan, inplane, full; one line per directory. */
static void print_format(const char *fmt, json_t *root)
{
    static const struct {
        const char *name, *domain, *key;
    } errs[] = {
        {"plan_log", "plan", "log"},       {"plan_rel", "plan", "rel_rmse"},
        {"inplane_log", "inplane", "log"}, {"inplane_rel", "inplane", "rel_rmse"},
        {"full_log", "full", "log"},       {"full_rel", "full", "rel_rmse"},
    };
    for (const char *p = fmt; *p; p++) {
        if (*p != '%') {
            putchar(*p);
            continue;
        }
        size_t len = strspn(p + 1, "abcdefghijklmnopqrstuvwxyz_");
        char name[32];
        snprintf(name, sizeof name, "%.*s", (int)len, p + 1);
        p += len;
        if (!strcmp(name, "plan") || !strcmp(name, "material")) {
            const char *v = json_string_value(json_object_get(root, name));
            fputs(v ? v : "-", stdout);
        } else if (!strcmp(name, "samples")) {
            printf("%lld", (long long)json_integer_value(json_object_get(root, "samples")));
        } else if (!strcmp(name, "rig") || !strcmp(name, "fit")) {
            json_t *v = json_object_get(root, name[0] == 'r' ? "rig_time_s" : "fit_time_s");
            printf("%.6g", json_number_value(v));
        } else {
            size_t i = 0;
            while (i < sizeof errs / sizeof errs[0] && strcmp(errs[i].name, name) != 0)
                i++;
            if (i == sizeof errs / sizeof errs[0])
                printf("%%%s", name);
            else if (has_domain(root, errs[i].domain))
                printf("%.6g", number(root, errs[i].domain, errs[i].key));
            else
                putchar('-'); /* no reference: no such error */
        }
    }
    putchar('\n');
}

static void header(void)
{
    printf("%-28s %-6s %7s %10s %8s  %-17s %-17s\n", "material", "plan", "samples", "rig time",
           "fit", "in-plane log/rRMSE", "full log/rRMSE");
}

static int row(const char *dir, const char *fmt)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/results.json", dir);
    json_error_t jerr;
    json_t *root = json_load_file(path, 0, &jerr);
    if (!root) {
        fprintf(stderr, "gonio results: %s:%d:%d: %s\n", path, jerr.line, jerr.column,
                jerr.text);
        return 2;
    }
    const char *material = json_string_value(json_object_get(root, "material"));
    const char *plan = json_string_value(json_object_get(root, "plan"));
    json_t *samples = json_object_get(root, "samples");
    json_t *rig = json_object_get(root, "rig_time_s"), *fit = json_object_get(root, "fit_time_s");
    if (!material && json_is_null(json_object_get(root, "material")))
        material = "-"; /* hardware: what it measured is not known */
    if (!material || !plan || !json_is_integer(samples) || !json_is_number(rig) ||
        !json_is_number(fit)) {
        fprintf(stderr, "gonio results: %s: missing plan, material, samples, rig_time_s or "
                        "fit_time_s\n",
                path);
        json_decref(root);
        return 2;
    }
    if (fmt) {
        print_format(fmt, root);
        json_decref(root);
        return 0;
    }
    double rig_s = json_number_value(rig);
    printf("%-28s %-6s %7lld %4.0f:%02.0f min %7.3fs  ", material, plan,
           (long long)json_integer_value(samples), (double)(long)(rig_s / 60),
           rig_s - 60 * (double)(long)(rig_s / 60), json_number_value(fit));
    for (int d = 0; d < 2; d++) {
        const char *domain = d ? "full" : "inplane";
        if (has_domain(root, domain))
            printf("%.4f / %-8.4f ", number(root, domain, "log"),
                   number(root, domain, "rel_rmse"));
        else
            printf("%-17s ", "-");
    }
    printf("\n");
    json_decref(root);
    return 0;
}

int cmd_results(int argc, char **argv)
{
    const char *fmt = NULL;
    int first = 1;
    if (argc >= 3 && !strcmp(argv[1], "--format")) {
        fmt = argv[2];
        first = 3;
    }
    if (argc <= first || !strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
        fprintf(argc <= first ? stderr : stdout,
                "usage: gonio results [--format FMT] CAPTURE_DIR...\n"
                "One row per capture: samples, rig time, fit time, and the log error and\n"
                "relative RMSE on the in-plane and full out-of-plane domains. FMT prints one\n"
                "line per capture instead, with %%plan %%material %%samples %%rig %%fit and\n"
                "%%<domain>_log, %%<domain>_rel for the domains plan, inplane and full.\n");
        return argc <= first ? 2 : 0;
    }
    if (!fmt)
        header();
    int status = 0;
    for (int i = first; i < argc; i++) {
        int rc = row(argv[i], fmt);
        if (rc > status)
            status = rc;
    }
    return status;
}
