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

/* kind->fit on data, then its model file written atomically to path.
 * *fit_s: wall time of the fit alone. When material is not NULL, the file
 * just written is opened (`model:PATH`) into *material (free with
 * brdf_material_free). Returns 0 or a negative code with err set; nothing
 * is written when the fit fails. */
int fit_model_run(const struct fit_model_kind *kind, const struct fit_data *data,
                  const struct fit_model_options *opt, const char *path,
                  struct fit_model_report *rep, double *fit_s, brdf_material **material,
                  struct gonio_err *err);

/* A model file written atomically to path and, when material is not NULL,
 * opened back (`model:PATH`) into *material: what a reader of the file
 * gets. The step fit_model_run ends with, for callers that fitted the
 * parameters themselves (a capture's warm-started ABC fit). Returns 0 or a
 * negative code with err set. */
int fit_model_write_open(const struct fit_model_file *mf, const char *path,
                         brdf_material **material, struct gonio_err *err);

/* The errors of a material against fit samples at their own pairs
 * (brdf/metrics.h): a model's in-sample error. */
int fit_sample_errors(const brdf_material *m, const struct fit_sample *s, size_t n,
                      struct brdf_errors *out, struct gonio_err *err);

#endif
