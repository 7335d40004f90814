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
        memcpy(out[i].u, js[i].u, sizeof out[i].u); /* NAN: none (fit_sample.u) */
    }
    return saturated;
}

int fit_data_from_journal(const struct journal_sample *js, size_t n,
                          struct fit_journal_data *out, struct gonio_err *err)
{
    memset(out, 0, sizeof *out);
    if (!(out->rgb = malloc((n ? n : 1) * sizeof *out->rgb)) || !(out->lower = malloc(n ? n : 1))) {
        fit_journal_data_free(out);
        return gonio_err_set(err, ENOMEM, "out of memory");
    }
    for (size_t i = 0; i < n; i++) {
        if (!journal_sample_has_brdf(&js[i])) {
            out->without_value++;
            continue;
        }
        out->saturated += fit_journal_samples(&js[i], 1, &out->rgb[out->n]);
        out->lower[out->n++] = (js[i].flags & JOURNAL_FLAG_SATURATED) != 0;
    }
    if (!out->saturated) { /* NULL when none is: fit_journal_data_for */
        free(out->lower);
        out->lower = NULL;
    }
    if (out->n == 0 && out->without_value > 0) {
        size_t k = out->without_value;
        fit_journal_data_free(out);
        return gonio_err_set(err, GONIO_EBADDATA,
                             "no sample has a BRDF value: %zu records of detector counts "
                             "not reduced (or dark frames); a calibration turns counts into BRDF",
                             k);
    }
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
