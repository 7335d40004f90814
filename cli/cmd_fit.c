/* gonio fit SAMPLES --model NAME [-o MODEL_FILE] [--seed N]: fit a
 * registered model (fit/models.h) to a capture's samples and write its
 * model file (docs/models.md). */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <jansson.h>

#include "brdf/domain.h"
#include "capture/verdicts.h"
#include "brdf/metrics.h"
#include "cli/commands.h"
#include "cli/output_path.h"
#include "fit/domain_weights.h"
#include "fit/journal_samples.h"
#include "journal/journal.h"
#include "fit/mlp.h"
#include "fit/model_file.h"
#include "fit/model_run.h"
#include "fit/models.h"

static void usage(FILE *out)
{
    fprintf(out, "usage: gonio fit SAMPLES --model NAME [-o FILE|DIR] [--seed N] [--epochs N]\n"
                 "                 [--truth SPEC] [--saturated clipped|censored]\n"
                 "                 [--weights domain|none] [--quiet]\n"
                 "  SAMPLES: a capture directory or its samples.csv; for mlp-spectral a\n"
                 "           capture directory (its spectra.csv) or a spectral CSV\n"
                 "           (theta_i,theta_r,wavelength_nm,value)\n"
                 "  -o: the model file, or a directory for DIR/NAME.model; default\n"
                 "      SAMPLES_DIR/NAME.model, ./NAME.model when SAMPLES_DIR is not writable\n"
                 "  --truth: also report errors against SPEC on the in-plane and full domains\n"
                 "  --saturated: fit saturated readings as lower bounds (one-sided\n"
                 "           residuals) or at their clipped value; default: the model's\n"
                 "           (clipped for abc, abc-prior, abc-pseudo, censored for the others)\n"
                 "  --weights: weight each sample by its share of the full domain (abc,\n"
                 "           abc-prior, latent, auto's candidates and scores; never fewer\n"
                 "           than 7 samples) or not; default: domain for the samples of an\n"
                 "           adaptive capture (its setup.json), else none\n"
                 "models:\n");
    for (size_t i = 0; fit_model_at(i); i++)
        fprintf(out, "  %-13s %s\n", fit_model_at(i)->name, fit_model_at(i)->summary);
}

/* The journal's samples as a fit takes them (fit/journal_samples.h). */
static int read_rgb(const char *path, struct fit_journal_data *out, struct gonio_err *err)
{
    struct journal_sample *js = NULL;
    size_t m = 0;
    int rc = journal_read(path, &js, &m, err);
    if (rc == 0)
        rc = fit_data_from_journal(js, m, out, err);
    free(js);
    return rc;
}

static void print_errors(const char *label, const struct brdf_errors *e)
{
    printf("%-10s log %.4f, rel_rmse %.4f (%zu pairs", label, e->log, e->rel_rmse, e->n_used);
    if (e->n_skipped)
        printf(", %zu without data", e->n_skipped);
    printf(")\n");
}

/* Errors of the model against the truth material on a reference domain. */
static int truth_errors(const char *label, const brdf_material *truth, const brdf_material *m,
                        int full, struct gonio_err *err)
{
    struct brdf_domain d;
    int rc = full ? brdf_domain_full(&d, err) : brdf_domain_inplane(&d, err);
    if (rc < 0)
        return rc;
    if (full && !brdf_material_isotropic(truth)) /* every azimuth of the sample */
        brdf_domain_turn(&d);
    struct brdf_errors e;
    rc = brdf_errors_material(truth, m, &d, &e, err);
    brdf_domain_free(&d);
    if (rc < 0)
        return rc;
    print_errors(label, &e);
    return 0;
}

/* Mean log error of the spectral model on its own samples. */
static int spectral_errors(const char *model_path, const struct fit_spectral_sample *s,
                           size_t n, struct gonio_err *err)
{
    struct fit_model_file *f = fit_model_file_read(model_path, err);
    if (!f)
        return -1;
    struct fit_mlp net;
    int rc = fit_mlp_from_file(f, model_path, &net, err);
    fit_model_file_free(f);
    if (rc)
        return rc;
    double sum = 0, swd = 0, swf = 0;
    size_t used = 0;
    for (size_t i = 0; i < n; i++) {
        double u[3] = {s[i].theta_i, s[i].theta_r, s[i].wavelength_nm}, v;
        double c = cos(s[i].theta_i * BRDF_DEG);
        if (!(c > 0) || !isfinite(s[i].value))
            continue;
        fit_mlp_spectral_eval(&net, u, 1, &v);
        sum += fabs(log1p(v * c) - log1p(s[i].value * c));
        swd += c * (v - s[i].value) * (v - s[i].value);
        swf += c * s[i].value * s[i].value;
        used++;
    }
    fit_mlp_free(&net);
    printf("%-10s log %.4f, rel_rmse %.4f (%zu samples)\n", "samples", used ? sum / used : NAN,
           swf > 0 ? sqrt(swd / swf) : NAN, used);
    return 0;
}

/* The command line of gonio fit. */
struct fit_args {
    const char *model, *out, *truth_spec;
    struct fit_model_options mo;
    enum fit_saturated how;
    int weights; /* -1: as the capture's setup.json says */
};

/* Options into a; -1 to go on, else the exit status. */
static int parse_args(int argc, char **argv, struct fit_args *a)
{
    static const struct option opts[] = {
        {"model", required_argument, NULL, 'm'}, {"output", required_argument, NULL, 'o'},
        {"seed", required_argument, NULL, 's'},  {"epochs", required_argument, NULL, 'e'},
        {"truth", required_argument, NULL, 't'}, {"quiet", no_argument, NULL, 'q'},
        {"saturated", required_argument, NULL, 'S'}, {"weights", required_argument, NULL, 'w'},
        {"help", no_argument, NULL, 'h'},        {NULL, 0, NULL, 0},
    };
    *a = (struct fit_args){.mo = fit_model_default_options(),
                           .how = FIT_SATURATED_DEFAULT,
                           .weights = -1};
    a->mo.quiet = 0; /* progress lines on stderr unless --quiet */
    optind = 1;
    int c;
    while ((c = getopt_long(argc, argv, "m:o:s:e:t:qh", opts, NULL)) != -1) {
        char *end;
        switch (c) {
        case 'm': a->model = optarg; break;
        case 'o': a->out = optarg; break;
        case 't': a->truth_spec = optarg; break;
        case 'q': a->mo.quiet = 1; break;
        case 'S':
            if (fit_saturated_parse(optarg, &a->how) < 0) {
                fprintf(stderr, "gonio fit: --saturated '%s': use clipped or censored\n", optarg);
                return 2;
            }
            break;
        case 'w':
            if (strcmp(optarg, "domain") && strcmp(optarg, "none")) {
                fprintf(stderr, "gonio fit: --weights '%s': use domain or none\n", optarg);
                return 2;
            }
            a->weights = !strcmp(optarg, "domain");
            break;
        case 's':
            a->mo.seed = strtoull(optarg, &end, 10);
            if (end == optarg || *end || optarg[0] == '-') {
                fprintf(stderr, "gonio fit: --seed '%s' is not a non-negative integer\n", optarg);
                return 2;
            }
            break;
        case 'e':
            a->mo.max_epochs = (int)strtol(optarg, &end, 10);
            if (end == optarg || *end || a->mo.max_epochs < 1) {
                fprintf(stderr, "gonio fit: --epochs '%s' is not a positive integer\n", optarg);
                return 2;
            }
            break;
        case 'h': usage(stdout); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (optind != argc - 1 || !a->model) {
        fprintf(stderr, "gonio fit: one SAMPLES argument and --model are required\n");
        usage(stderr);
        return 2;
    }
    return -1;
}

/* Where the samples are read from and the model written to. */
struct fit_paths {
    char samples[4096], dir[4096], out_buf[4200];
    const char *out;
    int is_dir; /* SAMPLES named a capture directory */
};

/* SAMPLES: a directory means its samples.csv, for a spectral model its
 * spectra.csv (a spectral capture writes both). */
static void resolve_paths(const char *arg, const struct fit_model_kind *kind,
                          const struct fit_args *a, struct fit_paths *p)
{
    struct stat st;
    p->is_dir = stat(arg, &st) == 0 && S_ISDIR(st.st_mode);
    if (p->is_dir) {
        snprintf(p->samples, sizeof p->samples, "%s/%s", arg,
                 kind->spectral ? "spectra.csv" : "samples.csv");
        snprintf(p->dir, sizeof p->dir, "%s", arg);
    } else {
        snprintf(p->samples, sizeof p->samples, "%s", arg);
        const char *slash = strrchr(arg, '/');
        snprintf(p->dir, sizeof p->dir, "%.*s", slash ? (int)(slash - arg) : 1,
                 slash ? arg : ".");
    }
    char name[80];
    snprintf(name, sizeof name, "%.64s.model", a->model);
    p->out = output_path("gonio fit", a->out, p->dir, name, p->out_buf, sizeof p->out_buf);
}

/* The captured material, so that abc-prior leaves it out of its prior:
 * --truth, else the capture's setup.json (simulated captures name it),
 * into material (empty when neither). An adaptive policy chose the samples
 * when setup.json says so: fitted as the capture fitted them, weighted by
 * their share of the domain (fit/models.h), unless --weights says
 * otherwise. The weights to use: 1 or 0. */
static int read_setup(const char *dir, const struct fit_args *a, char *material, size_t size)
{
    char setup_path[4200];
    snprintf(setup_path, sizeof setup_path, "%.4000s/setup.json", dir);
    json_t *setup = json_load_file(setup_path, 0, NULL);
    if (!a->truth_spec && json_is_string(json_object_get(setup, "material")))
        snprintf(material, size, "%s", json_string_value(json_object_get(setup, "material")));
    int weights = a->weights;
    if (weights < 0)
        weights = json_is_object(json_object_get(setup, "adaptive"));
    json_decref(setup);
    return weights;
}

/* The fit's summary on stdout, then its errors on its own samples. */
static int report_fit(const struct fit_model_kind *kind, const struct fit_args *a,
                      const struct fit_paths *p, const struct fit_model_report *rep,
                      const struct fit_journal_data *jd, const struct fit_spectral_sample *spec,
                      size_t n, const brdf_material *m, struct gonio_err *err)
{
    int censored = fit_model_censors(kind, a->how);
    printf("%-10s %s\n", "model", a->model);
    printf("%-10s %zu (%s)\n", "samples", n, p->samples);
    if (rep->weighted)
        printf("%-10s %s (%s)\n", "weights", FIT_DOMAIN_WEIGHTS_NOTE,
               a->weights >= 0 ? "--weights domain" : "an adaptive capture's samples");
    if (jd->saturated)
        printf("%-10s %zu readings, lower bounds: %s\n", "saturated", jd->saturated,
               censored ? "fitted one-sided (censored)" : "fitted at their clipped values");
    char line[400];
    fit_status_line(&rep->status, line, sizeof line);
    printf("%-10s %.3f s, %s\n", "fit", rep->fit_s, fit_status_name(fit_status_code(&rep->status)));
    printf("%-10s %s\n", "status", line);
    printf("%-10s %s\n", "details", rep->note);
    if (rep->auto_chosen[0]) /* as a capture's results.json says it (auto.chosen, auto.why) */
        printf("%-10s %s%s%s\n", "auto", rep->auto_chosen, rep->auto_why[0] ? "; " : "",
               rep->auto_why);
    if (kind->spectral)
        return spectral_errors(p->out, spec, n, err);
    struct brdf_errors e;
    int rc = fit_sample_errors(m, jd->rgb, n, &e, err);
    if (!rc)
        print_errors("samples", &e);
    return rc;
}

/* The fit, and with --model auto a capture's recorded premise checks as
 * its evidence: the isotropy verdict for the first fit, then the
 * out-of-plane verdicts as the capture took them (fit_auto_settle, the
 * capture's own steps with the verdicts read instead of measured), so
 * that the refit makes the capture's choice and says why as it did. */
struct auto_replay {
    const struct fit_model_kind *kind;
    const struct fit_data *data;
    const struct fit_model_options *mo;
    const char *out;
    struct fit_model_report *rep;
    brdf_material **m;
    struct capture_verdicts recorded;
};

static int replay_fit(void *user, struct gonio_err *err)
{
    struct auto_replay *r = user;
    brdf_material_free(*r->m);
    *r->m = NULL;
    return fit_model_run(r->kind, r->data, r->mo, r->out, r->rep, r->m, err);
}

static int replay_check(void *user, const char *model, char *verdict, size_t len,
                        struct gonio_err *err)
{
    (void)err;
    const struct auto_replay *r = user;
    snprintf(verdict, len, "%s", capture_verdicts_oop(&r->recorded, model));
    return 0;
}

static int run_fit(const struct fit_model_kind *kind, struct fit_data *data,
                   const struct fit_args *a, const struct fit_paths *p,
                   struct fit_model_report *rep, brdf_material **m, struct gonio_err *err)
{
    struct auto_replay r = {.kind = kind, .data = data, .mo = &a->mo, .out = p->out,
                            .rep = rep, .m = kind->spectral ? NULL : m};
    struct fit_auto_evidence ev = {0};
    if (!strcmp(kind->name, "auto")) {
        /* only a capture directory's own verdicts: a samples file says
         * nothing of which capture (if any) took it */
        if (p->is_dir && capture_verdicts_read(p->dir, &r.recorded, err) < 0)
            return -GONIO_EBADDATA;
        ev.isotropy = r.recorded.isotropy;
        data->auto_evidence = &ev;
        if (r.recorded.found)
            printf("%-10s the premise checks' verdicts of %s/results.json\n", "evidence",
                   p->dir);
        else
            printf("%-10s none (%s)\n", "evidence",
                   p->is_dir ? "no premise check's verdict in its results.json"
                             : "a samples file: only a capture directory's verdicts are read");
    }
    int rc = fit_model_run(kind, data, &a->mo, p->out, rep, r.m, err);
    if (!rc && rep->auto_chosen[0] && r.recorded.found) {
        const struct fit_auto_steps steps = {replay_fit, replay_check, &r};
        rc = fit_auto_settle(&ev, rep->auto_chosen, rep->auto_why, sizeof rep->auto_why,
                             &steps, err);
    }
    data->auto_evidence = NULL;
    return rc;
}

int cmd_fit(int argc, char **argv)
{
    struct fit_args a;
    int rc = parse_args(argc, argv, &a);
    if (rc >= 0)
        return rc;
    const struct fit_model_kind *kind = fit_model_find(a.model);
    if (!kind) {
        fprintf(stderr, "gonio fit: unknown model '%s' (see gonio fit --help)\n", a.model);
        return 2;
    }
    struct fit_paths p;
    resolve_paths(argv[optind], kind, &a, &p);
    struct gonio_err err = {0};
    struct fit_journal_data jd = {0};
    struct fit_spectral_sample *spec = NULL;
    size_t n_spectral = 0;
    rc = kind->spectral ? fit_spectral_samples_read(p.samples, &spec, &n_spectral, &err)
                        : read_rgb(p.samples, &jd, &err);
    if (rc < 0) {
        fprintf(stderr, "gonio fit: %s\n", err.msg);
        return gonio_exit_status(err.code);
    }
    if (jd.without_value)
        fprintf(stderr, "gonio fit: %zu records without a BRDF value (dark frames, counts not "
                        "reduced) left out\n", jd.without_value);
    int censored = fit_model_censors(kind, a.how);
    for (size_t i = 0; !censored && i < n_spectral; i++)
        spec[i].saturated = 0; /* spectra.csv's flags, as rgb_lower */
    char material_buf[512] = "";
    int weights = read_setup(p.dir, &a, material_buf, sizeof material_buf);
    struct fit_data data =
        fit_journal_data_for(&jd, kind, a.how,
                             a.truth_spec ? a.truth_spec : material_buf[0] ? material_buf : NULL,
                             weights > 0);
    data.spectral = spec;
    data.n_spectral = n_spectral;
    size_t n = kind->spectral ? data.n_spectral : data.n_rgb;
    if (!n) {
        fprintf(stderr, "gonio fit: %s: no samples\n", p.samples);
        fit_journal_data_free(&jd);
        free(spec);
        return 2;
    }
    brdf_material *truth = NULL, *m = NULL;
    if (a.truth_spec && !(truth = fit_material_open(a.truth_spec, &err))) {
        fprintf(stderr, "gonio fit: %s\n", err.msg);
        fit_journal_data_free(&jd);
        free(spec);
        return gonio_exit_status(err.code);
    }
    struct fit_model_report rep = {0};
    /* RGB models are assessed as read back from their file; the spectral
     * MLP on its own samples (spectral_errors). */
    rc = run_fit(kind, &data, &a, &p, &rep, &m, &err);
    if (!rc)
        rc = report_fit(kind, &a, &p, &rep, &jd, spec, n, m, &err);
    if (!rc && truth && m) {
        rc = truth_errors("inplane", truth, m, 0, &err);
        if (!rc)
            rc = truth_errors("full", truth, m, 1, &err);
    }
    if (!rc)
        printf("%-10s %s\n", "wrote", p.out);
    brdf_material_free(m);
    brdf_material_free(truth);
    fit_journal_data_free(&jd);
    free(spec);
    if (rc < 0) {
        fprintf(stderr, "gonio fit: %s\n", err.msg);
        return gonio_exit_status(err.code);
    }
    return 0;
}
