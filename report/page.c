/* The study report page (page.h). */
#include "report/page.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/paths.h"
#include "fit/model_file.h"
#include "report/html.h"
#include "report/page_private.h"
#include "report/raster.h"
#include "report/results.h"
#include "report/samples.h"
#include "report/slices.h"
#include "report/study_plots.h"

#define PNG_SCALE 1.5 /* PNG files of the figures: crisp on a high-density screen */

static const char css[] =
    "body{font-family:'DejaVu Sans','Liberation Sans',Arial,sans-serif;margin:2em auto;"
    "max-width:1200px;color:#222;line-height:1.4;padding:0 1em}"
    "h1{font-size:1.6em}h2{margin-top:2em;border-bottom:1px solid #ccc}"
    "table{border-collapse:collapse;margin:1em 0;font-size:0.85em}"
    "th,td{border:1px solid #ccc;padding:3px 7px;text-align:right}"
    "th{background:#f2f2f2}td.l,th.l{text-align:left}"
    "tr:nth-child(even) td{background:#fafafa}"
    "td.best{font-weight:bold}"
    "figure{margin:1.5em 0}figure svg{max-width:100%;height:auto}"
    "figure.render{display:inline-block;margin:0.5em}figure.render img{max-width:100%;"
    "height:auto;image-rendering:auto}"
    "figcaption{font-size:0.85em;color:#555}"
    ".note{color:#8a4b00;font-size:0.9em}"
    "nav a{margin-right:1em}";

struct page {
    FILE *f;
    const char *dir;
    const struct report_page_opts *o;
    const struct report_results *r;
    int n_fig;
    int failed; /* a plot file could not be written */
    struct gonio_err *err;
};

void report_note(FILE *f, int quiet, const char *fmt, ...)
{
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (!quiet)
        fprintf(stderr, "gonio report: %s\n", msg);
    if (f) {
        fputs("<p class=\"note\">", f);
        html_text(f, msg);
        fputs("</p>\n", f);
    }
}

/* A figure inline, and as NAME.svg and NAME.png in the plots folder. */
static void figure(struct page *p, const char *raw_name, char *svg, size_t len,
                   const char *caption)
{
    /* The name becomes a file name and an HTML id: names from results.json
     * are data, so only [A-Za-z0-9._-] survive and it cannot start with a
     * dot (no "..", no hidden file, no path). */
    char name[200];
    size_t k = 0;
    for (const char *c = raw_name; *c && k + 1 < sizeof name; c++) {
        int keep = (*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') ||
                   (*c >= '0' && *c <= '9') || *c == '-' || *c == '_' || (*c == '.' && k > 0);
        name[k++] = keep ? *c : '-';
    }
    name[k] = '\0';
    p->n_fig++;
    fprintf(p->f, "<figure id=\"%s\">\n", name);
    html_inline_svg(p->f, svg, len);
    fputs("<figcaption>", p->f);
    html_text(p->f, caption);
    fputs("</figcaption></figure>\n", p->f);
    if (p->o->plots_dir && !p->failed) {
        char path[4400];
        unsigned char *png = NULL;
        size_t png_len = 0;
        snprintf(path, sizeof path, "%.4000s/%.200s.svg", p->o->plots_dir, name);
        if (gonio_write_file_atomic(path, svg, len, p->err) < 0 ||
            report_svg_to_png(svg, len, PNG_SCALE, &png, &png_len, p->err) < 0)
            p->failed = 1;
        snprintf(path, sizeof path, "%.4000s/%.200s.png", p->o->plots_dir, name);
        if (!p->failed && gonio_write_file_atomic(path, png, png_len, p->err) < 0)
            p->failed = 1;
        free(png);
    }
    free(svg);
}

static int has_plan(const struct report_results *r, const char *plan)
{
    for (size_t i = 0; i < r->plans.n; i++)
        if (!strcmp(r->plans.name[i], plan))
            return 1;
    return 0;
}

static void cell_number(FILE *f, double v, int best)
{
    fputs(best ? "<td class=\"best\">" : "<td>", f);
    html_number(f, v, 3);
    fputs("</td>", f);
}

static void th_text(FILE *f, const char *cls, int colspan, const char *text)
{
    fprintf(f, "<th%s%s", cls ? " class=" : "", cls ? cls : "");
    if (colspan > 1)
        fprintf(f, " colspan=\"%d\"", colspan);
    fputc('>', f);
    html_text(f, text);
    fputs("</th>", f);
}

static double err_of(const struct report_row *w, enum report_domain d, enum report_metric m)
{
    return w ? w->err[d][m] : NAN;
}

/* Mean of a column over a scene's rows of one plan (materials differ). */
static double plan_mean(const struct report_results *r, const char *scene, const char *plan,
                        size_t offset)
{
    double sum = 0;
    size_t n = 0;
    for (size_t i = 0; i < r->n_rows; i++) {
        const struct report_row *w = &r->rows[i];
        double v = *(const double *)((const char *)w + offset);
        if (!strcmp(w->scene, scene) && !strcmp(w->plan, plan) && isfinite(v)) {
            sum += v;
            n++;
        }
    }
    return n ? sum / (double)n : NAN;
}

static void section_plans(struct page *p)
{
    FILE *f = p->f;
    const struct report_results *r = p->r;
    fputs("<h2 id=\"cost\">What each plan costs</h2>\n<p>Samples and simulated rig time per "
          "plan, the mean over the study's materials (rig time depends on the material through "
          "the exposure).</p>\n", f);
    for (size_t s = 0; s < r->scenes.n; s++) {
        const char *scene = r->scenes.name[s];
        fputs("<table><tr>", f);
        th_text(f, "l", 1, "plan");
        fputs("<th>samples</th><th>rig time</th><th>move</th><th>settle</th>"
              "<th>integration</th>", f);
        th_text(f, "l", 1, "scene");
        fputs("</tr>\n", f);
        for (size_t k = 0; k < r->plans.n; k++) {
            const char *plan = r->plans.name[k];
            fputs("<tr><td class=\"l\">", f);
            html_text(f, plan);
            fputs("</td><td>", f);
            html_number(f, plan_mean(r, scene, plan, offsetof(struct report_row, samples)), 6);
            static const size_t cols[] = {offsetof(struct report_row, rig_time_s),
                                          offsetof(struct report_row, move_s),
                                          offsetof(struct report_row, settle_s),
                                          offsetof(struct report_row, integration_s)};
            for (int c = 0; c < 4; c++) {
                fputs("</td><td>", f);
                html_duration(f, plan_mean(r, scene, plan, cols[c]));
            }
            fputs("</td><td class=\"l\">", f);
            html_text(f, scene);
            fputs("</td></tr>\n", f);
        }
        fputs("</table>\n", f);
    }
}

/* DS1 -> DS4: how the error grows as the capture shrinks. */
static void section_ablation(struct page *p)
{
    FILE *f = p->f;
    const struct report_results *r = p->r;
    static const char *ds[] = {"ds1", "ds2", "ds3", "ds4"};
    const char *plans[4];
    int n = 0;
    for (int i = 0; i < 4; i++)
        if (has_plan(r, ds[i]))
            plans[n++] = ds[i];
    fputs("<h2 id=\"ablation\">DS1 → DS4: from 912 pairs down to six</h2>\n", f);
    if (!n) {
        report_note(f, 1, "The study has none of the plans ds1..ds4.");
        return;
    }
    fputs("<p>Log error of each model fitted to the reduced in-plane datasets, on the in-plane "
          "domain and on the full out-of-plane domain (model against the true material). The "
          "lowest error of a row is in bold; – is a value the model does not have (the MLP "
          "is in-plane only) or a failed fit.</p>\n", f);
    for (size_t s = 0; s < r->scenes.n; s++) {
        const char *scene = r->scenes.name[s];
        fputs("<table><tr>", f);
        th_text(f, "l", 1, "material");
        th_text(f, "l", 1, "model");
        th_text(f, NULL, n, "log error, in-plane domain");
        th_text(f, NULL, n, "log error, full out-of-plane domain");
        fputs("</tr>\n<tr><th class=\"l\">scene ", f);
        html_text(f, scene);
        fputs("</th><th></th>", f);
        for (int d = 0; d < 2; d++)
            for (int i = 0; i < n; i++)
                th_text(f, NULL, 1, plans[i]);
        fputs("</tr>\n", f);
        for (size_t m = 0; m < r->materials.n; m++)
            for (size_t k = 0; k < r->models.n; k++) {
                const struct report_row *w[4];
                int any = 0;
                for (int i = 0; i < n; i++)
                    any |= (w[i] = report_results_find(r, r->materials.name[m], scene, plans[i],
                                                       r->models.name[k])) != NULL;
                if (!any)
                    continue;
                fputs("<tr><td class=\"l\">", f);
                html_text(f, r->materials.name[m]);
                fputs("</td><td class=\"l\">", f);
                html_text(f, r->models.name[k]);
                fputs("</td>", f);
                static const enum report_domain doms[] = {REPORT_INPLANE, REPORT_FULL};
                for (int d = 0; d < 2; d++) {
                    double best = INFINITY;
                    for (int i = 0; i < n; i++)
                        best = fmin(best, err_of(w[i], doms[d], REPORT_LOG));
                    for (int i = 0; i < n; i++) {
                        double v = err_of(w[i], doms[d], REPORT_LOG);
                        cell_number(f, v, v == best);
                    }
                }
                fputs("</tr>\n", f);
            }
        fputs("</table>\n", f);
    }
}

/* In-plane captures against the out-of-plane reference capture. */
static void section_inplane_vs_oop(struct page *p)
{
    FILE *f = p->f;
    const struct report_results *r = p->r;
    fputs("<h2 id=\"inplane\">In-plane against out-of-plane captures</h2>\n", f);
    int in = has_plan(r, "inplane-full"), out = has_plan(r, "oop200k");
    if (!in && !out) {
        report_note(f, 1, "The study has neither inplane-full nor oop200k rows (run gonio study "
                          "with --plans ...,inplane-full,oop200k for this comparison).");
        return;
    }
    fputs("<p>Error on the <em>full out-of-plane</em> domain of the same model fitted to an "
          "in-plane capture (inplane-full: every in-plane node, DS1: 912 pairs) and to the "
          "out-of-plane reference capture (oop200k). A ratio near 1 means the in-plane capture "
          "is as good as the dense out-of-plane one at a fraction of its rig time.</p>\n", f);
    static const char *plans[] = {"ds1", "inplane-full", "oop200k"};
    for (size_t s = 0; s < r->scenes.n; s++) {
        const char *scene = r->scenes.name[s];
        fputs("<table><tr>", f);
        th_text(f, "l", 1, "material");
        th_text(f, "l", 1, "model");
        th_text(f, NULL, 3, "full-domain log error");
        th_text(f, NULL, 3, "full-domain relative RMSE");
        th_text(f, NULL, 1, "log error ratio");
        th_text(f, NULL, 2, "rig time");
        fputs("</tr>\n<tr><th class=\"l\">scene ", f);
        html_text(f, scene);
        fputs("</th><th></th>", f);
        for (int d = 0; d < 2; d++)
            for (int i = 0; i < 3; i++)
                th_text(f, NULL, 1, plans[i]);
        fputs("<th>inplane-full / oop200k</th><th>inplane-full</th><th>oop200k</th></tr>\n", f);
        for (size_t m = 0; m < r->materials.n; m++)
            for (size_t k = 0; k < r->models.n; k++) {
                const struct report_row *w[3];
                for (int i = 0; i < 3; i++)
                    w[i] = report_results_find(r, r->materials.name[m], scene, plans[i],
                                               r->models.name[k]);
                if (!w[1] && !w[2])
                    continue;
                fputs("<tr><td class=\"l\">", f);
                html_text(f, r->materials.name[m]);
                fputs("</td><td class=\"l\">", f);
                html_text(f, r->models.name[k]);
                fputs("</td>", f);
                for (int met = 0; met < 2; met++) {
                    double best = INFINITY;
                    for (int i = 0; i < 3; i++)
                        best = fmin(best, err_of(w[i], REPORT_FULL, (enum report_metric)met));
                    for (int i = 0; i < 3; i++) {
                        double v = err_of(w[i], REPORT_FULL, (enum report_metric)met);
                        cell_number(f, v, v == best);
                    }
                }
                double a = err_of(w[1], REPORT_FULL, REPORT_LOG),
                       b = err_of(w[2], REPORT_FULL, REPORT_LOG);
                cell_number(f, b > 0 ? a / b : NAN, 0);
                fputs("<td>", f);
                html_duration(f, w[1] ? w[1]->rig_time_s : NAN);
                fputs("</td><td>", f);
                html_duration(f, w[2] ? w[2]->rig_time_s : NAN);
                fputs("</td></tr>\n", f);
            }
        fputs("</table>\n", f);
    }
}

static void section_figures(struct page *p)
{
    FILE *f = p->f;
    const struct report_results *r = p->r;
    fputs("<h2 id=\"pareto\">Accuracy against rig time</h2>\n<p>Each point is one plan and "
          "model; the grey staircase is the material's Pareto front: the lowest error any "
          "plan and model reach within a rig time. Hover a point for its row.</p>\n", f);
    static const enum report_domain doms[] = {REPORT_FULL, REPORT_INPLANE};
    static const char *dom_ids[] = {"full", "inplane"};
    for (int kind = 0; kind < 2; kind++) {
        if (kind == 1)
            fputs("<h2 id=\"bars\">Relative RMSE per plan and model</h2>\n<p>Relative RMSE is "
                  "dominated by the specular peak; read it beside the log error.</p>\n", f);
        for (size_t s = 0; s < r->scenes.n; s++)
            for (int d = 0; d < 2; d++) {
                struct report_plot_opts po = {r->scenes.name[s], doms[d],
                                              kind ? REPORT_RRMSE : REPORT_LOG, NULL};
                char name[160], *svg = NULL;
                size_t len = 0;
                struct gonio_err e = {0};
                snprintf(name, sizeof name, "%s-%s-%s", kind ? "bars" : "pareto",
                         dom_ids[d], r->scenes.name[s]);
                int rc = kind ? report_plot_bars(r, &po, name, &svg, &len, &e)
                              : report_plot_pareto(r, &po, name, &svg, &len, &e);
                if (rc < 0) {
                    report_note(f, p->o->quiet, "%s: %s", name, e.msg);
                    continue;
                }
                char caption[256];
                snprintf(caption, sizeof caption, "%s: %s on the %s domain, scene %s.",
                         kind ? "Bars" : "Pareto", report_metric_name(po.metric),
                         report_domain_name(po.domain), po.scene);
                figure(p, name, svg, len, caption);
            }
    }
}

/* Slices of one (material, scene, plan): truth, samples and every model. */
static void slices_figure(struct page *p, const char *material, const char *scene,
                          const char *plan)
{
    const struct report_results *r = p->r;
    FILE *f = p->f;
    brdf_material *truth = NULL, *models[REPORT_LIST_MAX] = {0};
    const char *labels[REPORT_LIST_MAX];
    char label_buf[REPORT_LIST_MAX][REPORT_NAME_MAX + 8];
    size_t nm = 0;
    struct report_sample *samples = NULL;
    size_t ns = 0;
    const struct report_row *first = NULL;
    struct gonio_err e = {0};
    char path[4400];
    for (size_t k = 0; k < r->models.n; k++) {
        const struct report_row *w =
            report_results_find(r, material, scene, plan, r->models.name[k]);
        if (!w)
            continue;
        if (!first)
            first = w;
        if (!w->model_file[0] || strcmp(w->status, "ok"))
            continue;
        snprintf(path, sizeof path, "model:%.2000s/%.2000s", p->dir, w->model_file);
        if (!(models[nm] = fit_material_open(path, &e))) {
            report_note(f, p->o->quiet, "%s: model left out of the slices: %s", w->row_id, e.msg);
            continue;
        }
        snprintf(label_buf[nm], sizeof label_buf[nm], "%s", w->model);
        labels[nm] = label_buf[nm];
        nm++;
    }
    if (!first)
        return;
    if (first->material_spec[0] && !(truth = fit_material_open(first->material_spec, &e)))
        report_note(f, p->o->quiet, "%s: ground truth left out of the slices: %s",
                    first->material_spec, e.msg);
    if (first->samples_file[0]) {
        snprintf(path, sizeof path, "%.2000s/%.2000s", p->dir, first->samples_file);
        if (report_samples_read(path, &samples, &ns, NULL, NULL, &e) < 0) {
            report_note(f, p->o->quiet, "%s: samples left out of the slices: %s", path, e.msg);
            samples = NULL;
            ns = 0;
        }
    }
    char title[256], name[200];
    snprintf(title, sizeof title, "%.63s, plan %.63s, scene %.63s: in-plane slices", material,
             plan, scene);
    snprintf(name, sizeof name, "slices-%.63s-%.63s-%.63s", material, scene, plan);
    struct report_slices in = {.title = title,
                               .truth = truth,
                               .truth_label = truth ? first->material_spec : NULL,
                               .models = (const brdf_material *const *)models,
                               .model_labels = labels,
                               .n_models = nm,
                               .samples = samples,
                               .n_samples = ns,
                               .channel = REPORT_Y};
    char *svg = NULL;
    size_t len = 0;
    if (report_plot_slices(&in, name, &svg, &len, &e) < 0) {
        report_note(f, p->o->quiet, "%s: %s", name, e.msg);
    } else {
        char caption[400];
        snprintf(caption, sizeof caption,
                 "BRDF luminance against theta_r for each theta_i (log axis): the ground truth "
                 "(black), the %zu in-plane samples of plan %.63s (circles) and the models fitted "
                 "to them. The dotted line marks the mirror direction.",
                 ns, plan);
        figure(p, name, svg, len, caption);
    }
    brdf_material_free(truth);
    for (size_t k = 0; k < nm; k++)
        brdf_material_free(models[k]);
    free(samples);
}

static void section_slices(struct page *p)
{
    const struct report_results *r = p->r;
    FILE *f = p->f;
    fputs("<h2 id=\"slices\">In-plane slices</h2>\n", f);
    char plans[REPORT_LIST_MAX][REPORT_NAME_MAX];
    size_t np = 0;
    if (p->o->slices_plans) {
        const char *s = p->o->slices_plans;
        while (*s && np < REPORT_LIST_MAX) {
            size_t l = strcspn(s, ",");
            if (l && l < REPORT_NAME_MAX) {
                snprintf(plans[np++], REPORT_NAME_MAX, "%.*s", (int)l, s);
            } /* every name is a plan of the study: check_slices */
            s += l + (s[l] == ',');
        }
    } else {
        if (has_plan(r, "ds2"))
            snprintf(plans[np++], REPORT_NAME_MAX, "ds2");
        if (has_plan(r, "ds4"))
            snprintf(plans[np++], REPORT_NAME_MAX, "ds4");
        if (!np && r->plans.n)
            snprintf(plans[np++], REPORT_NAME_MAX, "%s", r->plans.name[0]);
    }
    if (!r->scenes.n)
        return;
    for (size_t m = 0; m < r->materials.n; m++)
        for (size_t k = 0; k < np; k++)
            slices_figure(p, r->materials.name[m], r->scenes.name[0], plans[k]);
}

static void section_all_rows(struct page *p)
{
    FILE *f = p->f;
    const struct report_results *r = p->r;
    fputs("<h2 id=\"rows\">All results</h2>\n<p>One row per material, scene, plan and model "
          "(results.json of the study). Fit time is CPU time. The premise checks "
          "(docs/checks.md), when the study made them: the isotropy verdict of the capture, "
          "the out-of-plane verdict of the model the capture fitted, each with the rig time it "
          "cost; – where not made.</p>\n<table><tr>", f);
    static const char *heads[] = {"samples", "rig time", "move", "settle", "integration",
                                  "fit", "plan log", "plan rRMSE", "in-plane log",
                                  "in-plane rRMSE", "full log", "full rRMSE"};
    th_text(f, "l", 1, "row");
    for (size_t i = 0; i < sizeof heads / sizeof heads[0]; i++)
        th_text(f, NULL, 1, heads[i]);
    static const char *checks[] = {"isotropy", "isotropy rig time", "out of plane",
                                   "out-of-plane rig time"};
    for (size_t i = 0; i < sizeof checks / sizeof checks[0]; i++)
        th_text(f, i % 2 ? NULL : "l", 1, checks[i]);
    th_text(f, "l", 1, "status");
    fputs("</tr>\n", f);
    for (size_t i = 0; i < r->n_rows; i++) {
        const struct report_row *w = &r->rows[i];
        fputs("<tr><td class=\"l\">", f);
        html_text(f, w->row_id);
        fputs("</td><td>", f);
        html_number(f, w->samples, 7);
        const double t[] = {w->rig_time_s, w->move_s, w->settle_s, w->integration_s,
                            w->fit_cpu_s};
        for (int c = 0; c < 5; c++) {
            fputs("</td><td>", f);
            html_duration(f, t[c]);
        }
        fputs("</td>", f);
        for (int d = 0; d < REPORT_N_DOMAINS; d++)
            for (int m = 0; m < REPORT_N_METRICS; m++)
                cell_number(f, w->err[d][m], 0);
        const char *verdict[] = {w->isotropy, w->oop};
        const double spent[] = {w->isotropy_s, w->oop_s};
        for (int c = 0; c < 2; c++) {
            fputs("<td class=\"l\">", f);
            html_text(f, verdict[c][0] ? verdict[c] : "–");
            fputs("</td><td>", f);
            html_duration(f, spent[c]);
            fputs("</td>", f);
        }
        fputs("<td class=\"l\">", f);
        html_text(f, w->status[0] ? w->status : "ok");
        fputs("</td></tr>\n", f);
    }
    fputs("</table>\n", f);
}

/* --slices names plans the operator asked for: one the study lacks is a
 * usage error (exit 2, nothing written), not a note on a page written anyway. */
static int check_slices(const struct report_results *r, const char *list, struct gonio_err *err)
{
    const char *s = list;
    while (s && *s) {
        size_t l = strcspn(s, ",");
        char plan[REPORT_NAME_MAX];
        if (!l || l >= sizeof plan)
            return gonio_err_set(err, GONIO_EUSAGE, "--slices '%s': not a list of plans", list);
        snprintf(plan, sizeof plan, "%.*s", (int)l, s);
        if (!has_plan(r, plan))
            return gonio_err_set(err, GONIO_EUSAGE, "--slices: the study has no plan '%s'", plan);
        s += l + (s[l] == ',');
    }
    return 0;
}

int report_write_page(const char *dir, const struct report_page_opts *o, struct gonio_err *err)
{
    struct report_results r;
    int rc = report_results_read(dir, &r, err);
    if (rc < 0)
        return rc;
    if ((rc = check_slices(&r, o->slices_plans, err)) < 0) {
        report_results_free(&r);
        return rc;
    }
    char out_buf[4200];
    const char *out = o->out_html;
    if (!out) {
        snprintf(out_buf, sizeof out_buf, "%.4000s/report.html", dir);
        out = out_buf;
    }
    if (o->plots_dir && (rc = gonio_mkdir_p(o->plots_dir, err)) < 0) {
        report_results_free(&r);
        return rc;
    }
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    if (!f) {
        report_results_free(&r);
        return gonio_err_set(err, GONIO_EFIT, "report: out of memory");
    }
    struct page p = {f, dir, o, &r, 0, 0, err};
    fputs("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
          "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
          "<title>gonio study report: ", f);
    html_text(f, dir);
    fprintf(f, "</title>\n<style>%s</style>\n</head>\n<body>\n<h1>What accuracy costs in rig "
               "time</h1>\n<p>Study <code>", css);
    html_text(f, dir);
    fprintf(f, "</code>: %zu rows, %zu materials, %zu scenes, %zu plans, %zu models",
            r.n_rows, r.materials.n, r.scenes.n, r.plans.n, r.models.n);
    if (!r.complete)
        fprintf(f, " — <strong>incomplete: %zu rows missing</strong>", r.n_missing);
    fputs(". Errors are the log error <code>mean |log(1 + f̂ cos θi) − log(1 + f cos θi)|"
          "</code> (the headline) and the relative RMSE <code>sqrt(Σ w (f̂ − f)² / Σ w f²), "
          "w = cos θi</code>, on the plan's own points (model against the measured samples), "
          "the in-plane domain and the full out-of-plane domain (model against the true "
          "material). Rig time is the simulated rig's clock: move, settle and integration."
          "</p>\n<nav><a href=\"#cost\">cost</a><a href=\"#ablation\">DS1→DS4</a>"
          "<a href=\"#inplane\">in-plane vs out-of-plane</a><a href=\"#pareto\">Pareto</a>"
          "<a href=\"#bars\">rRMSE bars</a><a href=\"#slices\">slices</a>"
          "<a href=\"#renders\">renderings</a><a href=\"#rows\">all rows</a></nav>\n", f);
    section_plans(&p);
    section_ablation(&p);
    section_inplane_vs_oop(&p);
    section_figures(&p);
    section_slices(&p);
    fputs("<h2 id=\"renders\">Renderings</h2>\n", f);
    if (!report_page_renders(f, dir, o->quiet))
        fputs("<p>No renderings in this study directory (<code>renders/</code>, written by "
              "<code>gonio render</code>, docs/render.md).</p>\n",
              f);
    section_all_rows(&p);
    fputs("</body>\n</html>\n", f);
    int bad = ferror(f);
    if (fclose(f))
        bad = 1;
    report_results_free(&r);
    if (p.failed) {
        free(buf);
        return err->code ? -err->code : -GONIO_EFIT;
    }
    if (bad) {
        free(buf);
        return gonio_err_set(err, GONIO_EFIT, "report: out of memory");
    }
    rc = gonio_write_file_atomic(out, buf, len, err);
    free(buf);
    return rc < 0 ? rc : 0;
}
