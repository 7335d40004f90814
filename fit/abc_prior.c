/* The population prior for ABC and the MAP fit (fit/abc_prior.h). */
#include "fit/abc_prior.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include <gsl/gsl_linalg.h>
#include <gsl/gsl_matrix.h>

#include "fit/abc_model.h"
#include "fit/abc_prior_private.h"
#include "fit/model_file.h"
#include "fit/abc_problem.h"

/* Ridge added to the covariance's diagonal: keeps it positive definite
 * however collinear the table's columns are (the kd channels nearly are). */
#define PRIOR_RIDGE 1e-4

static const char *bare_name(const char *spec)
{
    const char *colon = spec ? strrchr(spec, ':') : NULL;
    return colon ? colon + 1 : spec;
}

int fit_abc_prior_build(const char *exclude, struct fit_abc_prior *out, struct gonio_err *err)
{
    memset(out, 0, sizeof *out);
    out->sigma = FIT_PRIOR_SIGMA;
    const char *ex = bare_name(exclude);
    double th[128][ABC_NPAR];
    size_t m = 0;
    for (size_t i = 0; i < abc_prior_n_rows && m < 128; i++) {
        const struct abc_prior_row *row = &abc_prior_rows[i];
        if (ex && *ex && !strcmp(row->name, ex)) {
            snprintf(out->excluded, sizeof out->excluded, "%s", row->name);
            continue;
        }
        struct brdf_abc p = {{row->v[0], row->v[1], row->v[2]},
                             {row->v[3], row->v[4], row->v[5]}, row->v[6], row->v[7], row->v[8]};
        for (int c = 0; c < 3; c++) {
            p.kd[c] = fmax(p.kd[c], FIT_PRIOR_FLOOR);
            p.A[c] = fmax(p.A[c], FIT_PRIOR_FLOOR);
        }
        abc_params_to_theta(&p, th[m]);
        out->shapes[m][0] = p.B;
        out->shapes[m][1] = p.C;
        out->shapes[m][2] = p.eta;
        m++;
    }
    if (m < 2 * ABC_NPAR)
        return gonio_err_set(err, GONIO_EFIT, "abc prior: %zu materials, need %d", m,
                             2 * ABC_NPAR);
    for (size_t k = 0; k < m; k++)
        for (int j = 0; j < ABC_NPAR; j++)
            out->mean[j] += th[k][j] / (double)m;
    for (int a = 0; a < ABC_NPAR; a++)
        for (int b = 0; b < ABC_NPAR; b++) {
            double s = 0;
            for (size_t k = 0; k < m; k++)
                s += (th[k][a] - out->mean[a]) * (th[k][b] - out->mean[b]);
            out->cov[a * ABC_NPAR + b] = s / (double)(m - 1) + (a == b ? PRIOR_RIDGE : 0.0);
        }
    out->n_materials = m;
    out->n_shapes = m;
    return 0;
}

/* W = sigma L^-1 with cov = L L^T, so |W d|^2 = sigma^2 d^T cov^-1 d. */
static int prior_term(const struct fit_abc_prior *pr, struct abc_prior_term *t)
{
    gsl_matrix *L = gsl_matrix_alloc(ABC_NPAR, ABC_NPAR);
    if (!L)
        return -1;
    memcpy(L->data, pr->cov, sizeof pr->cov);
    int rc = gsl_linalg_cholesky_decomp1(L);
    if (rc == 0)
        rc = gsl_linalg_tri_lower_invert(L);
    if (rc == 0) {
        memcpy(t->mean, pr->mean, sizeof t->mean);
        t->shapes = (const double(*)[3])pr->shapes;
        t->n_shapes = pr->n_shapes;
        for (int i = 0; i < ABC_NPAR; i++)
            for (int j = 0; j < ABC_NPAR; j++)
                t->W[i * ABC_NPAR + j] =
                    j <= i ? pr->sigma * gsl_matrix_get(L, (size_t)i, (size_t)j) : 0.0;
    }
    gsl_matrix_free(L);
    return rc ? -1 : 0;
}

int fit_abc_map(const struct fit_sample *samples, size_t n, const struct fit_options *opt,
                const struct fit_abc_prior *prior, struct brdf_abc *out, struct fit_info *info,
                struct gonio_err *err)
{
    if (!prior || !(prior->sigma > 0))
        return gonio_err_set(err, GONIO_EUSAGE, "fit_abc_map: no prior, or sigma <= 0");
    struct abc_prior_term t;
    if (prior_term(prior, &t) < 0)
        return gonio_err_set(err, GONIO_EFIT,
                             "fit_abc_map: prior covariance is not positive definite");
    return abc_fit_run(samples, n, opt, &t, prior->sigma, out, info, err);
}

int fit_abc_prior_warning(const struct fit_info *info, size_t n_samples, char *buf, size_t len)
{
    if (len)
        buf[0] = 0;
    double sd = info->sd.pred_log;
    if (isfinite(sd) && sd <= FIT_PRIOR_WARN_PRED_SD)
        return 0;
    snprintf(buf, len,
             "warning: %zu samples are not enough here: the fitted BRDF is uncertain by %.3f "
             "in log(1 + f cos) in plane (> %.2f); measure more pairs, near the mirror first",
             n_samples, sd, FIT_PRIOR_WARN_PRED_SD);
    return 1;
}

int fit_abc_prior_file_keys(struct fit_model_file *f, const struct fit_abc_prior *prior,
                            const struct fit_info *info)
{
    /* the population is gonio's DS1 fits of the NBRDFs (fit/abc_prior_table.c) */
    int rc = fit_model_file_set(f, "prior", "ABC fits (DS1) of %zu MERL materials%s%s, "
                                "sigma %g", prior->n_materials,
                                prior->excluded[0] ? " without " : "", prior->excluded,
                                prior->sigma);
    if (rc == 0)
        rc = fit_model_file_set(f, "sd_log_B", "%.4g", info->sd.log_B);
    if (rc == 0)
        rc = fit_model_file_set(f, "sd_log_C", "%.4g", info->sd.log_C);
    if (rc == 0)
        rc = fit_model_file_set(f, "sd_eta", "%.4g", info->sd.eta);
    if (rc == 0)
        rc = fit_model_file_set(f, "sd_pred_log", "%.4g", info->sd.pred_log);
    return rc;
}

int fit_abc_prior_model_fit(const struct fit_data *data, const struct fit_model_options *opt,
                            struct fit_model_file **out, struct fit_model_report *rep,
                            struct gonio_err *err)
{
    struct fit_model_options o = opt ? *opt : fit_model_default_options();
    if (!data->n_rgb)
        return gonio_err_set(err, GONIO_EUSAGE, "abc-prior: needs RGB samples");
    struct fit_abc_prior prior;
    int rc = fit_abc_prior_build(data->material, &prior, err);
    if (rc < 0)
        return rc;
    struct fit_options fo = fit_default_options();
    fo.seed = (unsigned)o.seed;
    fo.lower_bound = data->rgb_lower;
    fo.domain_weights = data->domain_weights;
    fo.warm_start = o.warm_start;
    struct brdf_abc p;
    struct fit_info info;
    if ((rc = fit_abc_map(data->rgb, data->n_rgb, &fo, &prior, &p, &info, err)) < 0)
        return rc;
    struct fit_model_file *f = fit_abc_fitted_file(&p, o.seed, &info);
    if (f && (fit_abc_warm_start_key(f, &o) || fit_abc_prior_file_keys(f, &prior, &info))) {
        fit_model_file_free(f);
        f = NULL;
    }
    if (!f)
        return gonio_err_set(err, ENOMEM, "abc-prior: out of memory");
    if (rep) {
        char warn[200];
        int w = fit_abc_prior_warning(&info, data->n_rgb - info.dropped, warn, sizeof warn);
        rep->has_abc = 1;
        rep->abc = p;
        rep->sd = info.sd;
        fit_abc_prior_warning(&info, data->n_rgb - info.dropped, rep->warning,
                              sizeof rep->warning);
        rep->converged = info.converged;
        rep->status = info.status;
        snprintf(rep->note, sizeof rep->note,
                 "%d starts, %d iterations; prior of %zu materials%s%s; sd log B %.2f, "
                 "predicted in-plane sd %.3f%s%s",
                 info.starts, info.iterations, prior.n_materials,
                 prior.excluded[0] ? " without " : "", prior.excluded, info.sd.log_B,
                 info.sd.pred_log,
                 w ? "; " : "", w ? warn : "");
    }
    *out = f;
    return 0;
}
