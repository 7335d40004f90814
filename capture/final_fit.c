#include "capture/final_fit.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/domain.h"
#include "fit/journal_samples.h"
#include "fit/model_run.h"

/* The capture's model file, DIR/NAME.model (the name `gonio fit DIR --model
 * NAME` writes by default), recorded in the summary. */
static void model_path(const char *dir, const char *name, struct capture_summary *out,
                       char *path, size_t len)
{
    snprintf(out->model_file, sizeof out->model_file, "%s.model", name);
    snprintf(path, len, "%.4000s/%s", dir, out->model_file);
}

int capture_fit_samples(const struct journal_sample *js, size_t n, const struct brdf_abc *warm,
                        const struct fit_model_kind *kind, const char *dir,
                        const char *material, int chosen, const double *u_systematic,
                        struct capture_summary *out, brdf_material **fitted,
                        struct gonio_err *err)
{
    struct fit_journal_data jd;
    int rc = fit_data_from_journal(js, n, &jd, err);
    if (rc < 0)
        return rc;
    out->saturated = jd.saturated;
    struct fit_data data =
        fit_journal_data_for(&jd, kind, FIT_SATURATED_DEFAULT, material, chosen);
    if (u_systematic)
        memcpy(data.u_systematic, u_systematic, sizeof data.u_systematic);
    /* --model auto takes the premise checks' verdicts so far */
    out->auto_evidence.isotropy = out->has_isotropy ? fit_auto_isotropy_of(out->isotropy.verdict)
                                                    : FIT_AUTO_ISOTROPY_UNKNOWN;
    data.auto_evidence = &out->auto_evidence;
    struct fit_model_options mo = fit_model_default_options();
    mo.warm_start = warm; /* the streaming fit's last parameters, when there is one */
    mo.warm_start_from = "the capture's streaming fit";
    struct fit_model_report rep = {0};
    char path[4200];
    model_path(dir, kind->name, out, path, sizeof path);
    rc = fit_model_run(kind, &data, &mo, path, &rep, fitted, err);
    out->fit_time_s = rep.fit_s;
    if (rc < 0 && err) {
        char msg[GONIO_ERR_MSG_MAX];
        snprintf(msg, sizeof msg, "%s", err->msg);
        gonio_err_set(err, err->code,
                      "final fit (model %s): %s; the %zu samples stay in %s/samples.csv",
                      kind->name, msg, n, dir);
    }
    if (rc < 0) {
        out->model_file[0] = '\0';
    } else {
        out->converged = rep.converged;
        out->status = rep.status;
        out->has_params = rep.has_abc;
        out->params = rep.abc;
        out->sd = rep.sd;
        out->sd_measured = rep.measured;
        snprintf(out->auto_chosen, sizeof out->auto_chosen, "%s", rep.auto_chosen);
        snprintf(out->auto_why, sizeof out->auto_why, "%s", rep.auto_why);
        snprintf(out->warning, sizeof out->warning, "%s", rep.warning);
        /* Plan-domain error: the model against what was measured. */
        rc = fit_sample_errors(*fitted, jd.rgb, jd.n, &out->err_plan, err);
    }
    fit_journal_data_free(&jd);
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
    if (rc >= 0 && !brdf_material_isotropic(truth))
        brdf_domain_turn(&full); /* the sample's every azimuth, not phi_h = 0 only */
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
