/* The plan structure, shared by the planner's own files only. */
#ifndef GONIO_PLANNER_PLAN_PRIVATE_H
#define GONIO_PLANNER_PLAN_PRIVATE_H

#include "planner/planner.h"

struct plan {
    char name[128];
    char path[4096];
    enum plan_kind kind;
    int out_of_plane;
    enum plan_order_mode declared, current;
    struct plan_stop stop;
    struct plan_point *pts; /* as written */
    size_t n;
    size_t dropped; /* grid pairs and domain nodes in the rig's blind zone */
    size_t *order; /* execution order: indices into pts */
    /* where the order starts: home, or the axes' present positions
     * (plan_order_from) */
    struct rig_axes start;
    size_t sample_azimuths; /* 0, or the sample azimuths each pair is measured at */
};

/* planner/order.c */
int plan_order_indices(const struct plan_point *pts, size_t n, enum plan_order_mode mode,
                       const struct rig_profile *rig, const struct rig_axes *start,
                       size_t *order);

/* planner/sample_azimuths.c: the plan's sample_azimuths key, if any, applied
 * to the placed points (each repeated at every azimuth: plan_point.rotation). */
struct cfg_doc;
struct cfg_node;
int plan_load_sample_azimuths(const struct cfg_doc *d, const struct cfg_node *root,
                              const struct rig_profile *rig, struct plan *p,
                              struct gonio_err *err);

#endif
