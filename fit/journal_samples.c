#include "fit/journal_samples.h"

#include <errno.h>
#include <stdlib.h>
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

int fit_data_from_journal(const struct journal_sample *js, size_t n,
                          struct fit_journal_data *out, struct gonio_err *err)
{
    memset(out, 0, sizeof *out);
    if (!(out->rgb = malloc((n ? n : 1) * sizeof *out->rgb)))
        return gonio_err_set(err, ENOMEM, "out of memory");
    out->n = n;
    out->saturated = fit_journal_samples(js, n, out->rgb);
    if (out->saturated && !(out->lower = malloc(n))) {
        fit_journal_data_free(out);
        return gonio_err_set(err, ENOMEM, "out of memory");
    }
    for (size_t i = 0; out->lower && i < n; i++)
        out->lower[i] = (js[i].flags & JOURNAL_FLAG_SATURATED) != 0;
    return 0;
}

struct fit_data fit_journal_data_for(const struct fit_journal_data *d,
                                     const struct fit_model_kind *kind, enum fit_saturated how,
                                     const char *material, int domain_weights)
{
    return (struct fit_data){.rgb = d->rgb,
                             .n_rgb = d->n,
                             .rgb_lower = d->lower && fit_model_censors(kind, how) ? d->lower
                                                                                    : NULL,
                             .material = material,
                             .domain_weights = domain_weights};
}

void fit_journal_data_free(struct fit_journal_data *d)
{
    free(d->rgb);
    free(d->lower);
    memset(d, 0, sizeof *d);
}
