/* Inside capture/: the signal rate a detector of counts will see at a
 * plan's points, interpolated from the points measured so far
 * (docs/plans.md, "Auto-ranging"), for the ETA's walk of the ladder.
 *
 * A material's brightness follows its half and difference angles
 * (Rusinkiewicz's theta_h, theta_d; isotropic materials) far more than
 * the pair's two directions: a specular lobe is a function of theta_h, a
 * Fresnel rise of theta_d. So a point's rate is the inverse-distance mean
 * of the logarithms of the rates at the RATE_MAP_NEIGHBOURS measured
 * points nearest it in (theta_h, RATE_MAP_D_WEIGHT x theta_d): a rate
 * spans decades over a lobe, and the logarithm interpolates across them
 * where a plain mean would follow the brightest. How far that is to be
 * trusted is the leave-one-out spread of the same interpolation over the
 * first RATE_MAP_SPREAD_POINTS points measured (a pre-scan's, spread over
 * the plan, then the order's first): each predicted from the others.
 *
 * Two models interpolate so: the log rate itself (RATE_MAP_PLAIN), and
 * the log of the rate over cos theta_i, times cos theta_i at the point
 * (RATE_MAP_FORESHORTENED: a diffuse material's rate is its
 * foreshortening, which theta_h and theta_d do not see). Neither is the
 * better everywhere (docs/notes/eta-ranging.md): the plain one cannot rise
 * past the brightest point measured, the other takes a bright grazing
 * point's foreshortening off and carries it elsewhere. Each is weighed by
 * how well it predicted the rates measured so far, as a log score: the
 * first points' leave-one-out errors, then every later point's before it
 * was measured, each a normal error of the model's spread. So right after
 * a pre-scan the one that interpolated it better leads, and the other
 * takes over where it predicts the points that follow better. */
#ifndef GONIO_CAPTURE_RATE_MAP_H
#define GONIO_CAPTURE_RATE_MAP_H

#include <stddef.h>

#include "common/err.h"
#include "planner/planner.h"

#define RATE_MAP_NEIGHBOURS 3
#define RATE_MAP_D_WEIGHT 0.5     /* theta_d's weight against theta_h's */
#define RATE_MAP_SPREAD_POINTS 64 /* measured points the spread is taken over */
#define RATE_MAP_MIN_SPREAD 1e-3  /* the least a model's spread counts as, in a score */

enum { RATE_MAP_PLAIN, RATE_MAP_FORESHORTENED, RATE_MAP_MODELS };

typedef struct rate_map rate_map;

/* Over plan's points (read once, not kept). NULL with err filled when out
 * of memory. */
rate_map *rate_map_new(const struct plan *plan, struct gonio_err *err);
void rate_map_free(rate_map *m);

/* Take the spread over the first `points` measured instead (2 up to
 * RATE_MAP_SPREAD_POINTS; else RATE_MAP_SPREAD_POINTS): a pre-scan's, which
 * stand far apart as the points no one has measured yet do from them. A
 * spread over points measured next to each other (a travel order's) says
 * how well a point is known from its neighbours, not from afar. Call it
 * before observing. */
void rate_map_spread_over(rate_map *m, size_t points);

/* The rate measured at point (counts per second, > 0; a point outside the
 * plan, a point measured already or a rate not > 0 is ignored).
 * O(points). */
void rate_map_observe(rate_map *m, size_t point, double rate);

/* The rate model `model` expects at point: its own where measured, else
 * interpolated; NAN before any observation. */
double rate_map_at(const rate_map *m, int model, size_t point);

/* Model `model`'s leave-one-out standard deviation of the natural
 * logarithm of the rate over the first points (0 with fewer than two
 * measured). */
double rate_map_spread(const rate_map *m, int model);

/* Model `model`'s weight, from the log scores: the models' sum to 1. */
double rate_map_weight(const rate_map *m, int model);

/* How many points have been observed. */
size_t rate_map_count(const rate_map *m);

#endif
