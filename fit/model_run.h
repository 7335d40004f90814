/* Fitting a registered model as `gonio fit` and a capture's final fit both
 * do it: fit, write the model file, and read it back as a material, so that
 * what is assessed is what a reader of the file gets (docs/models.md). */
#ifndef GONIO_FIT_MODEL_RUN_H
#define GONIO_FIT_MODEL_RUN_H

#include <stddef.h>

#include "brdf/material.h"
#include "brdf/metrics.h"
#include "common/err.h"
#include "fit/fit.h"
#include "fit/models.h"

/* kind->fit on data, then its model file written atomically to path:
 * the one fit step of `gonio fit`, a capture's final fit and the study.
 * rep (may be NULL) receives the fit's report, with its wall and CPU time
 * and whether the fit itself succeeded (rep->fitted: a failure after it is
 * the file's). When material is not NULL, the file just written is opened
 * (`model:PATH`) into *material (free with brdf_material_free). Returns 0
 * or a negative code with err set; nothing is written when the fit
 * fails. */
int fit_model_run(const struct fit_model_kind *kind, const struct fit_data *data,
                  const struct fit_model_options *opt, const char *path,
                  struct fit_model_report *rep, brdf_material **material,
                  struct gonio_err *err);

/* The errors of a material against fit samples at their own pairs
 * (brdf/metrics.h): a model's in-sample error. */
int fit_sample_errors(const brdf_material *m, const struct fit_sample *s, size_t n,
                      struct brdf_errors *out, struct gonio_err *err);

#endif
