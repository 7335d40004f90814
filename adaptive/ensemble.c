/* Delete-group jackknife ensemble of ABC fits (adaptive/ensemble.h). */
#include "adaptive/ensemble.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

#include "brdf/metrics.h"
#include "common/err.h"
#include "fit/domain_weights.h"

void ens_init(struct ens *e)
{
    *e = (struct ens){.fit_error = NAN, .cv_error = NAN};
}

void ens_free(struct ens *e)
{
    free(e->scratch);
    free(e->cv_resid);
    ens_init(e);
}

double ens_log_value(const struct brdf_abc *params, const struct brdf_pair *p)
{
    double rgb[3];
    brdf_abc_eval(params, p, rgb);
    double c = p->wi[2] > 0 ? p->wi[2] : 0;
    double sum = 0;
    for (int k = 0; k < 3; k++)
        sum += log1p(fmax(rgb[k], 0) * c);
    return sum / 3;
}

void ens_deviations(const struct ens *e, const struct brdf_pair *p, double dev[ENS_GROUPS])
{
    double mean = 0;
    for (int g = 0; g < ENS_GROUPS; g++) {
        dev[g] = ens_log_value(&e->member[g], p);
        mean += dev[g];
    }
    mean /= ENS_GROUPS;
    double k = sqrt((double)(ENS_GROUPS - 1) / ENS_GROUPS);
    for (int g = 0; g < ENS_GROUPS; g++)
        dev[g] = k * (dev[g] - mean);
}

double ens_variance(const struct ens *e, const struct brdf_pair *p)
{
    double dev[ENS_GROUPS], ss = 0;
    ens_deviations(e, p, dev);
    for (int g = 0; g < ENS_GROUPS; g++)
        ss += dev[g] * dev[g];
    return ss;
}

/* Log error of params on the samples of group g (g < 0: every sample). */
static double group_error(const struct brdf_abc *params, const struct fit_sample *s, size_t n,
                          int g, struct brdf_errors_acc *acc, double *resid)
{
    struct brdf_errors_acc own;
    brdf_errors_acc_init(&own);
    for (size_t k = 0; k < n; k++) {
        if (g >= 0 && (int)(k % ENS_GROUPS) != g)
            continue;
        double rgb[3];
        brdf_abc_eval(params, &s[k].g, rgb);
        brdf_errors_acc_add(&own, &s[k].g, s[k].rgb, rgb, 1);
        if (acc)
            brdf_errors_acc_add(acc, &s[k].g, s[k].rgb, rgb, 1);
        if (resid) {
            double c = fmax(s[k].g.wi[2], 0), r = 0;
            for (int ch = 0; ch < 3; ch++)
                r += fabs(log1p(fmax(rgb[ch], 0) * c) - log1p(fmax(s[k].rgb[ch], 0) * c));
            resid[k] = isfinite(r) ? r / 3 : 0;
        }
    }
    struct brdf_errors out;
    brdf_errors_acc_finish(&own, &out);
    return out.log;
}

int ens_fit(struct ens *e, const struct fit_sample *s, size_t n, int weighted)
{
    if (n > e->cap) {
        struct fit_sample *grown = realloc(e->scratch, 2 * n * sizeof *grown);
        if (grown)
            e->scratch = grown;
        double *r = realloc(e->cv_resid, 2 * n * sizeof *r);
        if (r)
            e->cv_resid = r;
        if (!grown || !r)
            return -ENOMEM;
        e->cap = 2 * n;
    }
    struct fit_options fo = fit_default_options();
    fo.heldout = 0; /* the ensemble holds out its own groups */
    /* every member weighs as the fit to all samples does: weighted only
     * when the smallest member has the samples a weighted fit needs */
    fo.domain_weights = weighted && n - (n + ENS_GROUPS - 1) / ENS_GROUPS >=
                                        FIT_DOMAIN_WEIGHTS_MIN_SAMPLES;
    struct brdf_abc next, cold;
    struct fit_info info, cold_info;
    int had = e->ok;
    fo.warm_start = had ? &e->full : NULL;
    int ok = fit_abc(s, n, &fo, &next, &info, NULL) == 0;
    /* A warm start only refines: each time the data have doubled the
     * global start runs too and the lower cost wins (as fit/stream.c). */
    if (had && n >= 2 * e->cold_n) {
        fo.warm_start = NULL;
        if (fit_abc(s, n, &fo, &cold, &cold_info, NULL) == 0 &&
            (!ok || cold_info.cost < info.cost)) {
            next = cold;
            ok = 1;
        }
        e->cold_n = n;
    } else if (!had) {
        e->cold_n = n;
    }
    if (!ok) {
        e->ok = 0;
        return -GONIO_EFIT;
    }
    e->full = next;
    fo.warm_start = &e->full;
    struct brdf_errors_acc cv;
    brdf_errors_acc_init(&cv);
    for (int g = 0; g < ENS_GROUPS; g++) {
        size_t m = 0;
        for (size_t k = 0; k < n; k++)
            if ((int)(k % ENS_GROUPS) != g)
                e->scratch[m++] = s[k];
        if (fit_abc(e->scratch, m, &fo, &e->member[g], NULL, NULL) != 0) {
            e->ok = 0;
            return -GONIO_EFIT;
        }
        group_error(&e->member[g], s, n, g, &cv, e->cv_resid);
    }
    struct brdf_errors cve;
    brdf_errors_acc_finish(&cv, &cve);
    e->cv_error = cve.log;
    e->fit_error = group_error(&e->full, s, n, -1, NULL, NULL);
    e->ok = 1;
    return 0;
}
