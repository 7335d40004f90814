/* Loading plans: YAML to points, reachability, declared order. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/angles.h"
#include "brdf/domain.h"
#include "common/cfg.h"
#include "common/paths.h"
#include "planner/plan_private.h"

static const char *const order_names[] = {"travel", "progressive", "as-written", "greedy",
                                          "adaptive", NULL};

const char *plan_order_name(enum plan_order_mode mode)
{
    return (unsigned)mode <= PLAN_ORDER_ADAPTIVE ? order_names[mode] : "?";
}

int plan_order_parse(const char *name)
{
    for (int i = 0; order_names[i]; i++)
        if (!strcmp(order_names[i], name))
            return i;
    return -1;
}

/* Grid values are base + k*step from an integer k, never accumulated, and
 * compared with a tolerance far below any sensible step, so 0.1-degree
 * steps give the same pairs as integer ones would. */
#define GRID_EPS 1e-9

static int grid_add(struct plan_point **pts, size_t *n, size_t *cap, double ti, double tr)
{
    if (*n == *cap) {
        size_t nc = *cap ? 2 * *cap : 256;
        struct plan_point *p = realloc(*pts, nc * sizeof *p);
        if (!p)
            return -ENOMEM;
        *pts = p;
        *cap = nc;
    }
    struct plan_point *pt = &(*pts)[(*n)++];
    memset(pt, 0, sizeof *pt);
    pt->theta_i = ti;
    pt->theta_r = tr;
    return 0;
}

static int cmp_point(const void *x, const void *y)
{
    const struct plan_point *a = x, *b = y;
    if (a->theta_i != b->theta_i)
        return a->theta_i < b->theta_i ? -1 : 1;
    if (a->theta_r != b->theta_r)
        return a->theta_r < b->theta_r ? -1 : 1;
    return 0;
}

static int same_pair(const struct plan_point *a, const struct plan_point *b)
{
    return fabs(a->theta_i - b->theta_i) < 1e-6 && fabs(a->theta_r - b->theta_r) < 1e-6 &&
           a->out_of_plane == b->out_of_plane && fabs(a->phi_i - b->phi_i) < 1e-6 &&
           fabs(a->theta_o - b->theta_o) < 1e-6 && fabs(a->phi_o - b->phi_o) < 1e-6;
}

static void inplane_fill(struct plan_point *pt)
{
    pt->phi_i = 0;
    pt->theta_o = fabs(pt->theta_r);
    pt->phi_o = pt->theta_r >= 0 ? 180 : 0;
}

int plan_grid_generate(const struct plan_grid *g, struct plan_point **out)
{
    struct plan_point *pts = NULL;
    size_t n = 0, cap = 0;
    long ni = (long)floor(g->theta_i_max / g->theta_i_step + GRID_EPS);
    long nd = (long)floor((g->theta_r_max - g->theta_r_min) / g->diffuse_step + GRID_EPS);
    long ng = (long)floor(g->glossy_half_width / g->glossy_step + GRID_EPS);
    for (long i = 0; i <= ni; i++) {
        double ti = (double)i * g->theta_i_step;
        for (long k = 0; k <= nd; k++) {
            double tr = g->theta_r_min + (double)k * g->diffuse_step;
            if (fabs(tr - ti) > g->glossy_half_width + GRID_EPS &&
                fabs(ti + tr) >= g->blind - GRID_EPS && grid_add(&pts, &n, &cap, ti, tr) < 0)
                goto nomem;
        }
        for (long k = -ng; k <= ng; k++) {
            double tr = ti + (double)k * g->glossy_step;
            if (tr >= g->theta_r_min - GRID_EPS && tr <= g->theta_r_max + GRID_EPS &&
                fabs(ti + tr) >= g->blind - GRID_EPS && grid_add(&pts, &n, &cap, ti, tr) < 0)
                goto nomem;
        }
    }
    qsort(pts, n, sizeof *pts, cmp_point);
    size_t m = 0;
    for (size_t i = 0; i < n; i++) {
        if (m && same_pair(&pts[m - 1], &pts[i]))
            continue;
        pts[m] = pts[i];
        inplane_fill(&pts[m]);
        m++;
    }
    if (!pts && !(pts = malloc(sizeof *pts)))
        return -ENOMEM;
    *out = pts;
    return (int)m;
nomem:
    free(pts);
    return -ENOMEM;
}

static double wrap180(double deg)
{
    double w = fmod(deg + 180.0, 360.0);
    if (w <= 0)
        w += 360.0;
    return w - 180.0; /* (-180, 180] */
}

static int in_limits(double v, const struct rig_axis *ax)
{
    return v >= ax->min - 1e-9 && v <= ax->max + 1e-9;
}

int plan_point_place(struct plan_point *pt, const struct rig_profile *rig, char *reason,
                     size_t size)
{
    if (!pt->out_of_plane) {
        brdf_inplane_to_axes(pt->theta_i, pt->theta_r, &pt->ax.s, &pt->ax.a);
        pt->ax.az = 0;
    } else {
        if (!rig->out_of_plane) {
            snprintf(reason, size, "needs an out-of-plane axis and rig '%s' has none",
                     rig->name);
            return -GONIO_EUNREACHABLE;
        }
        /* Nominal three-axis mapping: sample tilt, arm at the polar angle
         * as if forward-scattering, sample azimuth turning the detector's
         * plane; phi_o - phi_i = 180 is the in-plane forward case (az = 0). */
        pt->ax.s = pt->theta_i;
        pt->ax.a = pt->theta_i + pt->theta_o;
        pt->ax.az = wrap180(pt->phi_o - pt->phi_i - 180.0);
    }
    if (!in_limits(pt->ax.s, &rig->sample)) {
        snprintf(reason, size, "sample axis at s = %g deg is beyond its limits %g..%g",
                 pt->ax.s, rig->sample.min, rig->sample.max);
        return -GONIO_EUNREACHABLE;
    }
    if (!in_limits(pt->ax.a, &rig->arm)) {
        snprintf(reason, size, "detector arm at a = %g deg is beyond its limits %g..%g",
                 pt->ax.a, rig->arm.min, rig->arm.max);
        return -GONIO_EUNREACHABLE;
    }
    if (pt->out_of_plane && !in_limits(pt->ax.az, &rig->azimuth)) {
        snprintf(reason, size, "azimuth axis at %g deg is beyond its limits %g..%g",
                 pt->ax.az, rig->azimuth.min, rig->azimuth.max);
        return -GONIO_EUNREACHABLE;
    }
    double sep = fabs(pt->ax.a);
    if (pt->out_of_plane) {
        struct brdf_pair p;
        brdf_pair_spherical(pt->theta_i, pt->phi_i, pt->theta_o, pt->phi_o, &p);
        double c = p.wi[0] * p.wo[0] + p.wi[1] * p.wo[1] + p.wi[2] * p.wo[2];
        sep = acos(fmax(-1.0, fmin(1.0, c))) / BRDF_DEG;
    }
    if (pt->out_of_plane ? sep < rig->blind_deg - 1e-9
                         : brdf_axes_in_blind_zone(pt->ax.a, rig->blind_deg - 1e-9)) {
        if (pt->out_of_plane)
            snprintf(reason, size,
                     "detector at %g deg from the source is inside the %g deg blind zone", sep,
                     rig->blind_deg);
        else
            snprintf(reason, size, "detector arm at a = %g deg is inside the %g deg blind zone",
                     pt->ax.a, rig->blind_deg);
        return -GONIO_EUNREACHABLE;
    }
    return 0;
}

static void describe(const struct plan_point *pt, char *buf, size_t size)
{
    if (pt->out_of_plane)
        snprintf(buf, size, "pair (theta_i %g, phi_i %g, theta_o %g, phi_o %g)", pt->theta_i,
                 pt->phi_i, pt->theta_o, pt->phi_o);
    else
        snprintf(buf, size, "pair (theta_i %g, theta_r %g)", pt->theta_i, pt->theta_r);
}

static int load_grid(const struct cfg_doc *d, const struct cfg_node *gn, double rig_blind,
                     struct plan *p, struct gonio_err *err)
{
    static const char *const keys[] = {"theta_i_step", "theta_i_max", "diffuse_step",
                                       "glossy_step", "glossy_half_width", "theta_r_min",
                                       "theta_r_max", "blind", NULL};
    struct plan_grid g = {.theta_i_max = 80, .glossy_half_width = 15, .theta_r_min = -80,
                          .theta_r_max = 80, .blind = rig_blind};
    int rc;
    if ((rc = cfg_check_keys(d, gn, "grid", keys, err)) < 0 ||
        (rc = cfg_double(d, gn, "theta_i_step", CFG_REQUIRED, 0.01, 90, &g.theta_i_step,
                         err)) < 0 ||
        (rc = cfg_double(d, gn, "theta_i_max", CFG_OPTIONAL, 0, 90, &g.theta_i_max, err)) < 0 ||
        (rc = cfg_double(d, gn, "diffuse_step", CFG_REQUIRED, 0.01, 180, &g.diffuse_step,
                         err)) < 0 ||
        (rc = cfg_double(d, gn, "glossy_step", CFG_REQUIRED, 0.01, 90, &g.glossy_step,
                         err)) < 0 ||
        (rc = cfg_double(d, gn, "glossy_half_width", CFG_OPTIONAL, 0, 90, &g.glossy_half_width,
                         err)) < 0 ||
        (rc = cfg_double(d, gn, "theta_r_min", CFG_OPTIONAL, -90, 90, &g.theta_r_min, err)) < 0 ||
        (rc = cfg_double(d, gn, "theta_r_max", CFG_OPTIONAL, -90, 90, &g.theta_r_max, err)) < 0 ||
        (rc = cfg_double(d, gn, "blind", CFG_OPTIONAL, 0, 45, &g.blind, err)) < 0)
        return rc;
    if (g.theta_r_min >= g.theta_r_max)
        return cfg_error(d, cfg_get(d, gn, "theta_r_max"), "theta_r_max", err,
                         "must exceed theta_r_min (value '%g', allowed %g..90)", g.theta_r_max,
                         g.theta_r_min);
    /* Refuse a grid too fine to hold before generating it: a step of 0.01
     * on both axes would be 1.6e8 pairs (about 20 GB). */
    double rows = floor(g.theta_i_max / g.theta_i_step + GRID_EPS) + 1,
           per_row = floor((g.theta_r_max - g.theta_r_min) / g.diffuse_step + GRID_EPS) + 1 +
                     2 * floor(g.glossy_half_width / g.glossy_step + GRID_EPS) + 1;
    if (rows * per_row > PLAN_MAX_POINTS)
        return cfg_error(d, gn, "grid", err,
                         "up to %.0f pairs (%.0f theta_i rows of %.0f), more than a plan "
                         "holds (%d); use coarser steps", rows * per_row, rows, per_row,
                         PLAN_MAX_POINTS);
    rc = plan_grid_generate(&g, &p->pts);
    if (rc < 0)
        return gonio_err_set(err, -rc, "%s: out of memory", cfg_path(d));
    /* The grid's blind is the rule's own; a rig that sees less near the
     * source (a 10 deg blind zone against the plans' 5) leaves out the pairs
     * it cannot reach and counts them, as domain plans do, instead of
     * refusing the whole plan (docs/plans.md, "Reachability"). */
    p->n = 0;
    for (int i = 0; i < rc; i++) {
        if (fabs(p->pts[i].theta_i + p->pts[i].theta_r) < rig_blind - GRID_EPS)
            p->dropped++;
        else
            p->pts[p->n++] = p->pts[i];
    }
    int line, col;
    cfg_mark(gn, &line, &col);
    for (size_t i = 0; i < p->n; i++) {
        p->pts[i].line = line;
        p->pts[i].col = col;
    }
    return 0;
}

static int load_pairs(const struct cfg_doc *d, const struct cfg_node *seq, struct plan *p,
                      struct gonio_err *err)
{
    size_t n = cfg_seq_len(d, seq);
    if (n == 0 || n > PLAN_MAX_POINTS)
        return cfg_error(d, seq, "pairs", err, "%zu pairs (allowed 1..%d pairs)", n,
                         PLAN_MAX_POINTS);
    p->pts = calloc(n, sizeof *p->pts);
    if (!p->pts)
        return gonio_err_set(err, ENOMEM, "%s: out of memory", cfg_path(d));
    size_t first_len = 0;
    for (size_t i = 0; i < n; i++) {
        const struct cfg_node *item = cfg_seq_item(d, seq, i);
        size_t len = cfg_seq_len(d, item);
        if (!cfg_is_seq(d, item) || (len != 2 && len != 4))
            return cfg_error(d, item, "pairs", err,
                             "item %zu: expected [theta_i, theta_r] or "
                             "[theta_i, phi_i, theta_o, phi_o]",
                             i + 1);
        if (i == 0)
            first_len = len;
        else if (len != first_len)
            return cfg_error(d, item, "pairs", err,
                             "item %zu: mixes in-plane and out-of-plane pairs", i + 1);
        struct plan_point *pt = &p->pts[i];
        double v[4];
        static const double lo2[] = {0, -90}, hi2[] = {90, 90};
        static const double lo4[] = {0, -360, 0, -360}, hi4[] = {90, 360, 90, 360};
        static const char *const n2[] = {"theta_i", "theta_r"};
        static const char *const n4[] = {"theta_i", "phi_i", "theta_o", "phi_o"};
        for (size_t k = 0; k < len; k++) {
            int rc = cfg_node_double(d, cfg_seq_item(d, item, k), len == 2 ? n2[k] : n4[k],
                                     len == 2 ? lo2[k] : lo4[k], len == 2 ? hi2[k] : hi4[k],
                                     &v[k], err);
            if (rc < 0)
                return rc;
        }
        if (len == 2) {
            pt->theta_i = v[0];
            pt->theta_r = v[1];
            inplane_fill(pt);
        } else {
            pt->out_of_plane = 1;
            pt->theta_i = v[0];
            pt->phi_i = v[1];
            pt->theta_o = v[2];
            pt->phi_o = v[3];
        }
        cfg_mark(item, &pt->line, &pt->col);
        for (size_t j = 0; j < i; j++) {
            if (same_pair(&p->pts[j], pt)) {
                char what[160];
                describe(pt, what, sizeof what);
                return cfg_error(d, item, "pairs", err, "%s listed twice (first at line %d)",
                                 what, p->pts[j].line);
            }
        }
        p->n = i + 1;
    }
    p->out_of_plane = first_len == 4;
    return 0;
}

static int load_stop(const struct cfg_doc *d, const struct cfg_node *root, struct plan *p,
                     struct gonio_err *err)
{
    static const char *const top[] = {"converge", NULL};
    static const char *const keys[] = {"tol", "rounds", "every", "min_points", NULL};
    /* Defaults chosen with bench/stream_replay on DS1 (docs/fitting.md);
     * min_points 0 stands for "11/40 of the plan", set once the points
     * are known. They hold for `stop: all` too, for `gonio capture --stop
     * converge`. */
    p->stop = (struct plan_stop){PLAN_STOP_ALL, 0.008, 2, 24, 0};
    const struct cfg_node *s = cfg_get(d, root, "stop"), *c;
    if (!s)
        return 0;
    if (cfg_is_scalar(d, s)) {
        static const char *const names[] = {"all", NULL};
        int dummy;
        return cfg_enum(d, root, "stop", CFG_REQUIRED, names, &dummy, err) < 0
                   ? -GONIO_EBADCONFIG
                   : 0;
    }
    int rc;
    if ((rc = cfg_check_keys(d, s, "stop", top, err)) < 0 ||
        (rc = cfg_map(d, s, "converge", CFG_REQUIRED, &c, err)) < 0 ||
        (rc = cfg_check_keys(d, c, "converge", keys, err)) < 0 ||
        (rc = cfg_double(d, c, "tol", CFG_OPTIONAL, 1e-9, 1, &p->stop.tol, err)) < 0 ||
        (rc = cfg_int(d, c, "rounds", CFG_OPTIONAL, 1, 1000, &p->stop.rounds, err)) < 0 ||
        (rc = cfg_int(d, c, "every", CFG_OPTIONAL, 1, 1000000, &p->stop.every, err)) < 0 ||
        (rc = cfg_int(d, c, "min_points", CFG_OPTIONAL, 1, 100000000, &p->stop.min_points,
                      err)) < 0)
        return rc;
    p->stop.kind = PLAN_STOP_CONVERGE;
    return 0;
}

/* Spherical angles (degrees) of a unit direction. */
static void to_spherical(const double w[3], double *theta, double *phi)
{
    *theta = acos(fmax(-1.0, fmin(1.0, w[2]))) / BRDF_DEG;
    *phi = (fabs(w[0]) < 1e-15 && fabs(w[1]) < 1e-15) ? 0.0 : atan2(w[1], w[0]) / BRDF_DEG;
}

/* Reference-domain plans (brdf/domain.h). The domains are the error
 * domains of DESIGN.md section 3 and include retro-reflection nodes (light
 * and detector together) that no rig can measure: like the grid rule's
 * blind zone, the generator drops nodes inside the rig's blind zone and
 * counts them; every other unreachable node is refused as usual. */
static int load_domain(const struct cfg_doc *d, const struct cfg_node *dn,
                       const struct rig_profile *rig, struct plan *p, struct gonio_err *err)
{
    static const char *const keys[] = {"set", "n", "seed", NULL};
    static const char *const sets[] = {"full", "inplane", "oop-random", NULL};
    int set;
    long n = BRDF_DOMAIN_OOP200K_N, seed = (long)BRDF_DOMAIN_OOP200K_SEED;
    int rc;
    if ((rc = cfg_check_keys(d, dn, "domain", keys, err)) < 0 ||
        (rc = cfg_enum(d, dn, "set", CFG_REQUIRED, sets, &set, err)) < 0 ||
        (rc = cfg_int(d, dn, "n", CFG_OPTIONAL, 1, PLAN_MAX_POINTS, &n, err)) < 0 ||
        (rc = cfg_int(d, dn, "seed", CFG_OPTIONAL, 0, 0x7fffffffL, &seed, err)) < 0)
        return rc;
    if (set != PLAN_DOMAIN_OOP_RANDOM && cfg_get(d, dn, "n"))
        return cfg_error(d, cfg_get(d, dn, "n"), "n", err,
                         "only for set oop-random (set '%s' takes every node)", sets[set]);
    struct brdf_domain dom = {0};
    struct gonio_err derr = {0};
    if (set == PLAN_DOMAIN_FULL)
        rc = brdf_domain_full(&dom, &derr);
    else if (set == PLAN_DOMAIN_INPLANE)
        rc = brdf_domain_inplane(&dom, &derr);
    else
        rc = brdf_domain_oop_random(&dom, (size_t)n, (uint64_t)seed, &derr);
    if (rc < 0)
        return cfg_error(d, dn, "domain", err, "%s", derr.msg);
    p->pts = calloc(dom.n ? dom.n : 1, sizeof *p->pts);
    if (!p->pts) {
        brdf_domain_free(&dom);
        return gonio_err_set(err, ENOMEM, "%s: out of memory", cfg_path(d));
    }
    int line, col;
    cfg_mark(dn, &line, &col);
    p->out_of_plane = set != PLAN_DOMAIN_INPLANE;
    p->n = 0;
    for (size_t i = 0; i < dom.n; i++) {
        struct plan_point *pt = &p->pts[p->n];
        const struct brdf_pair *bp = &dom.pairs[i];
        if (!p->out_of_plane) {
            if (brdf_pair_to_inplane(bp, &pt->theta_i, &pt->theta_r) < 0) {
                brdf_domain_free(&dom);
                return cfg_error(d, dn, "domain", err, "in-plane node %zu is out of plane", i);
            }
            inplane_fill(pt);
        } else {
            pt->out_of_plane = 1;
            to_spherical(bp->wi, &pt->theta_i, &pt->phi_i);
            to_spherical(bp->wo, &pt->theta_o, &pt->phi_o);
        }
        pt->line = line;
        pt->col = col;
        char reason[256];
        if (plan_point_place(pt, rig, reason, sizeof reason) < 0 && strstr(reason, "blind zone")) {
            p->dropped++;
            continue;
        }
        p->n++;
    }
    brdf_domain_free(&dom);
    return 0;
}

/* Mark each point with the first ladder plan (coarse to fine) holding the
 * same pair; points in none get the last level. */
static int load_ladder(const struct cfg_doc *d, const struct cfg_node *root,
                       const struct rig_profile *rig, int depth, struct plan *p,
                       struct gonio_err *err);

static int load_file(const char *path_or_name, const struct rig_profile *rig, int depth,
                     struct plan **out, struct gonio_err *err)
{
    static const char *const keys[] = {"name", "description", "grid", "pairs", "domain",
                                       "order", "stop", "progressive", "sample_azimuths", NULL};
    *out = NULL;
    struct plan *p = calloc(1, sizeof *p);
    if (!p)
        return gonio_err_set(err, ENOMEM, "%s: out of memory", path_or_name);
    if (gonio_config_path(path_or_name, "plans", p->path, sizeof p->path) < 0) {
        free(p);
        return gonio_err_set(err, GONIO_EBADCONFIG, "%s: path too long", path_or_name);
    }
    struct cfg_doc *d = NULL;
    int rc = cfg_load(p->path, &d, err);
    if (rc < 0) {
        if (rc == -GONIO_ENOTFOUND && !strchr(path_or_name, '/'))
            gonio_err_set(err, GONIO_ENOTFOUND, "%s: no such plan (looked for %s)",
                          path_or_name, p->path);
        free(p);
        return rc;
    }
    const struct cfg_node *root = cfg_root(d), *node;
    const char *name = NULL;
    int order = PLAN_ORDER_TRAVEL;
    if ((rc = cfg_check_keys(d, root, "plan", keys, err)) < 0 ||
        (rc = cfg_string(d, root, "name", CFG_OPTIONAL, &name, err)) < 0 ||
        (rc = cfg_enum(d, root, "order", CFG_OPTIONAL, order_names, &order, err)) < 0 ||
        (rc = load_stop(d, root, p, err)) < 0)
        goto fail;
    int kinds = !!cfg_get(d, root, "grid") + !!cfg_get(d, root, "pairs") +
                !!cfg_get(d, root, "domain");
    if (kinds != 1) {
        rc = cfg_error(d, root, NULL, err,
                       kinds ? "a plan has only one of the keys grid, pairs, domain"
                             : "missing required key: one of grid, pairs, domain");
        goto fail;
    }
    if (cfg_get(d, root, "grid")) {
        p->kind = PLAN_KIND_GRID;
        if ((rc = cfg_map(d, root, "grid", CFG_REQUIRED, &node, err)) < 0 ||
            (rc = load_grid(d, node, rig->blind_deg, p, err)) < 0)
            goto fail;
    } else if (cfg_get(d, root, "pairs")) {
        p->kind = PLAN_KIND_PAIRS;
        if ((rc = cfg_seq(d, root, "pairs", CFG_REQUIRED, &node, err)) < 0 ||
            (rc = load_pairs(d, node, p, err)) < 0)
            goto fail;
    } else {
        p->kind = PLAN_KIND_DOMAIN;
        if ((rc = cfg_map(d, root, "domain", CFG_REQUIRED, &node, err)) < 0 ||
            (rc = load_domain(d, node, rig, p, err)) < 0)
            goto fail;
    }
    /* Refuse, never drop: a pair the rig cannot reach is the plan's error. */
    for (size_t i = 0; i < p->n; i++) {
        char reason[256], what[160];
        if (plan_point_place(&p->pts[i], rig, reason, sizeof reason) < 0) {
            describe(&p->pts[i], what, sizeof what);
            rc = gonio_err_set(err, GONIO_EUNREACHABLE,
                               "%s:%d:%d: %s unreachable on rig '%s': %s", p->path,
                               p->pts[i].line, p->pts[i].col, what, rig->name, reason);
            goto fail;
        }
    }
    if (depth == 0 && ((rc = load_ladder(d, root, rig, depth, p, err)) < 0 ||
                       (rc = plan_load_sample_azimuths(d, root, rig, p, err)) < 0))
        goto fail;
    if (name) {
        snprintf(p->name, sizeof p->name, "%s", name);
    } else {
        const char *base = strrchr(p->path, '/');
        base = base ? base + 1 : p->path;
        size_t len = strlen(base);
        if (len >= sizeof p->name)
            len = sizeof p->name - 1;
        memcpy(p->name, base, len);
        p->name[len] = 0;
        char *dot = strrchr(p->name, '.');
        if (dot && dot != p->name)
            *dot = 0;
    }
    p->declared = (enum plan_order_mode)order;
    /* A fit to the coarse levels alone can be calm and still off (DS1 on
     * specular-black-phenolic after its DS2 level: 1.6 times the full
     * capture's error): no decision before 11/40 of the plan (DS1: 250). */
    if (p->stop.min_points == 0) {
        long share = (long)(p->n * 11 / 40);
        p->stop.min_points = share > p->stop.every ? share : p->stop.every;
    }
    p->order = malloc((p->n ? p->n : 1) * sizeof *p->order);
    if (!p->order) {
        rc = gonio_err_set(err, ENOMEM, "%s: out of memory", p->path);
        goto fail;
    }
    cfg_free(d);
    *out = p;
    return 0;
fail:
    cfg_free(d);
    plan_free(p);
    return rc;
}

static int load_ladder(const struct cfg_doc *d, const struct cfg_node *root,
                       const struct rig_profile *rig, int depth, struct plan *p,
                       struct gonio_err *err)
{
    const struct cfg_node *seq;
    int rc = cfg_seq(d, root, "progressive", CFG_OPTIONAL, &seq, err);
    if (rc <= 0)
        return rc;
    size_t levels = cfg_seq_len(d, seq);
    for (size_t i = 0; i < p->n; i++)
        p->pts[i].level = (int)levels;
    for (size_t l = levels; l-- > 0;) {
        const char *ref;
        if ((rc = cfg_node_string(d, cfg_seq_item(d, seq, l), "progressive", &ref, err)) < 0)
            return rc;
        struct plan *sub;
        struct gonio_err sub_err = {0};
        if (load_file(ref, rig, depth + 1, &sub, &sub_err) < 0)
            return cfg_error(d, cfg_seq_item(d, seq, l), "progressive", err,
                             "cannot use plan '%s' as a level: %s", ref, sub_err.msg);
        /* Walking from the finest level down leaves each point at the
         * coarsest level that holds it. */
        for (size_t i = 0; i < p->n; i++)
            for (size_t j = 0; j < sub->n; j++)
                if (same_pair(&p->pts[i], &sub->pts[j]))
                    p->pts[i].level = (int)l;
        plan_free(sub);
    }
    return 0;
}

int plan_load(const char *path_or_name, const struct rig_profile *rig, struct plan **out,
              struct gonio_err *err)
{
    int rc = load_file(path_or_name, rig, 0, out, err);
    if (rc < 0)
        return rc;
    if ((rc = plan_order(*out, (*out)->declared, rig)) < 0) {
        plan_free(*out);
        *out = NULL;
        return gonio_err_set(err, -rc, "%s: out of memory", path_or_name);
    }
    return (int)(*out)->n;
}

void plan_free(struct plan *plan)
{
    if (!plan)
        return;
    free(plan->pts);
    free(plan->order);
    free(plan);
}

/* The travel order's search is a heuristic: from a far start the tour it
 * finds may cost more than the tour from home with the way from the start
 * to its first point. The cheaper of the two from plan->start is kept, so
 * that ordering from where the axes stand never costs rig time. */
static int keep_cheaper_than_home(struct plan *plan, const struct rig_profile *rig)
{
    static const struct rig_axes home = {0, 0, 0};
    size_t *from_start = malloc((plan->n ? plan->n : 1) * sizeof *from_start);
    if (!from_start)
        return -ENOMEM;
    memcpy(from_start, plan->order, plan->n * sizeof *from_start);
    struct plan_estimate a, b;
    plan_estimate(plan, rig, &a);
    struct rig_axes start = plan->start;
    size_t blocks = plan->sample_azimuths ? plan->sample_azimuths : 1, m = plan->n / blocks;
    int rc = plan_order_indices(plan->pts, m, PLAN_ORDER_TRAVEL, rig, &home, plan->order);
    if (rc == 0) {
        plan_estimate(plan, rig, &b); /* from plan->start still */
        if (b.move_s >= a.move_s)
            memcpy(plan->order, from_start, plan->n * sizeof *from_start);
    }
    plan->start = start;
    free(from_start);
    return rc;
}

int plan_order(struct plan *plan, enum plan_order_mode mode, const struct rig_profile *rig)
{
    return plan_order_from(plan, mode, rig, NULL);
}

int plan_order_from(struct plan *plan, enum plan_order_mode mode, const struct rig_profile *rig,
                    const struct rig_axes *start)
{
    static const struct rig_axes home = {0, 0, 0};
    /* A plan that turns the sample orders each azimuth's points apart: one
     * turn per azimuth, not one between any two points; the first from
     * start, the others from home as before. */
    size_t blocks = plan->sample_azimuths ? plan->sample_azimuths : 1, m = plan->n / blocks;
    int rc = 0;
    for (size_t b = 0; b < blocks && rc == 0; b++) {
        rc = plan_order_indices(plan->pts + b * m, m, mode, rig, b == 0 && start ? start : &home,
                                plan->order + b * m);
        for (size_t i = 0; i < m && b > 0; i++)
            plan->order[b * m + i] += b * m;
    }
    if (rc == 0) {
        plan->current = mode;
        plan->start = start ? *start : home;
    }
    if (rc == 0 && mode == PLAN_ORDER_TRAVEL && start)
        rc = keep_cheaper_than_home(plan, rig);
    return rc;
}

void plan_order_start(const struct plan *plan, struct rig_axes *start)
{
    *start = plan->start;
}

size_t plan_count(const struct plan *plan)
{
    return plan->n;
}

const struct plan_point *plan_point(const struct plan *plan, size_t i)
{
    return i < plan->n ? &plan->pts[plan->order[i]] : NULL;
}

const char *plan_name(const struct plan *plan)
{
    return plan->name;
}

const char *plan_path(const struct plan *plan)
{
    return plan->path;
}

enum plan_kind plan_kind(const struct plan *plan)
{
    return plan->kind;
}

size_t plan_sample_azimuths(const struct plan *plan)
{
    return plan->sample_azimuths;
}

int plan_is_out_of_plane(const struct plan *plan)
{
    return plan->out_of_plane;
}

enum plan_order_mode plan_declared_order(const struct plan *plan)
{
    return plan->declared;
}

enum plan_order_mode plan_current_order(const struct plan *plan)
{
    return plan->current;
}

size_t plan_dropped(const struct plan *plan)
{
    return plan->dropped;
}

const struct plan_stop *plan_stop(const struct plan *plan)
{
    return &plan->stop;
}
