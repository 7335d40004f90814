/* abc-pseudo (fit/pseudo.h). */
#include "fit/pseudo.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fit/abc_model.h"
#include "fit/mlp.h"
#include "fit/model_file.h"

int fit_pseudo_grid(struct brdf_pair **pairs)
{
    /* At most 17 theta_i x (33 diffuse + 31 glossy) pairs. */
    struct brdf_pair *p = malloc(17 * 64 * sizeof *p);
    if (!p)
        return -ENOMEM;
    int n = 0;
    for (int i = 0; i <= 16; i++) {
        int ti = 5 * i;
        /* theta_r in whole degrees: diffuse nodes every 5 outside the
         * glossy band, glossy nodes every 1 inside it, ascending. */
        for (int tr = -80; tr <= 80; tr++) {
            int glossy = abs(tr - ti) <= 15;
            int diffuse = (tr + 80) % 5 == 0 && abs(tr - ti) > 15;
            if ((!glossy && !diffuse) || abs(ti + tr) < 5)
                continue;
            brdf_pair_inplane(ti, tr, &p[n++]);
        }
    }
    *pairs = p;
    return n;
}

int fit_abc_pseudo_fit(const struct fit_data *data, const struct fit_model_options *opt,
                       struct fit_model_file **out, struct fit_model_report *rep,
                       struct gonio_err *err)
{
    struct fit_model_options o = opt ? *opt : fit_model_default_options();
    if (!data->n_rgb)
        return gonio_err_set(err, GONIO_EUSAGE, "abc-pseudo: needs RGB samples");
    struct fit_mlp net;
    struct fit_mlp_train_report tr;
    int rc = fit_mlp_rgb_train_samples(data->rgb, data->n_rgb, data->rgb_lower, o.seed,
                                       o.max_epochs, o.quiet,
                                       &net, &tr, NULL, NULL, err);
    if (rc)
        return rc;
    struct brdf_pair *grid = NULL;
    int ng = fit_pseudo_grid(&grid);
    struct fit_sample *dense = ng > 0 ? malloc(((size_t)ng + data->n_rgb) * sizeof *dense) : NULL;
    /* the measured lower bounds stay lower bounds; the network's values are values */
    unsigned char *lower = data->rgb_lower ? calloc((size_t)ng + data->n_rgb, 1) : NULL;
    if (!dense || (data->rgb_lower && !lower)) {
        fit_mlp_free(&net);
        free(grid);
        free(dense);
        free(lower);
        return gonio_err_set(err, ENOMEM, "abc-pseudo: out of memory");
    }
    if (lower)
        memcpy(lower, data->rgb_lower, data->n_rgb);
    /* Measured samples first, then the network's values at the grid. */
    memcpy(dense, data->rgb, data->n_rgb * sizeof *dense);
    size_t n = data->n_rgb;
    for (int k = 0; k < ng; k++) {
        double ti, trr, u[2], z[3];
        brdf_pair_to_inplane(&grid[k], &ti, &trr);
        u[0] = ti;
        u[1] = trr;
        fit_mlp_forward(&net, u, 1, z);
        dense[n].g = grid[k];
        for (int c = 0; c < 3; c++) {
            dense[n].rgb[c] = fit_mlp_value(z[c]);
            dense[n].u[c] = NAN; /* a network's value has no measurement uncertainty */
        }
        n++;
    }
    fit_mlp_free(&net);
    free(grid);
    struct fit_options fo = fit_default_options();
    fo.seed = (unsigned)o.seed;
    fo.lower_bound = lower;
    struct brdf_abc p;
    struct fit_info info;
    rc = fit_abc(dense, n, &fo, &p, &info, err);
    free(dense);
    free(lower);
    if (rc)
        return rc;
    /* What the data can determine is set by the measured geometries, not by
     * the network's values between them; and the fit has converged only if
     * both stages did. */
    size_t g = fit_status_geometries(data->rgb, NULL, data->n_rgb);
    if (g != (size_t)-1)
        info.status.geometries = g;
    if (!tr.early_stopped)
        info.status.findings |= 1u << FIT_STATUS_NOT_CONVERGED;
    fit_status_decide(&info.status);
    struct fit_model_file *f = fit_abc_fitted_file(&p, o.seed, &info);
    if (!f)
        return gonio_err_set(err, ENOMEM, "abc-pseudo: out of memory");
    fit_model_file_set(f, "source", "abc-pseudo");
    fit_model_file_set(f, "samples_measured", "%zu", data->n_rgb);
    fit_model_file_set(f, "samples_pseudo", "%d", ng);
    fit_model_file_set(f, "mlp_loss_heldout", "%.6g", tr.val_loss);
    if (rep) {
        rep->converged = info.converged && tr.early_stopped;
        rep->status = info.status;
        snprintf(rep->note, sizeof rep->note,
                 "MLP %d epochs (held-out loss %.3g); ABC on %zu measured + %d pseudo samples: "
                 "%d iterations, %s", tr.epochs, tr.val_loss, data->n_rgb, ng, info.iterations,
                 info.reason ? info.reason : "-");
    }
    *out = f;
    return 0;
}
