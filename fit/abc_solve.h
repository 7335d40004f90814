/* Internal to fit/: one local solve of the ABC problem (fit/abc_problem.h),
 * MINPACK's Levenberg-Marquardt on the 9 x 9 normal equations. */
#ifndef GONIO_FIT_ABC_SOLVE_H
#define GONIO_FIT_ABC_SOLVE_H

#include "fit/abc_problem.h"
#include "fit/fit.h"

/* Cost-stall test: iterations over which the relative decrease is taken. */
#define ABC_STALL_WINDOW 8
/* Small-decrease test, MINPACK's ftol (the one SciPy's least_squares
 * applies): a step whose actual and predicted decrease are both at most
 * this much (relative to the cost) ends the solve. The starts are solved to
 * ABC_COARSE_FTOL, enough to tell their basins apart (the distinct minima
 * of the 10 study materials differ by 1e-4 relative or more); the winner
 * is then polished to ABC_POLISH_FTOL. */
#define ABC_COARSE_FTOL 1e-6
#define ABC_POLISH_FTOL 1e-10

struct abc_solve_result {
    double theta[ABC_NPAR];
    double cost;
    int iterations;
    int converged;
    const char *reason;
    /* the trust region where the solve stopped, to resume it (the polish) */
    double D[ABC_NPAR], delta, par;
};

/* One Levenberg-Marquardt solve from theta0 (or, when resume is not NULL,
 * resumed from that solve's point and trust region) until a step lowers
 * the cost by less than step_ftol, or another of MINPACK's tests or the
 * cost-stall test (opt->ftol) ends it; opt->max_iter, xtol and gtol apply.
 * Returns 0, -1 when the cost is not finite or there is no memory. */
int abc_local_solve(const struct abc_problem *pb, const double theta0[ABC_NPAR],
                    const struct fit_options *opt, double step_ftol,
                    const struct abc_solve_result *resume, struct abc_solve_result *res);

#endif
