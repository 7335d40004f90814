/* Inside capture/: a capture's final fit of its journalled samples, its
 * model file, and its errors against a reference material. */
#ifndef GONIO_CAPTURE_FINAL_FIT_H
#define GONIO_CAPTURE_FINAL_FIT_H

#include "brdf/abc.h"
#include "brdf/material.h"
#include "capture/capture.h"
#include "fit/models.h"
#include "journal/journal.h"

/* The final fit of the n journalled samples js with model kind, warm
 * started from warm (NULL: none), its model file written as DIR/NAME.model
 * and read back (*fitted), and its error on them (the plan domain) into
 * out. Saturated readings are fitted as lower bounds when the model
 * censors them (fit_model_censors; docs/fitting.md "Saturated readings"),
 * and samples an adaptive policy chose (chosen) are weighted by their
 * share of the domain (fit/models.h fit_data); material is what was
 * measured (abc-prior leaves it out of its prior), or NULL. u_systematic
 * (NULL: none): per channel, the relative uncertainty all samples' u share
 * (rad_systematic_rel_u of the capture's calibration), for the fits
 * weighted by u (fit_data.u_systematic). A failed fit names the model and
 * leaves the journal as it is. */
int capture_fit_samples(const struct journal_sample *js, size_t n, const struct brdf_abc *warm,
                        const struct fit_model_kind *kind, const char *dir,
                        const char *material, int chosen, const double *u_systematic,
                        struct capture_summary *out, brdf_material **fitted,
                        struct gonio_err *err);

/* Errors of model against truth over the in-plane and full domains (all
 * its nodes, or a seeded sample of assess_nodes of them) into out. */
int capture_assess_truth(const brdf_material *truth, const brdf_material *model,
                         size_t assess_nodes, struct capture_summary *out,
                         struct gonio_err *err);

#endif
