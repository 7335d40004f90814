/* The Pareto front of (cost, error) points: the points that no other point
 * beats on both, i.e. the best accuracy each rig time buys. */
#ifndef GONIO_REPORT_PARETO_H
#define GONIO_REPORT_PARETO_H

#include <stddef.h>

/* Write into idx the indices of the points on the front of x[n], y[n]
 * (both minimised), in ascending x (and so descending y). A point is off
 * the front when another has x <= and y <= with one of them strictly less;
 * of identical points only the first (lowest index) is kept. Points with a
 * non-finite coordinate take no part. idx must hold n entries. Returns the
 * number of points on the front. */
size_t report_pareto_front(const double *x, const double *y, size_t n, size_t *idx);

#endif
