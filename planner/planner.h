/* Capture plans: which angle pairs to measure, in which order, and how long
 * the rig will take.
 *
 * A plan is YAML data (configs/plans/, docs/plans.md): a grid spec, an
 * explicit list of pairs, or a reference domain. plan_load generates the
 * pairs, maps each to rig axes (s = theta_i, a = theta_i + theta_r) and
 * refuses any pair the rig cannot reach, naming the file, the pair and the
 * reason; it then orders the points as the plan says. */
#ifndef GONIO_PLANNER_PLANNER_H
#define GONIO_PLANNER_PLANNER_H

#include <stddef.h>

#include "common/err.h"
#include "rig/motion.h"
#include "rig/rig.h"

enum plan_kind { PLAN_KIND_GRID, PLAN_KIND_PAIRS, PLAN_KIND_DOMAIN };

/* The most points a plan may hold (the full reference domain has 923,870):
 * a file asking for more is refused before anything is generated. */
#define PLAN_MAX_POINTS 2000000

enum plan_order_mode {
    PLAN_ORDER_TRAVEL,      /* least move time (heuristic: 2-opt + Or-opt) */
    PLAN_ORDER_PROGRESSIVE, /* coarse to fine, each level travel-ordered */
    PLAN_ORDER_AS_WRITTEN,  /* file order (grids: theta_i, then theta_r) */
    PLAN_ORDER_GREEDY,      /* nearest neighbour in move time: a baseline */
    /* The capture chooses each next point from the samples so far
     * (adaptive/adaptive.h): the plan is the candidate pool, kept in
     * written order, which does not matter. */
    PLAN_ORDER_ADAPTIVE,
};

enum plan_stop_kind { PLAN_STOP_ALL, PLAN_STOP_CONVERGE };

/* stop: {converge: {...}}: stop once the fitted model's error changes by
 * less than tol (relative) over `rounds` consecutive fit rounds, a fit
 * round running every `every` new samples, never before min_points. */
struct plan_stop {
    enum plan_stop_kind kind;
    double tol;
    long rounds, every, min_points;
};

/* The grid rule of DESIGN.md section 3. */
struct plan_grid {
    double theta_i_step, theta_i_max;
    double diffuse_step, glossy_step, glossy_half_width;
    double theta_r_min, theta_r_max;
    double blind; /* pairs with |theta_i + theta_r| < blind are dropped */
};

enum plan_domain_set { PLAN_DOMAIN_FULL, PLAN_DOMAIN_INPLANE, PLAN_DOMAIN_OOP_RANDOM };

/* One measurement point. In-plane points have out_of_plane = 0 and
 * theta_o = |theta_r|, phi_i = 0, phi_o = 180 (theta_r >= 0) or 0, following
 * wo = (-sin tr, 0, cos tr). General points carry the spherical angles and
 * theta_r = 0. */
struct plan_point {
    double theta_i, theta_r;
    double phi_i, theta_o, phi_o;
    int out_of_plane;
    struct rig_axes ax;
    /* The sample turned about its normal, degrees, on the rig's rotation
     * axis (a plan's sample_azimuths); 0: unturned. theta_i, theta_r and
     * the spherical angles are the rig's; the sample sees the pair turned
     * by -rotation (brdf_pair_rotate). */
    double rotation;
    int level;     /* progressive level: 0 is the coarsest */
    int line, col; /* where the pair is written in the plan file (0: generated) */
};

struct plan_estimate {
    double total_s, move_s, settle_s, integration_s;
};

struct plan;

/* Load a plan: a path, or a bare name (ds2) resolved to
 * <gonio_config_dir()>/plans/NAME.yaml. The rig decides reachability.
 * Returns the point count, or -GONIO_EBADCONFIG (bad file),
 * -GONIO_EUNREACHABLE (a pair the rig cannot reach), -GONIO_ENOTFOUND;
 * err says "path:line:col: ..." in every case. */
int plan_load(const char *path_or_name, const struct rig_profile *rig, struct plan **out,
              struct gonio_err *err);
void plan_free(struct plan *plan);

/* Generate a grid's pairs in written order (theta_i, then theta_r
 * ascending), duplicates removed. *out is malloc'd. Returns the count or
 * -ENOMEM. Axis fields are not filled. */
int plan_grid_generate(const struct plan_grid *grid, struct plan_point **out);

/* Reorder the points (always starting from the written order). Returns 0
 * or -ENOMEM. */
int plan_order(struct plan *plan, enum plan_order_mode mode, const struct rig_profile *rig);

/* plan_order with the path starting at start (the axes' present positions:
 * a capture starts where the last one, or a bring-up command, left them)
 * instead of home; start NULL: home. The as-written and adaptive orders do
 * not depend on it. plan_order_start says where the current order starts. */
int plan_order_from(struct plan *plan, enum plan_order_mode mode, const struct rig_profile *rig,
                    const struct rig_axes *start);
void plan_order_start(const struct plan *plan, struct rig_axes *start);

/* Some of the plan's points, ids[0..m) (indices into its current order),
 * put in mode's order as a path from start: a resumed capture's points
 * left, from where its axes stand. The plan is unchanged and the ids keep
 * their identity (a journal's point numbers); only the order they are
 * visited in changes. The as-written and adaptive orders leave ids as
 * given. 0 or -ENOMEM. */
int plan_order_subset(const struct plan *plan, enum plan_order_mode mode,
                      const struct rig_profile *rig, const struct rig_axes *start, long *ids,
                      size_t m);

/* Rig time from where the current order starts (home, all axes at 0,
 * unless plan_order_from said otherwise) through every point in the
 * current order: move + settle + fixed integration per point. */
void plan_estimate(const struct plan *plan, const struct rig_profile *rig,
                   struct plan_estimate *est);

/* The integration a detector will choose at a point (an auto-exposing
 * detector integrates longer where the material is dark: planner/meter.h). */
typedef double (*plan_integration_fn)(void *user, const struct plan_point *pt);

/* plan_estimate with each point's integration from integration (NULL: the
 * rig's fixed one); point_s (plan_count entries, or NULL) receives each
 * point's share: the move to it, settle and integration. */
void plan_estimate_points(const struct plan *plan, const struct rig_profile *rig,
                          plan_integration_fn integration, void *user, double *point_s,
                          struct plan_estimate *est);

/* plan_estimate_points with the first move from start (the axes' present
 * positions: sample, arm, azimuth); start NULL: where the order starts
 * (plan_order_start). A capture starts wherever the last one left the axes. */
void plan_estimate_from(const struct plan *plan, const struct rig_profile *rig,
                        const struct rig_axes *start, plan_integration_fn integration,
                        void *user, double *point_s, struct plan_estimate *est);

/* A lower bound on the move time of any order from home: up to 2000
 * points the Held-Karp 1-tree bound (subgradient ascent on node penalties,
 * about 0.6 s for DS1), else the weight of a minimum spanning tree over home
 * and the points, in the move-time metric. NAN for plans too large for the
 * O(n^2) computation. */
double plan_move_lower_bound(const struct plan *plan, const struct rig_profile *rig);

/* Accessors. plan_point(i) is the i-th point in execution order. */
size_t plan_count(const struct plan *plan);
const struct plan_point *plan_point(const struct plan *plan, size_t i);
const char *plan_name(const struct plan *plan);
const char *plan_path(const struct plan *plan);
enum plan_kind plan_kind(const struct plan *plan);
int plan_is_out_of_plane(const struct plan *plan);
/* The sample azimuths each in-plane pair is measured at (the plan's
 * sample_azimuths, plan_point.rotation), or 0 when the plan does not turn the
 * sample. */
size_t plan_sample_azimuths(const struct plan *plan);
enum plan_order_mode plan_declared_order(const struct plan *plan); /* the file's order */
enum plan_order_mode plan_current_order(const struct plan *plan);
const struct plan_stop *plan_stop(const struct plan *plan);
/* Grid pairs and domain nodes left out because they sit in the rig's
 * blind zone (retro-reflection); 0 for lists of pairs, which are refused. */
size_t plan_dropped(const struct plan *plan);

/* "travel", "progressive", "as-written", "greedy", "adaptive"; parse
 * returns -1 when unknown. */
const char *plan_order_name(enum plan_order_mode mode);
int plan_order_parse(const char *name);

/* Check one point against the rig and fill its axes. Returns 0, or
 * -GONIO_EUNREACHABLE with why (e.g. "detector arm at a = 2 deg is inside
 * the 5 deg blind zone") written to reason. */
int plan_point_place(struct plan_point *pt, const struct rig_profile *rig, char *reason,
                     size_t size);

/* The plan in the stable JSON form of DESIGN.md section 8 (pairs in
 * execution order, count, estimate); malloc'd text, NULL when out of
 * memory. */
char *plan_json_text(const struct plan *plan, const struct plan_estimate *est);

#endif
