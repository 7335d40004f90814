/* ABC as a registry model (fit/models.h): fit_abc behind the common fit
 * signature, and ABC parameters in a model file of kind "abc":
 * data = kd[3], A[3], B, C, eta (A without the published 1/pi, brdf/abc.h). */
#ifndef GONIO_FIT_ABC_MODEL_H
#define GONIO_FIT_ABC_MODEL_H

#include "brdf/abc.h"
#include "fit/models.h"

#define FIT_ABC_FILE_VERSION 1

int fit_abc_model_fit(const struct fit_data *data, const struct fit_model_options *opt,
                      struct fit_model_file **out, struct fit_model_report *rep,
                      struct gonio_err *err);

/* A model file holding these parameters (NULL: out of memory). */
struct fit_model_file *fit_abc_model_file(const struct brdf_abc *p);

/* The same for the result of a fit: also the seed it ran with, its final
 * cost, the data's scale and the fit's status (fit_status_file_keys), the
 * keys every abc file written by a fit carries, and "weights" when the
 * samples were weighted (fit_info.domain_weights) (NULL: out of memory). */
struct fit_model_file *fit_abc_fitted_file(const struct brdf_abc *p, unsigned long long seed,
                                           const struct fit_info *info);

/* The model file's "warm_start" key when the fit was warm started
 * (fit_model_options.warm_start): where the start came from. 0, or -1 out
 * of memory. */
int fit_abc_warm_start_key(struct fit_model_file *f, const struct fit_model_options *opt);

/* The parameters of an abc model file, checked (finite, kd, A, B, C >= 0,
 * eta >= 1); errors name path. */
int fit_abc_model_params(const struct fit_model_file *f, const char *path, struct brdf_abc *p,
                         struct gonio_err *err);

brdf_material *fit_abc_model_open(const struct fit_model_file *f, const char *name,
                                  struct gonio_err *err);

#endif
