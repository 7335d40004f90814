/* Published analytic fits of the MERL materials, read from the shared data
 * folder (<shared>/data/merl/fits/, see its README for sources):
 *   abc_low2012_merl.csv    ABC model, Low, Kronander, Ynnerman, Unger,
 *                           "BRDF models for accurate and efficient
 *                           rendering of glossy surfaces", TOG 31(1), 2012
 *   sgd_bagher2012_merl.csv shifted gamma, Bagher, Soler, Holzschuch, CGF 2012
 * Both tables were taken from J. Dupuy's public-domain dj_brdf.h. */
#ifndef GONIO_BRDF_PUBLISHED_H
#define GONIO_BRDF_PUBLISHED_H

#include "brdf/abc.h"
#include "brdf/sgd.h"
#include "common/err.h"

/* One row of the published ABC table as printed, before conversion. */
struct brdf_abc_published {
    double kd[3];
    double A[3]; /* includes the extra factor pi of the published fits */
    double B, C, ior;
};

/* The published A carries a factor pi that our brdf_abc_eval does not:
 * dj_brdf evaluates kd/pi + F D G / (pi cos_i cos_o) with D = A/(...)^C,
 * so A_ours = A_published / pi; kd, B, C and ior are unchanged. */
void brdf_published_abc_convert(const struct brdf_abc_published *pub, struct brdf_abc *out);

/* Look NAME up in the table at path (a CSV of the layout above). Errors
 * (GONIO_ENOTFOUND for a missing file or name, GONIO_EBADDATA for a bad
 * row) name the file and the problem. */
int brdf_published_abc_read(const char *path, const char *name, struct brdf_abc_published *out,
                            struct gonio_err *err);
int brdf_published_sgd_read(const char *path, const char *name, struct brdf_sgd *out,
                            struct gonio_err *err);

/* The same from the shared data folder, ABC converted to our convention. */
int brdf_published_abc(const char *name, struct brdf_abc *out, struct gonio_err *err);
int brdf_published_sgd(const char *name, struct brdf_sgd *out, struct gonio_err *err);

#endif
