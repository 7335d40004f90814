#include "capture/final_fit.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/domain.h"
#include "common/clock.h"
#include "fit/abc_model.h"
#include "fit/abc_prior.h"
#include "fit/fit.h"
#include "fit/journal_samples.h"
#include "fit/model_file.h"
#include "fit/model_run.h"

/* The capture's model file, DIR/NAME.model (the name `gonio fit DIR --model
 * NAME` writes by default), recorded in the summary. */
static void model_path(const char *dir, const char *name, struct capture_summary *out,
                       char *path, size_t len)
{
    snprintf(out->model_file, sizeof out->model_file, "%s.model", name);
    snprintf(path, len, "%.4000s/%s", dir, out->model_file);
}

/* abc and abc-prior: fit_abc / fit_abc_map, warm-started from the
 * streaming fit, with parameter sds and (abc-prior) the too-few-samples
 * warning; the parameters go into results.json and, as gonio fit's abc
 * kind, into DIR/NAME.model, read back so that the errors are the file's. */
static int fit_abc_capture(const struct fit_data *data, const struct brdf_abc *warm,
                           const char *dir, const char *model, struct capture_summary *out,
                           brdf_material **fitted, struct gonio_err *err)
{
    const struct fit_sample *fs = data->rgb;
    size_t n = data->n_rgb;
    const char *material = data->material;
    struct fit_options opt = fit_default_options();
    opt.warm_start = warm; /* the streaming fit's last parameters, when there is one */
    opt.lower_bound = data->rgb_lower;
    opt.domain_weights = data->domain_weights;
    struct fit_info info;
    double t0 = gonio_monotonic_s();
    /* abc-prior: MAP with the population prior, the material left out of it */
    struct fit_abc_prior prior;
    int use_prior = !strcmp(model, "abc-prior");
    int rc = use_prior ? fit_abc_prior_build(material, &prior, err) : 0;
    if (rc == 0)
        rc = use_prior ? fit_abc_map(fs, n, &opt, &prior, &out->params, &info, err)
                       : fit_abc(fs, n, &opt, &out->params, &info, err);
    out->fit_time_s = gonio_monotonic_s() - t0;
    if (rc < 0)
        return rc;
    out->has_params = 1;
    out->sd = info.sd;
    if (use_prior)
        fit_abc_prior_warning(&info, n - info.dropped, out->warning, sizeof out->warning);
    out->converged = info.converged;
    out->status = info.status;

    /* The keys gonio fit's abc and abc-prior files carry, and where the
     * start came from (a warm start makes the file differ from gonio fit's). */
    struct fit_model_file *mf = fit_abc_fitted_file(&out->params, opt.seed, &info);
    if (mf && ((warm && fit_model_file_set(mf, "warm_start", "the capture's streaming fit")) ||
               (use_prior && fit_abc_prior_file_keys(mf, &prior, &info)))) {
        fit_model_file_free(mf);
        mf = NULL;
    }
    if (!mf)
        return gonio_err_set(err, ENOMEM, "out of memory");
    char path[4200];
    model_path(dir, model, out, path, sizeof path);
    rc = fit_model_write_open(mf, path, fitted, err);
    fit_model_file_free(mf);
    if (rc < 0)
        out->model_file[0] = '\0';
    return rc;
}

/* Any other registered RGB model: the fit `gonio fit` makes, its model
 * file written as DIR/NAME.model and read back, so that the errors below
 * are those of the file an operator renders or exports. */
static int fit_registry_capture(const struct fit_data *data, const char *dir,
                                const struct fit_model_kind *kind, struct capture_summary *out,
                                brdf_material **fitted, struct gonio_err *err)
{
    struct fit_model_options mo = fit_model_default_options();
    struct fit_model_report rep = {0};
    char path[4200];
    model_path(dir, kind->name, out, path, sizeof path);
    int rc = fit_model_run(kind, data, &mo, path, &rep, &out->fit_time_s, fitted, err);
    if (rc < 0) {
        out->model_file[0] = '\0';
        return rc;
    }
    out->converged = rep.converged;
    out->status = rep.status;
    return 0;
}

int capture_fit_samples(const struct journal_sample *js, size_t n, const struct brdf_abc *warm,
                        const struct fit_model_kind *kind, const char *dir,
                        const char *material, int chosen, struct capture_summary *out,
                        brdf_material **fitted, struct gonio_err *err)
{
    struct fit_sample *fs = malloc((n ? n : 1) * sizeof *fs);
    unsigned char *lower = malloc(n ? n : 1);
    if (!fs || !lower) {
        free(fs);
        free(lower);
        return gonio_err_set(err, ENOMEM, "out of memory");
    }
    out->saturated = fit_journal_samples(js, n, fs);
    for (size_t i = 0; i < n; i++)
        lower[i] = (js[i].flags & JOURNAL_FLAG_SATURATED) != 0;
    struct fit_data data = {.rgb = fs,
                            .n_rgb = n,
                            .rgb_lower = out->saturated && fit_model_censors(
                                             kind, FIT_SATURATED_DEFAULT) ? lower : NULL,
                            .material = material,
                            .domain_weights = chosen};
    int rc = !strcmp(kind->name, "abc") || !strcmp(kind->name, "abc-prior")
                 ? fit_abc_capture(&data, warm, dir, kind->name, out, fitted, err)
                 : fit_registry_capture(&data, dir, kind, out, fitted, err);
    if (rc < 0 && err) {
        char msg[GONIO_ERR_MSG_MAX];
        snprintf(msg, sizeof msg, "%s", err->msg);
        gonio_err_set(err, err->code,
                      "final fit (model %s): %s; the %zu samples stay in %s/samples.csv",
                      kind->name, msg, n, dir);
    }
    if (rc == 0) /* Plan-domain error: the model against what was measured. */
        rc = fit_sample_errors(*fitted, fs, n, &out->err_plan, err);
    free(fs);
    free(lower);
    return rc;
}

#define ASSESS_SEED UINT64_C(20261201) /* the sample of the full domain (assess_nodes) */
int capture_assess_truth(const brdf_material *truth, const brdf_material *model,
                         size_t assess_nodes, struct capture_summary *out,
                         struct gonio_err *err)
{
    struct brdf_domain inplane = {0}, full = {0};
    int rc = brdf_domain_inplane(&inplane, err);
    if (rc >= 0)
        rc = assess_nodes ? brdf_domain_oop_random(&full, assess_nodes, ASSESS_SEED, err)
                          : brdf_domain_full(&full, err);
    if (rc >= 0)
        rc = brdf_errors_material(truth, model, &inplane, &out->err_inplane, err);
    if (rc >= 0)
        rc = brdf_errors_material(truth, model, &full, &out->err_full, err);
    if (rc >= 0) {
        out->has_truth = 1;
        rc = 0;
    }
    brdf_domain_free(&inplane);
    brdf_domain_free(&full);
    return rc;
}
