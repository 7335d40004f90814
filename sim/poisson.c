#include "sim/poisson.h"

#include <math.h>

#include <gsl/gsl_randist.h>

double sim_poisson(const gsl_rng *r, double mean)
{
    if (!(mean > 0))
        return 0;
    if (mean <= SIM_POISSON_GSL_MAX)
        return (double)gsl_ran_poisson(r, mean);
    if (isinf(mean))
        return mean;
    double k = floor(mean + sqrt(mean) * gsl_ran_ugaussian(r) + 0.5);
    return k > 0 ? k : 0;
}
