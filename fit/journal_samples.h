/* A capture journal's samples as the fits take them. The conversion sits
 * here, on the fit side, so that the journal library knows nothing of the
 * fitter (docs/architecture.md). */
#ifndef GONIO_FIT_JOURNAL_SAMPLES_H
#define GONIO_FIT_JOURNAL_SAMPLES_H

#include <stddef.h>

#include "fit/fit.h"
#include "journal/journal.h"

/* The samples in journal order (out has room for n); returns how many are
 * saturated. Those keep their clipped value: only a lower bound of the
 * BRDF, but leaving them out cost sparse plans their only peak samples
 * (docs/formats.md has the figures). */
size_t fit_journal_samples(const struct journal_sample *js, size_t n, struct fit_sample *out);

#endif
