#include "brdf/metrics.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

#define BLOCK 4096

void brdf_errors_acc_init(struct brdf_errors_acc *acc)
{
    acc->sum_log = acc->sum_wd2 = acc->sum_wf2 = 0;
    acc->n_used = acc->n_skipped = 0;
}

void brdf_errors_acc_add(struct brdf_errors_acc *acc, const struct brdf_pair *pairs,
                         const double *truth_rgb, const double *pred_rgb, size_t n)
{
    /* Partial sums per call, added once: a block of a few thousand terms
     * keeps the rounding of a million-pair sum small without Kahan. */
    double s_log = 0, s_wd2 = 0, s_wf2 = 0;
    for (size_t i = 0; i < n; i++) {
        const double *f = truth_rgb + 3 * i, *g = pred_rgb + 3 * i;
        if (isnan(f[0]) || isnan(f[1]) || isnan(f[2]) || isnan(g[0]) || isnan(g[1]) ||
            isnan(g[2])) {
            acc->n_skipped++;
            continue;
        }
        double w = pairs[i].wi[2] > 0 ? pairs[i].wi[2] : 0;
        for (int c = 0; c < 3; c++) {
            /* log1p keeps the small-value end exact where 1 + f cos rounds. */
            s_log += fabs(log1p(g[c] * w) - log1p(f[c] * w));
            double dlt = g[c] - f[c];
            s_wd2 += w * dlt * dlt;
            s_wf2 += w * f[c] * f[c];
        }
        acc->n_used++;
    }
    acc->sum_log += s_log;
    acc->sum_wd2 += s_wd2;
    acc->sum_wf2 += s_wf2;
}

void brdf_errors_acc_finish(const struct brdf_errors_acc *acc, struct brdf_errors *out)
{
    out->n_used = acc->n_used;
    out->n_skipped = acc->n_skipped;
    if (acc->n_used == 0) {
        out->log = out->rel_rmse = NAN;
        return;
    }
    out->log = acc->sum_log / (3.0 * (double)acc->n_used);
    if (acc->sum_wd2 == 0)
        out->rel_rmse = 0; /* identical, even where the truth is all zero */
    else
        out->rel_rmse = sqrt(acc->sum_wd2 / acc->sum_wf2); /* +inf for a zero truth */
}

void brdf_errors_compute(const struct brdf_pair *pairs, const double *truth_rgb,
                         const double *pred_rgb, size_t n, struct brdf_errors *out)
{
    struct brdf_errors_acc acc;
    brdf_errors_acc_init(&acc);
    for (size_t i = 0; i < n; i += BLOCK) {
        size_t m = n - i < BLOCK ? n - i : BLOCK;
        brdf_errors_acc_add(&acc, pairs + i, truth_rgb + 3 * i, pred_rgb + 3 * i, m);
    }
    brdf_errors_acc_finish(&acc, out);
}

int brdf_errors_material(const brdf_material *truth, const brdf_material *model,
                         const struct brdf_domain *d, struct brdf_errors *out,
                         struct gonio_err *err)
{
    struct brdf_errors_acc acc;
    brdf_errors_acc_init(&acc);
    double *buf = malloc(2 * 3 * BLOCK * sizeof *buf);
    if (!buf) {
        brdf_errors_acc_finish(&acc, out);
        return gonio_err_set(err, ENOMEM, "errors of %s against %s: out of memory",
                             brdf_material_name(model), brdf_material_name(truth));
    }
    double *f = buf, *g = buf + 3 * BLOCK;
    for (size_t i = 0; i < d->n; i += BLOCK) {
        size_t m = d->n - i < BLOCK ? d->n - i : BLOCK;
        brdf_material_eval(truth, d->pairs + i, m, f);
        brdf_material_eval(model, d->pairs + i, m, g);
        brdf_errors_acc_add(&acc, d->pairs + i, f, g, m);
    }
    free(buf);
    brdf_errors_acc_finish(&acc, out);
    return 0;
}
