/* Pareto and bar figures of a study (study_plots.h). */
#include "report/study_plots.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "report/pareto.h"
#include "report/plot.h"
#include "report/svg.h"

#define LEFT 80.0
#define RIGHT 24.0
#define GAP_X 84.0
#define GAP_Y 78.0
#define MAX_COLS 3
#define BARS_LOG_RATIO 30.0

static size_t index_of(const struct report_list *l, const char *name)
{
    for (size_t i = 0; i < l->n; i++)
        if (!strcmp(l->name[i], name))
            return i;
    return 0;
}

static double value(const struct report_row *w, const struct report_plot_opts *o)
{
    return w->err[o->domain][o->metric];
}

/* The rows of the scene with a plottable value; counts them per material. */
static const char *scene_of(const struct report_results *r, const struct report_plot_opts *o)
{
    return o->scene ? o->scene : r->scenes.n ? r->scenes.name[0] : "";
}

static int usable(const struct report_row *w, const char *scene,
                  const struct report_plot_opts *o, int need_time)
{
    double v = value(w, o);
    return !strcmp(w->scene, scene) && isfinite(v) && v > 0 &&
           (!need_time || (isfinite(w->rig_time_s) && w->rig_time_s > 0));
}

static void make_title(char *out, size_t cap, const char *what, const char *scene,
                       const struct report_plot_opts *o)
{
    if (o->title)
        snprintf(out, cap, "%s", o->title);
    else
        snprintf(out, cap, "%s: %s on the %s domain, scene %s", what,
                 report_metric_name(o->metric), report_domain_name(o->domain), scene);
}

static const enum svg_marker plan_markers[] = {SVG_CIRCLE,  SVG_SQUARE,        SVG_DIAMOND,
                                               SVG_TRIANGLE, SVG_TRIANGLE_DOWN, SVG_STAR,
                                               SVG_CROSS,   SVG_PLUS};

static struct plot_style model_style(size_t k)
{
    return (struct plot_style){plot_color(k), 0, NULL, SVG_CIRCLE, 8, 0};
}

static struct plot_style plan_style(size_t p, const char *colour)
{
    return (struct plot_style){colour, 0, NULL, plan_markers[p % 8], 8, 0};
}

/* What the panels of a Pareto figure share: the results, the options, the
 * scene, and scratch sized for every row (a panel's points, the row of
 * each, those on the front, and the front's staircase). */
struct pareto_fig {
    const struct report_results *r;
    const struct report_plot_opts *o;
    const char *scene;
    double *x, *y, *sx, *sy;
    size_t *which, *front;
};

static int pareto_alloc(struct pareto_fig *f, struct gonio_err *err)
{
    size_t n = f->r->n_rows;
    f->x = malloc(n * sizeof *f->x);
    f->y = malloc(n * sizeof *f->y);
    f->which = malloc(n * sizeof *f->which);
    f->front = malloc(n * sizeof *f->front);
    f->sx = malloc((2 * n + 2) * sizeof *f->sx);
    f->sy = malloc((2 * n + 2) * sizeof *f->sy);
    if (!f->x || !f->y || !f->which || !f->front || !f->sx || !f->sy)
        return gonio_err_set(err, GONIO_EFIT, "pareto: out of memory");
    return 0;
}

static void pareto_free(struct pareto_fig *f)
{
    free(f->x);
    free(f->y);
    free(f->which);
    free(f->front);
    free(f->sx);
    free(f->sy);
}

/* The materials with a plottable row (their indices in mat_idx), and axes
 * shared by every panel, so materials compare at a glance. Returns their
 * number; the axes are set only when it is not 0. */
static size_t pareto_materials(const struct pareto_fig *f, size_t *mat_idx,
                               struct plot_axis *ax, struct plot_axis *ay)
{
    const struct report_results *r = f->r;
    double xlo = INFINITY, xhi = 0, ylo = INFINITY, yhi = 0;
    size_t n_mat = 0;
    for (size_t m = 0; m < r->materials.n; m++) {
        int any = 0;
        for (size_t i = 0; i < r->n_rows; i++) {
            const struct report_row *w = &r->rows[i];
            if (strcmp(w->material, r->materials.name[m]) || !usable(w, f->scene, f->o, 1))
                continue;
            any = 1;
            xlo = fmin(xlo, w->rig_time_s);
            xhi = fmax(xhi, w->rig_time_s);
            ylo = fmin(ylo, value(w, f->o));
            yhi = fmax(yhi, value(w, f->o));
        }
        if (any)
            mat_idx[n_mat++] = m;
    }
    if (n_mat) {
        plot_axis_fit(ax, PLOT_DURATION, xlo, xhi, 8);
        plot_axis_fit(ay, PLOT_LOG, ylo, yhi, 6);
    }
    return n_mat;
}

/* Legend entries: a colour per model, a marker per plan, the front. */
static size_t pareto_legend(const struct report_results *r, struct plot_legend_entry *le)
{
    size_t nl = 0;
    for (size_t k = 0; k < r->models.n && nl < 16; k++)
        le[nl++] = (struct plot_legend_entry){r->models.name[k], model_style(k)};
    for (size_t p = 0; p < r->plans.n && nl < 32; p++)
        le[nl++] = (struct plot_legend_entry){r->plans.name[p], plan_style(p, "#555555")};
    le[nl++] = (struct plot_legend_entry){"Pareto front", {"#888888", 2.5, NULL, 0, 0, 0}};
    return nl;
}

/* The plottable rows of a material into f->x (rig time), f->y (error) and
 * f->which (row index). Returns their number. */
static size_t pareto_points(struct pareto_fig *f, const char *mat)
{
    size_t n = 0;
    for (size_t i = 0; i < f->r->n_rows; i++) {
        const struct report_row *w = &f->r->rows[i];
        if (!strcmp(w->material, mat) && usable(w, f->scene, f->o, 1)) {
            f->x[n] = w->rig_time_s;
            f->y[n] = value(w, f->o);
            f->which[n++] = i;
        }
    }
    return n;
}

/* The staircase of the nf front points (f->front): from each front point
 * right to the next one's rig time, then down to its error; the last runs
 * to the right edge. Returns its number of vertices, in f->sx, f->sy. */
static size_t pareto_staircase(struct pareto_fig *f, const struct plot_panel *pn, size_t nf)
{
    size_t ns = 0;
    for (size_t j = 0; j < nf; j++) {
        if (j) {
            f->sx[ns] = plot_px(pn, f->x[f->front[j]]);
            f->sy[ns++] = plot_py(pn, f->y[f->front[j - 1]]);
        }
        f->sx[ns] = plot_px(pn, f->x[f->front[j]]);
        f->sy[ns++] = plot_py(pn, f->y[f->front[j]]);
    }
    if (nf) {
        f->sx[ns] = pn->x + pn->w;
        f->sy[ns] = f->sy[ns - 1];
        ns++;
    }
    return ns;
}

/* The n points, marker by plan and colour by model; the nf on the front
 * filled. */
static void pareto_markers(svg_doc *s, const struct pareto_fig *f, const struct plot_panel *pn,
                           size_t n, size_t nf)
{
    const struct report_results *r = f->r;
    for (size_t j = 0; j < n; j++) {
        const struct report_row *w = &r->rows[f->which[j]];
        size_t pi = index_of(&r->plans, w->plan), mi = index_of(&r->models, w->model);
        struct plot_style st = plan_style(pi, plot_color(mi));
        int on_front = 0;
        for (size_t k = 0; k < nf; k++)
            on_front |= f->front[k] == j;
        st.hollow = !on_front; /* the front's points stand out filled */
        char tip[512];
        snprintf(tip, sizeof tip, "%s: %g samples, rig time %.0f s, %s %.4g%s", w->row_id,
                 w->samples, w->rig_time_s, report_metric_name(f->o->metric), f->y[j],
                 on_front ? " (on the Pareto front)" : "");
        plot_draw_marker(s, &st, plot_px(pn, f->x[j]), plot_py(pn, f->y[j]), tip);
    }
}

/* One material's panel: frame, front and points. */
static void pareto_panel(svg_doc *s, struct pareto_fig *f, const char *mat,
                         const struct plot_panel *pn, const char *ylabel)
{
    plot_draw_frame(s, pn, mat, "rig time", ylabel);
    size_t n = pareto_points(f, mat);
    size_t nf = report_pareto_front(f->x, f->y, n, f->front);
    size_t ns = pareto_staircase(f, pn, nf);
    svg_clip_begin(s, pn->x - 6, pn->y - 6, pn->w + 12, pn->h + 12);
    svg_polyline(s, f->sx, f->sy, ns, "#888888", 2.5, NULL);
    pareto_markers(s, f, pn, n, nf);
    svg_group_end(s);
}

int report_plot_pareto(const struct report_results *r, const struct report_plot_opts *o,
                       const char *id_prefix, char **svg, size_t *len, struct gonio_err *err)
{
    struct pareto_fig f = {.r = r, .o = o, .scene = scene_of(r, o)};
    size_t mat_idx[REPORT_LIST_MAX];
    struct plot_axis ax, ay;
    size_t n_mat = pareto_materials(&f, mat_idx, &ax, &ay);
    if (!n_mat)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "pareto: no row of scene '%s' has a %s on the %s domain and a "
                             "rig time",
                             f.scene, report_metric_name(o->metric),
                             report_domain_name(o->domain));
    struct plot_legend_entry le[2 * REPORT_LIST_MAX + 1];
    size_t nl = pareto_legend(r, le);

    double pw = 270, ph = 210;
    size_t cols, rows;
    plot_grid(n_mat, MAX_COLS, &cols, &rows);
    double width = LEFT + (double)cols * pw + (double)(cols - 1) * GAP_X + RIGHT;
    if (width < 560)
        width = 560; /* room for the title and legend with one panel */
    double leg_h = plot_legend_height(width - LEFT - RIGHT, le, nl);
    double first = 40 + leg_h + 30;
    double height = first + (double)rows * ph + (double)(rows - 1) * GAP_Y + 72;
    svg_doc *s = svg_new(width, height, id_prefix);
    if (!s)
        return gonio_err_set(err, GONIO_EFIT, "pareto: out of memory");
    char title[256], ylabel[96];
    make_title(title, sizeof title, "Accuracy against rig time", f.scene, o);
    svg_text(s, width / 2, 22, SVG_MIDDLE, 14, 0, 1, "#222222", title);
    plot_draw_legend(s, LEFT, 34, width - LEFT - RIGHT, le, nl);
    snprintf(ylabel, sizeof ylabel, "%s (%s)", report_metric_name(o->metric),
             report_domain_name(o->domain));

    int rc = pareto_alloc(&f, err);
    if (rc < 0)
        goto out;
    for (size_t k = 0; k < n_mat; k++) {
        struct plot_panel pn = {LEFT + (double)(k % cols) * (pw + GAP_X),
                                first + (double)(k / cols) * (ph + GAP_Y), pw, ph, ax, ay};
        pareto_panel(s, &f, r->materials.name[mat_idx[k]], &pn, k % cols == 0 ? ylabel : NULL);
    }
    svg_text(s, LEFT, height - 10, SVG_START, PLOT_FONT_SMALL, 0, 0, "#555555",
             "Filled markers lie on the Pareto front; hollow ones are beaten on both rig time "
             "and error.");
    *svg = svg_finish(s, len);
    s = NULL;
    if (!*svg)
        rc = gonio_err_set(err, GONIO_EFIT, "pareto: out of memory");
out:
    svg_free(s);
    pareto_free(&f);
    return rc;
}

int report_plot_bars(const struct report_results *r, const struct report_plot_opts *o,
                     const char *id_prefix, char **svg, size_t *len, struct gonio_err *err)
{
    const char *scene = scene_of(r, o);
    size_t n_mat = 0, mat_idx[REPORT_LIST_MAX];
    for (size_t m = 0; m < r->materials.n; m++)
        for (size_t i = 0; i < r->n_rows; i++)
            if (!strcmp(r->rows[i].material, r->materials.name[m]) &&
                usable(&r->rows[i], scene, o, 0)) {
                mat_idx[n_mat++] = m;
                break;
            }
    if (!n_mat)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "bars: no row of scene '%s' has a %s on the %s domain", scene,
                             report_metric_name(o->metric), report_domain_name(o->domain));
    size_t np = r->plans.n, nm = r->models.n;
    /* Bars of 14 units and a gap between groups, wide enough for the name. */
    double group_w = 14.0 * (double)nm + 14;
    for (size_t p = 0; p < np; p++)
        group_w = fmax(group_w, 0.62 * PLOT_FONT_SMALL * (double)strlen(r->plans.name[p]) + 12);
    double pw = fmax(220, group_w * (double)np), ph = 190;
    size_t cols, rows;
    plot_grid(n_mat, pw > 400 ? 2 : MAX_COLS, &cols, &rows);
    double width = fmax(560, LEFT + (double)cols * pw + (double)(cols - 1) * GAP_X + RIGHT);
    struct plot_legend_entry le[REPORT_LIST_MAX];
    size_t nl = 0;
    for (size_t k = 0; k < nm && nl < REPORT_LIST_MAX; k++)
        le[nl++] = (struct plot_legend_entry){r->models.name[k],
                                              {plot_color(k), 0, NULL, SVG_SQUARE, 11, 0}};
    double leg_h = plot_legend_height(width - LEFT - RIGHT, le, nl);
    double first = 40 + leg_h + 30;
    double height = first + (double)rows * ph + (double)(rows - 1) * GAP_Y + 72;
    svg_doc *s = svg_new(width, height, id_prefix);
    if (!s)
        return gonio_err_set(err, GONIO_EFIT, "bars: out of memory");
    char title[256], ylabel[96];
    make_title(title, sizeof title, "Errors per plan and model", scene, o);
    svg_text(s, width / 2, 22, SVG_MIDDLE, 14, 0, 1, "#222222", title);
    plot_draw_legend(s, LEFT, 34, width - LEFT - RIGHT, le, nl);
    snprintf(ylabel, sizeof ylabel, "%s (%s)", report_metric_name(o->metric),
             report_domain_name(o->domain));
    for (size_t k = 0; k < n_mat; k++) {
        const char *mat = r->materials.name[mat_idx[k]];
        double vmax = 0, vmin = INFINITY;
        for (size_t i = 0; i < r->n_rows; i++)
            if (!strcmp(r->rows[i].material, mat) && usable(&r->rows[i], scene, o, 0)) {
                vmax = fmax(vmax, value(&r->rows[i], o));
                vmin = fmin(vmin, value(&r->rows[i], o));
            }
        /* Errors spanning more than a factor 30 (a six-pair fit next to a
         * dense one) go on a log axis, or the small ones are invisible. */
        int log_y = vmax > BARS_LOG_RATIO * vmin;
        struct plot_panel pn = {.x = LEFT + (double)(k % cols) * (pw + GAP_X),
                                .y = first + (double)(k / cols) * (ph + GAP_Y),
                                .w = pw,
                                .h = ph};
        /* One category per plan: x runs 0..np with group p centred at p + 0.5. */
        plot_axis_fixed(&pn.ax, PLOT_LINEAR, 0, (double)np, 3);
        pn.ax.n_ticks = pn.ax.n_minor = 0;
        if (log_y)
            plot_axis_fit(&pn.ay, PLOT_LOG, vmin, vmax, 6);
        else
            plot_axis_fit(&pn.ay, PLOT_LINEAR, 0, vmax, 6);
        char panel_title[REPORT_NAME_MAX + 16];
        snprintf(panel_title, sizeof panel_title, "%s%s", mat, log_y ? " (log axis)" : "");
        plot_draw_frame(s, &pn, panel_title, NULL, k % cols == 0 ? ylabel : NULL);
        double slot = pn.w / (double)np, bw = fmin(14, (slot - 10) / (double)nm);
        for (size_t p = 0; p < np; p++) {
            double cx = pn.x + slot * ((double)p + 0.5);
            svg_text(s, cx, pn.y + pn.h + 15, SVG_MIDDLE, PLOT_FONT_SMALL, 0, 0, "#222222",
                     r->plans.name[p]);
            for (size_t mi = 0; mi < nm; mi++) {
                double bx = cx - bw * (double)nm / 2 + bw * (double)mi;
                const struct report_row *w =
                    report_results_find(r, mat, scene, r->plans.name[p], r->models.name[mi]);
                if (!w)
                    continue;
                double v = value(w, o);
                if (!isfinite(v)) {
                    /* Not available (a model with no value on this domain): say so. */
                    svg_text(s, bx + bw / 2, pn.y + pn.h - 4, SVG_MIDDLE, 8, 0, 0, "#999999",
                             "–");
                    continue;
                }
                double top = plot_py(&pn, v);
                svg_rect(s, bx + 0.5, top, bw - 1, pn.y + pn.h - top, plot_color(mi), NULL, 0);
            }
        }
        svg_text(s, pn.x + pn.w / 2, pn.y + pn.h + 34, SVG_MIDDLE, PLOT_FONT, 0, 0, "#222222",
                 "plan");
    }
    svg_text(s, LEFT, height - 10, SVG_START, PLOT_FONT_SMALL, 0, 0, "#555555",
             "A dash at the baseline: the model has no value on this domain (the in-plane MLP "
             "out of plane) or its fit failed.");
    *svg = svg_finish(s, len);
    if (!*svg)
        return gonio_err_set(err, GONIO_EFIT, "bars: out of memory");
    return 0;
}
