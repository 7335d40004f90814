/* Internal to fit/: the embedded population table (abc_prior_table.c). */
#ifndef GONIO_FIT_ABC_PRIOR_PRIVATE_H
#define GONIO_FIT_ABC_PRIOR_PRIVATE_H

#include <stddef.h>

struct abc_prior_row {
    const char *name; /* MERL material name */
    double v[9];      /* kd[3], A[3], B, C, eta (brdf/abc.h convention) */
};

extern const struct abc_prior_row abc_prior_rows[];
extern const size_t abc_prior_n_rows;

#endif
