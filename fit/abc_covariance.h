/* Internal to fit/: the ABC fit's uncertainties at its optimum. */
#ifndef GONIO_FIT_ABC_COVARIANCE_H
#define GONIO_FIT_ABC_COVARIANCE_H

#include <stddef.h>

#include "fit/abc_problem.h"
#include "fit/fit.h"

/* The residual variance of a fit of cost (half the sum of squared, weighted
 * residuals) over pb's rows: their mean square with ABC_NPAR degrees of
 * freedom spent, weighted rows counted as Kish's effective number. NAN for
 * no more (effective) rows than parameters. */
double abc_residual_variance(const struct abc_problem *pb, double cost);

/* The parameter standard deviations at theta into u (fit/fit.h struct
 * fit_uncertainty): covariance s2 (J^T J)^-1, or for a weighted problem
 * the sandwich s2 H^-1 (J^T W^2 J) H^-1, and the predictive sd over an
 * in-plane grid. u_sys (NULL: none): per channel c, a relative scale error
 * of all of c's values with sd u_sys[c], shared by them (one capture's
 * reference standard), each channel's first-order effect on theta added in
 * quadrature. K (nk rows) and cn: the
 * root of J^T J at theta (abc_jacobian_root). All NAN when s2 is not
 * finite. */
void abc_uncertainty(const struct abc_problem *pb, const double th[ABC_NPAR], double s2,
                     const double u_sys[3], const double *K, size_t nk, const double cn[ABC_NPAR],
                     struct fit_uncertainty *u);

#endif
