/* ABC through the model registry and model files (fit/abc_model.h). */
#include "fit/abc_model.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fit/domain_weights.h"
#include "fit/model_file.h"

struct fit_model_file *fit_abc_model_file(const struct brdf_abc *p)
{
    struct fit_model_file *f = fit_model_file_new("abc", FIT_ABC_FILE_VERSION);
    double x[9] = {p->kd[0], p->kd[1], p->kd[2], p->A[0], p->A[1], p->A[2], p->B, p->C, p->eta};
    if (!f || fit_model_file_set(f, "layout", "kd_r,kd_g,kd_b,A_r,A_g,A_b,B,C,eta") ||
        fit_model_file_set(f, "convention", "A without the 1/pi of the published MERL fits") ||
        fit_model_file_set_data(f, x, 9)) {
        fit_model_file_free(f);
        return NULL;
    }
    return f;
}

struct fit_model_file *fit_abc_fitted_file(const struct brdf_abc *p, unsigned long long seed,
                                           const struct fit_info *info)
{
    struct fit_model_file *f = fit_abc_model_file(p);
    if (f && (fit_model_file_set(f, "seed", "%llu", seed) ||
              fit_model_file_set(f, "cost", "%.6g", info->cost) ||
              fit_model_file_set(f, "scale", "%.17g", info->scale) ||
              (info->domain_weights &&
               fit_model_file_set(f, "weights", FIT_DOMAIN_WEIGHTS_NOTE)) ||
              fit_status_file_keys(f, &info->status))) {
        fit_model_file_free(f);
        return NULL;
    }
    return f;
}

int fit_abc_warm_start_key(struct fit_model_file *f, const struct fit_model_options *opt)
{
    if (!opt->warm_start)
        return 0;
    return fit_model_file_set(f, "warm_start", "%s",
                              opt->warm_start_from ? opt->warm_start_from : "given");
}

int fit_abc_model_params(const struct fit_model_file *f, const char *path, struct brdf_abc *p,
                         struct gonio_err *err)
{
    if (strcmp(f->kind, "abc") || f->version != FIT_ABC_FILE_VERSION)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: %s version %d is not an abc model "
                             "version %d", path, f->kind, f->version, FIT_ABC_FILE_VERSION);
    if (f->n_data != 9)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: abc model holds %zu values (need 9)",
                             path, f->n_data);
    const double *x = f->data;
    for (int k = 0; k < 9; k++)
        if (!isfinite(x[k]) || x[k] < 0)
            return gonio_err_set(err, GONIO_EBADDATA, "%s: abc parameter %d is %g "
                                 "(must be finite and >= 0)", path, k, x[k]);
    if (x[8] < 1)
        return gonio_err_set(err, GONIO_EBADDATA, "%s: abc eta %g < 1", path, x[8]);
    *p = (struct brdf_abc){{x[0], x[1], x[2]}, {x[3], x[4], x[5]}, x[6], x[7], x[8]};
    return 0;
}

brdf_material *fit_abc_model_open(const struct fit_model_file *f, const char *name,
                                  struct gonio_err *err)
{
    const char *path = name && !strncmp(name, "model:", 6) ? name + 6 : name ? name : "(model)";
    struct brdf_abc p;
    if (fit_abc_model_params(f, path, &p, err))
        return NULL;
    brdf_material *m = brdf_abc_material(&p, name);
    if (!m)
        gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    return m;
}

int fit_abc_model_fit(const struct fit_data *data, const struct fit_model_options *opt,
                      struct fit_model_file **out, struct fit_model_report *rep,
                      struct gonio_err *err)
{
    struct fit_model_options o = opt ? *opt : fit_model_default_options();
    if (!data->n_rgb)
        return gonio_err_set(err, GONIO_EUSAGE, "abc: needs RGB samples");
    struct fit_options fo = fit_default_options();
    fo.seed = (unsigned)o.seed;
    fo.lower_bound = data->rgb_lower;
    fo.domain_weights = data->domain_weights;
    memcpy(fo.u_systematic, data->u_systematic, sizeof fo.u_systematic);
    fo.warm_start = o.warm_start;
    struct brdf_abc p;
    struct fit_info info;
    int rc = fit_abc(data->rgb, data->n_rgb, &fo, &p, &info, err);
    if (rc)
        return rc;
    struct fit_model_file *f = fit_abc_fitted_file(&p, o.seed, &info);
    if (f && fit_abc_warm_start_key(f, &o)) {
        fit_model_file_free(f);
        f = NULL;
    }
    if (!f)
        return gonio_err_set(err, ENOMEM, "abc: out of memory");
    if (rep) {
        rep->has_abc = 1;
        rep->abc = p;
        rep->sd = info.sd;
        rep->converged = info.converged;
        rep->status = info.status;
        rep->weighted = info.domain_weights;
        rep->measured = info.measurement_weights;
        snprintf(rep->note, sizeof rep->note, "%d starts, %d iterations, %s; %zu samples dropped",
                 info.starts, info.iterations, info.reason ? info.reason : "-", info.dropped);
    }
    *out = f;
    return 0;
}
