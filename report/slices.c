/* In-plane slices (slices.h). */
#include "report/slices.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/angles.h"
#include "report/plot.h"
#include "report/svg.h"

#define THETA_R_MAX 80.0
#define THETA_R_STEP 0.25
#define N_GRID ((size_t)(2 * THETA_R_MAX / THETA_R_STEP) + 2)
#define PANEL_W 250.0
#define PANEL_H 190.0
#define LEFT 78.0
#define GAP_X 78.0
#define GAP_Y 72.0
#define RIGHT 20.0
#define MAX_COLS 3
#define SAMPLE_TOL_DEG 0.5 /* measured theta_i jitters around the planned one */
#define DYNAMIC_RANGE 1e5  /* the log axis shows at most this ratio below the peak */

double report_channel_value(enum report_channel c, const double rgb[3])
{
    switch (c) {
    case REPORT_R: return rgb[0];
    case REPORT_G: return rgb[1];
    case REPORT_B: return rgb[2];
    case REPORT_Y: break;
    }
    return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

int report_slices_theta_i(const struct report_slices *in, double *out, struct gonio_err *err)
{
    if (in->n_theta_i) {
        if (in->n_theta_i > REPORT_SLICES_MAX_PANELS)
            return gonio_err_set(err, GONIO_EUSAGE, "theta_i: %zu panels asked for, at most %d",
                                 in->n_theta_i, REPORT_SLICES_MAX_PANELS);
        for (size_t i = 0; i < in->n_theta_i; i++) {
            if (!(in->theta_i[i] >= 0 && in->theta_i[i] <= 89))
                return gonio_err_set(err, GONIO_EUSAGE,
                                     "theta_i: %g is outside 0..89 degrees", in->theta_i[i]);
            out[i] = in->theta_i[i];
        }
        return (int)in->n_theta_i;
    }
    if (!in->n_samples) {
        for (int i = 0; i < 6; i++)
            out[i] = 15.0 * i;
        return 6;
    }
    /* The distinct planned theta_i of the samples (rounded to 0.5 degree). */
    double *t = malloc((in->n_samples + 6) * sizeof *t);
    if (!t)
        return gonio_err_set(err, GONIO_EFIT, "out of memory");
    size_t n = 0;
    for (size_t i = 0; i < in->n_samples; i++)
        if (isfinite(in->samples[i].theta_i))
            t[n++] = round(2 * in->samples[i].theta_i) / 2;
    qsort(t, n, sizeof *t, cmp_double);
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        if (!m || t[i] - t[m - 1] > SAMPLE_TOL_DEG)
            t[m++] = t[i];
    int k = 0;
    if (m < 3) {
        /* One or two incidences (a six-pair plan): show them among the
         * standard ones, so the figure also shows how the models
         * extrapolate to the incidences that were not measured. */
        for (int i = 0; i < 6; i++) {
            int dup = 0;
            for (size_t j = 0; j < m; j++)
                dup |= fabs(t[j] - 15.0 * i) <= SAMPLE_TOL_DEG;
            if (!dup)
                t[m++] = 15.0 * i;
        }
        qsort(t, m, sizeof *t, cmp_double);
        for (size_t i = 0; i < m; i++)
            out[k++] = t[i];
    } else if (m <= 6) {
        for (size_t i = 0; i < m; i++)
            out[k++] = t[i];
    } else {
        for (int i = 0; i < 6; i++)
            out[k++] = t[(size_t)llround((double)i * (double)(m - 1) / 5.0)];
    }
    free(t);
    if (!k)
        return gonio_err_set(err, GONIO_EBADDATA, "the samples have no finite theta_i");
    return k;
}

/* The theta_r at which curves are evaluated: a fine grid plus the exact
 * mirror direction, where a glossy peak is. Returns their number. */
static size_t theta_r_grid(double theta_i, double *tr)
{
    size_t n = 0;
    int steps = (int)llround(2 * THETA_R_MAX / THETA_R_STEP);
    for (int k = 0; k <= steps; k++) {
        double t = -THETA_R_MAX + k * THETA_R_STEP;
        if (theta_i > t - THETA_R_STEP + 1e-9 && theta_i < t - 1e-9)
            tr[n++] = theta_i;
        tr[n++] = t;
    }
    return n;
}

/* Values of a material along theta_r at one theta_i. */
static void eval_slice(const brdf_material *m, double theta_i, const double *tr, size_t n,
                       enum report_channel c, struct brdf_pair *pairs, double *rgb, double *out)
{
    for (size_t i = 0; i < n; i++)
        brdf_pair_inplane(theta_i, tr[i], &pairs[i]);
    brdf_material_eval(m, pairs, n, rgb);
    for (size_t i = 0; i < n; i++) {
        double v = report_channel_value(c, rgb + 3 * i);
        out[i] = v > 0 && isfinite(v) ? v : NAN;
    }
}

static void extend(double v, double *lo, double *hi)
{
    if (v > 0 && isfinite(v)) {
        *lo = v < *lo ? v : *lo;
        *hi = v > *hi ? v : *hi;
    }
}

static const char *dashes[] = {NULL, "7 3", "2 2.5", "9 3 2 3"};

/* What the panels of one figure share: the input, its incidences, every
 * curve evaluated once (a row of N_GRID values per panel and curve: the
 * truth first if there is one, then the models) and the scratch buffers
 * the evaluation and the drawing reuse. */
struct slices_fig {
    const struct report_slices *in;
    double ti[REPORT_SLICES_MAX_PANELS];
    int np;
    size_t n_curves;
    double *tr, *vals, *rgb, *px, *py;
    struct brdf_pair *pairs;
};

static int fig_alloc(struct slices_fig *f, struct gonio_err *err)
{
    size_t rows = (size_t)f->np * (f->n_curves ? f->n_curves : 1);
    f->tr = malloc(N_GRID * sizeof *f->tr);
    f->vals = malloc(rows * N_GRID * sizeof *f->vals);
    f->rgb = malloc(3 * N_GRID * sizeof *f->rgb);
    f->pairs = malloc(N_GRID * sizeof *f->pairs);
    f->px = malloc(N_GRID * sizeof *f->px);
    f->py = malloc(N_GRID * sizeof *f->py);
    if (!f->tr || !f->vals || !f->rgb || !f->pairs || !f->px || !f->py)
        return gonio_err_set(err, GONIO_EFIT, "slices: out of memory");
    return 0;
}

static void fig_free(struct slices_fig *f)
{
    free(f->tr);
    free(f->vals);
    free(f->rgb);
    free(f->pairs);
    free(f->px);
    free(f->py);
}

static double *curve_values(const struct slices_fig *f, int p, size_t c)
{
    return f->vals + ((size_t)p * f->n_curves + c) * N_GRID;
}

/* Evaluates every curve and returns the y range in *lo..*hi: it comes from
 * the truth and the samples (models that run wild are clipped, not allowed
 * to squash the axis), or from the models when there is nothing else. */
static int evaluate_curves(struct slices_fig *f, double *lo, double *hi, struct gonio_err *err)
{
    const struct report_slices *in = f->in;
    double mlo = INFINITY, mhi = 0;
    *lo = INFINITY;
    *hi = 0;
    for (int p = 0; p < f->np; p++) {
        size_t ng = theta_r_grid(f->ti[p], f->tr);
        for (size_t c = 0; c < f->n_curves; c++) {
            const brdf_material *m = in->truth ? (c ? in->models[c - 1] : in->truth)
                                               : in->models[c];
            double *v = curve_values(f, p, c);
            eval_slice(m, f->ti[p], f->tr, ng, in->channel, f->pairs, f->rgb, v);
            for (size_t i = 0; i < ng; i++)
                extend(v[i], in->truth && !c ? lo : &mlo, in->truth && !c ? hi : &mhi);
        }
    }
    for (size_t i = 0; i < in->n_samples; i++)
        extend(report_channel_value(in->channel, in->samples[i].rgb), lo, hi);
    if (!(*hi > 0)) {
        *lo = mlo;
        *hi = mhi;
    }
    if (!(*hi > 0))
        return gonio_err_set(err, GONIO_EBADDATA, "slices: no positive value to plot");
    if (*lo < *hi / DYNAMIC_RANGE)
        *lo = *hi / DYNAMIC_RANGE;
    return 0;
}

/* Legend entries: truth, samples, models (at most 16, named in names[]).
 * Returns their number. */
static size_t slices_legend(const struct report_slices *in, struct plot_legend_entry *le,
                            char names[][96])
{
    size_t nl = 0;
    if (in->truth)
        le[nl++] = (struct plot_legend_entry){
            in->truth_label ? in->truth_label : "ground truth", {"#000000", 1.6, NULL, 0, 0, 0}};
    if (in->n_samples)
        le[nl++] = (struct plot_legend_entry){
            "samples", {"#000000", 0, NULL, SVG_CIRCLE, 5.5, 1}};
    for (size_t k = 0; k < in->n_models && k < 16; k++) {
        const char *name = in->model_labels && in->model_labels[k]
                               ? in->model_labels[k]
                               : brdf_material_name(in->models[k]);
        snprintf(names[k], 96, "%s", name);
        le[nl++] = (struct plot_legend_entry){
            names[k], {plot_color(k), 1.5, dashes[k % 4], 0, 0, 0}};
    }
    return nl;
}

static const char *channel_ylabel(enum report_channel c)
{
    return c == REPORT_Y   ? "BRDF (luminance), 1/sr"
           : c == REPORT_R ? "BRDF (red), 1/sr"
           : c == REPORT_G ? "BRDF (green), 1/sr"
                           : "BRDF (blue), 1/sr";
}

/* The curves of panel p, models under the truth so the truth stays
 * readable. */
static void draw_curves(svg_doc *s, const struct slices_fig *f, int p,
                        const struct plot_panel *pn)
{
    const struct report_slices *in = f->in;
    size_t ng = theta_r_grid(f->ti[p], f->tr);
    double *px = f->px, *py = f->py;
    for (size_t c = f->n_curves; c-- > 0;) {
        const double *v = curve_values(f, p, c);
        for (size_t i = 0; i < ng; i++) {
            px[i] = plot_px(pn, f->tr[i]);
            py[i] = plot_py(pn, v[i]);
            /* Far outside the area: cut, so a runaway model draws no
             * giant coordinates. */
            if (py[i] < pn->y - 4 * pn->h || py[i] > pn->y + 5 * pn->h)
                py[i] = py[i] < pn->y ? pn->y - 4 * pn->h : pn->y + 5 * pn->h;
        }
        int is_truth = in->truth && c == 0;
        size_t k = in->truth ? c - 1 : c;
        svg_polyline(s, px, py, ng, is_truth ? "#000000" : plot_color(k),
                     is_truth ? 1.6 : 1.5, is_truth ? NULL : dashes[k % 4]);
    }
}

/* The samples measured at (about) the panel's incidence ti. */
static void draw_samples(svg_doc *s, const struct report_slices *in, double ti,
                         const struct plot_panel *pn)
{
    struct plot_style sst = {"#000000", 0, NULL, SVG_CIRCLE, 5.5, 1};
    for (size_t i = 0; i < in->n_samples; i++) {
        const struct report_sample *sm = &in->samples[i];
        if (!(fabs(sm->theta_i - ti) <= SAMPLE_TOL_DEG))
            continue;
        double v = report_channel_value(in->channel, sm->rgb);
        char tip[128];
        snprintf(tip, sizeof tip, "θi %.2f°, θr %.2f°: %.4g 1/sr", sm->theta_i, sm->theta_r, v);
        plot_draw_marker(s, &sst, plot_px(pn, sm->theta_r), plot_py(pn, v), tip);
    }
}

/* Panel p: frame, mirror direction, curves and samples, clipped to its area. */
static void draw_panel(svg_doc *s, const struct slices_fig *f, int p,
                       const struct plot_panel *pn, const char *ylabel)
{
    char title[64];
    snprintf(title, sizeof title, "θi = %g°", f->ti[p]);
    plot_draw_frame(s, pn, title, "θr, degrees", ylabel);
    svg_clip_begin(s, pn->x, pn->y, pn->w, pn->h);
    double xm = plot_px(pn, f->ti[p]);
    svg_line(s, xm, pn->y, xm, pn->y + pn->h, "#9a9a9a", 0.8, "3 3"); /* mirror direction */
    draw_curves(s, f, p, pn);
    draw_samples(s, f->in, f->ti[p], pn);
    svg_group_end(s);
}

int report_plot_slices(const struct report_slices *in, const char *id_prefix, char **svg,
                       size_t *len, struct gonio_err *err)
{
    struct slices_fig f = {.in = in};
    f.np = report_slices_theta_i(in, f.ti, err);
    if (f.np < 0)
        return f.np;
    if (!in->truth && !in->n_models && !in->n_samples)
        return gonio_err_set(err, GONIO_EUSAGE, "slices: nothing to draw (no material, model "
                                                "or samples)");
    f.n_curves = (in->truth ? 1 : 0) + in->n_models;
    svg_doc *s = NULL;
    double lo, hi;
    int rc = fig_alloc(&f, err);
    if (rc == 0)
        rc = evaluate_curves(&f, &lo, &hi, err);
    if (rc < 0)
        goto out;
    struct plot_axis ax, ay;
    plot_axis_fixed(&ax, PLOT_LINEAR, -THETA_R_MAX, THETA_R_MAX, 9);
    plot_axis_fit(&ay, PLOT_LOG, lo, hi, 7);
    struct plot_legend_entry le[2 + 16];
    char model_names[16][96];
    size_t nl = slices_legend(in, le, model_names);

    size_t cols, rows;
    plot_grid((size_t)f.np, MAX_COLS, &cols, &rows);
    double width = LEFT + (double)cols * PANEL_W + (double)(cols - 1) * GAP_X + RIGHT;
    if (in->title && width < 0.62 * 14 * (double)strlen(in->title) + 40)
        width = 0.62 * 14 * (double)strlen(in->title) + 40; /* the title fits */
    double top = in->title ? 34 : 12;
    double leg_h = plot_legend_height(width - LEFT - RIGHT, le, nl);
    double first = top + leg_h + 30;
    double height = first + (double)rows * PANEL_H + (double)(rows - 1) * GAP_Y + 50;
    s = svg_new(width, height, id_prefix);
    if (!s) {
        rc = gonio_err_set(err, GONIO_EFIT, "slices: out of memory");
        goto out;
    }
    if (in->title)
        svg_text(s, width / 2, 22, SVG_MIDDLE, 14, 0, 1, "#222222", in->title);
    plot_draw_legend(s, LEFT, top, width - LEFT - RIGHT, le, nl);
    for (int p = 0; p < f.np; p++) {
        struct plot_panel pn = {LEFT + (double)((size_t)p % cols) * (PANEL_W + GAP_X),
                                first + (double)((size_t)p / cols) * (PANEL_H + GAP_Y),
                                PANEL_W, PANEL_H, ax, ay};
        draw_panel(s, &f, p, &pn, (size_t)p % cols == 0 ? channel_ylabel(in->channel) : NULL);
    }
    *svg = svg_finish(s, len);
    s = NULL;
    if (!*svg)
        rc = gonio_err_set(err, GONIO_EFIT, "slices: out of memory");
out:
    svg_free(s);
    fig_free(&f);
    return rc;
}
