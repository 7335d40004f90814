/* A capture journal's samples as the fits take them. The conversion sits
 * here, on the fit side, so that the journal library knows nothing of the
 * fitter (docs/architecture.md). */
#ifndef GONIO_FIT_JOURNAL_SAMPLES_H
#define GONIO_FIT_JOURNAL_SAMPLES_H

#include <stddef.h>

#include "fit/fit.h"
#include "fit/models.h"
#include "journal/journal.h"

/* The samples in journal order (out has room for n); returns how many are
 * saturated. Those keep their clipped value: only a lower bound of the
 * BRDF, but leaving them out cost sparse plans their only peak samples
 * (docs/formats.md has the figures). */
size_t fit_journal_samples(const struct journal_sample *js, size_t n, struct fit_sample *out);

/* A journal's samples as fit data: the one conversion a capture's final
 * fit, the study and `gonio fit` share. Records without a BRDF value
 * (journal_sample_has_brdf: dark frames, counts not reduced) are left out
 * and counted. Owns its arrays (free with fit_journal_data_free). */
struct fit_journal_data {
    struct fit_sample *rgb; /* the samples with a value, in journal order */
    size_t n;
    size_t without_value;   /* records left out: no BRDF value */
    size_t saturated;       /* how many the detector saturated */
    unsigned char *lower;   /* their flags (1: saturated), NULL when none is */
};

/* The n journalled samples js into out. Returns 0, -ENOMEM with err, or
 * -GONIO_EBADDATA when records are there but none has a BRDF value
 * ("no sample has a BRDF value: 40 records of counts not reduced ..."). */
int fit_data_from_journal(const struct journal_sample *js, size_t n,
                          struct fit_journal_data *out, struct gonio_err *err);

/* The fit data of d for a fit of kind: its samples, the saturated ones as
 * lower bounds when kind censors them under how (fit_model_censors), and
 * material and domain_weights as given (fit/models.h struct fit_data). */
struct fit_data fit_journal_data_for(const struct fit_journal_data *d,
                                     const struct fit_model_kind *kind, enum fit_saturated how,
                                     const char *material, int domain_weights);

void fit_journal_data_free(struct fit_journal_data *d);

#endif
