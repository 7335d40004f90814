#include "fit/journal_samples.h"

#include <string.h>

size_t fit_journal_samples(const struct journal_sample *js, size_t n, struct fit_sample *out)
{
    size_t saturated = 0;
    for (size_t i = 0; i < n; i++) {
        saturated += (js[i].flags & JOURNAL_FLAG_SATURATED) != 0;
        journal_sample_pair(&js[i], &out[i].g);
        memcpy(out[i].rgb, js[i].rgb, sizeof out[i].rgb);
    }
    return saturated;
}
