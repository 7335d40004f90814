#include "capture/job.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "capture/calibration_check.h"
#include "capture/sequence.h"

static void job_inputs_free(struct capture_job *in)
{
    free(in->integration_s);
    if (in->cal)
        cal_loaded_free(in->cal);
    free(in->cal);
    in->cal = NULL;
    plan_free(in->plan);
    brdf_material_free(in->truth_own);
    in->integration_s = NULL;
    in->plan = NULL;
    in->truth_own = NULL;
}

/* "default" names the material actually used. */
static const char *material_spec(const char *spec)
{
    return strcmp(spec, "default") ? spec : brdf_material_default_spec();
}

/* What the rig measures, as its source knows it or as the host labels it;
 * and the reference of the truth errors: the named one, else what the
 * source says the rig measures, else none. */
static int resolve_materials(const struct capture_config *cfg, struct capture_job *in,
                             struct gonio_err *err)
{
    if (in->src->material) {
        in->truth = in->src->material;
        snprintf(in->material_name, sizeof in->material_name, "%s",
                 brdf_material_name(in->src->material));
    } else if (cfg->material) {
        snprintf(in->material_name, sizeof in->material_name, "%s",
                 material_spec(cfg->material));
    }
    if (cfg->truth) {
        if (!(in->truth_own = brdf_material_open(material_spec(cfg->truth), err)))
            return -abs(err ? err->code : GONIO_ENOTFOUND);
        in->truth = in->truth_own;
    }
    if (in->truth)
        snprintf(in->truth_name, sizeof in->truth_name, "%s", brdf_material_name(in->truth));
    return 0;
}

/* The capture's rig time before it runs. */
static int estimate(struct capture_job *in, struct gonio_err *err)
{
    size_t n = plan_count(in->plan);
    const struct capture_rig *src = in->src;
    if (!src->integration_s) {
        plan_estimate(in->plan, &in->rig, &in->est);
        return 0;
    }
    if (!(in->integration_s = malloc((n ? n : 1) * sizeof *in->integration_s)))
        return gonio_err_set(err, ENOMEM, "out of memory");
    plan_estimate_points(in->plan, &in->rig, src->integration_s, src->user, NULL, &in->est);
    for (size_t i = 0; i < n; i++)
        in->integration_s[i] = src->integration_s(src->user, plan_point(in->plan, i));
    return 0;
}

/* The pre-scan: cfg->prescan's points. By default on a host's rig, whose
 * material the engine cannot meter before it measures,
 * CAPTURE_PRESCAN_DEFAULT points, but one in CAPTURE_PRESCAN_SHARE of a
 * smaller plan's, and none when that is fewer than 2: the pre-scan crosses
 * the plan's domain once, which on a small plan costs more than its ETA is
 * worth (DS3, 52 points: 6 cost 19 s of 81 s, 2 cost 1.4 s; DS4, 6 points:
 * 2 cost 8 s of 18 s; docs/plans.md). None on a rig whose
 * source knows the integration its detector will choose (the estimate
 * already counts it), and never in the adaptive order, whose policy chooses every
 * point. */
static size_t prescan_default(const struct plan *plan)
{
    size_t n = plan_count(plan) / CAPTURE_PRESCAN_SHARE;
    return n < 2 ? 0 : n > CAPTURE_PRESCAN_DEFAULT ? CAPTURE_PRESCAN_DEFAULT : n;
}

int capture_prescan_option(const char *opt, long long points, int *prescan,
                           struct gonio_err *err)
{
    if (points < 0 || points > CAPTURE_PRESCAN_MAX)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "%s %lld: a number of points from 0 (none) to %d", opt, points,
                             CAPTURE_PRESCAN_MAX);
    *prescan = points ? (int)points : CAPTURE_PRESCAN_OFF;
    return 0;
}

static int resolve_prescan(const struct capture_config *cfg, struct capture_job *in,
                           struct gonio_err *err)
{
    if (cfg->prescan < CAPTURE_PRESCAN_OFF || cfg->prescan > CAPTURE_PRESCAN_MAX)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "prescan %d: a number of points from 0 (none) to %d",
                             cfg->prescan, CAPTURE_PRESCAN_MAX);
    if (cfg->prescan > 0 && in->adaptive)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "--prescan %d: the adaptive order chooses every point itself "
                             "(plan '%s')",
                             cfg->prescan, plan_name(in->plan));
    in->prescan = cfg->prescan > 0                        ? (size_t)cfg->prescan
                  : cfg->prescan == CAPTURE_PRESCAN_OFF ? 0
                  : !in->src->integration_s && !in->adaptive ? prescan_default(in->plan)
                                                         : 0;
    if (in->prescan > plan_count(in->plan))
        in->prescan = plan_count(in->plan);
    return 0;
}

enum plan_stop_kind capture_stop_kind(const struct capture_config *cfg, const struct plan *plan)
{
    if (cfg->stop)
        return strcmp(cfg->stop, "all") ? PLAN_STOP_CONVERGE : PLAN_STOP_ALL;
    return plan_stop(plan)->kind;
}

/* Resolve cfg on the rig source src into job (which capture_job_free
 * frees whatever fails). */
static int resolve_inputs(const struct capture_config *cfg, const struct capture_rig *src,
                          struct capture_job *in, struct gonio_err *err)
{
    in->src = src;
    int rc;
    const char *rig = cfg->rig ? cfg->rig : src->profile;
    if (!rig)
        return gonio_err_set(err, GONIO_EUSAGE, "no rig profile: name one (--rig NAME|FILE)");
    if ((rc = rig_profile_load(rig, &in->rig, err)) < 0 ||
        (rc = plan_load(cfg->plan, &in->rig, &in->plan, err)) < 0)
        return rc;
    if ((rc = capture_checks_rig("--check", cfg->checks, &in->rig, in->rig.name, err)) < 0)
        return rc;
    if (cfg->checks && cfg->measure_only)
        return gonio_err_set(err, GONIO_EUSAGE, "--check: not in a measure-only run");
    if (cfg->order) {
        int mode = plan_order_parse(cfg->order);
        if (mode < 0)
            return gonio_err_set(err, GONIO_EUSAGE,
                                 "--order '%s': use travel, progressive, as-written, greedy or "
                                 "adaptive",
                                 cfg->order);
        if ((rc = plan_order(in->plan, (enum plan_order_mode)mode, &in->rig)) < 0)
            return gonio_err_set(err, -rc, "ordering plan: %s", gonio_strerror(rc));
    }
    if (!(in->model = fit_model_find_rgb(cfg->model, "--model", err)))
        return -GONIO_EUSAGE;
    if (cfg->stop && strcmp(cfg->stop, "all") && strcmp(cfg->stop, "converge"))
        return gonio_err_set(err, GONIO_EUSAGE, "--stop '%s': use all or converge", cfg->stop);
    in->adaptive = plan_current_order(in->plan) == PLAN_ORDER_ADAPTIVE;
    if (in->adaptive && cfg->uncalibrated) /* its policy predicts and scores BRDF values */
        return gonio_err_set(err, GONIO_EUSAGE,
                             "--uncalibrated with --order adaptive (plan '%s'): the adaptive "
                             "order chooses its points from BRDF values, which an uncalibrated "
                             "capture does not have; give a calibration, or another order",
                             plan_name(in->plan));
    int converge = capture_stop_kind(cfg, in->plan) == PLAN_STOP_CONVERGE;
    if ((rc = sequence_options(cfg, in->plan, converge, &in->policy, err)) < 0 ||
        (rc = resolve_prescan(cfg, in, err)) < 0 || (rc = resolve_materials(cfg, in, err)) < 0)
        return rc;
    return estimate(in, err);
}

/* The calibration the capture reduces with, chosen and checked before
 * anything moves (capture/calibration.h). The gain state is the
 * detector's to say at its first reading; the calibration's own holds. */
static int resolve_calibration(const struct capture_config *cfg, struct capture_job *in,
                               struct gonio_err *err)
{
    if (!cfg->calibrations && cfg->reference_after && !cfg->estimate_only)
        return gonio_err_set(err, GONIO_EUSAGE, "--reference-after: the standard is read again "
                             "against a calibration, and the capture names none");
    if (!cfg->calibrations)
        return 0;
    struct cal_need need = {.rig = in->rig.name,
                            .detector = in->src->detector ? in->src->detector : "unknown",
                            .integration_s = in->rig.integration_s, .gain_state = -1,
                            .now = time(NULL)};
    struct cal_meta m;
    int rc = cal_select(cfg->calibrations, cfg->calibration, &need, &m, err);
    if (rc < 0)
        return rc;
    if (!(in->cal = calloc(1, sizeof *in->cal)))
        return gonio_err_set(err, ENOMEM, "out of memory");
    if ((rc = cal_load(cfg->calibrations, m.id, in->cal, err)) < 0)
        return rc;
    if (cfg->reference_after && !cfg->estimate_only && in->cal->meta.kind == CAL_BEAM)
        return gonio_err_set(err, GONIO_EUSAGE, "--reference-after: calibration %s is a beam "
                             "calibration, read with no standard; --reference-after reads the "
                             "standard again and needs a reference calibration", m.id);
    return 0;
}

/* The job's own copy of cfg: every string member copied into one block. */
static int copy_config(const struct capture_config *cfg, struct capture_job *job,
                       struct gonio_err *err)
{
    job->cfg = *cfg;
    const char **member[] = {&job->cfg.plan, &job->cfg.material, &job->cfg.rig,
                             &job->cfg.truth, &job->cfg.model, &job->cfg.out_dir,
                             &job->cfg.order, &job->cfg.stop, &job->cfg.calibration,
                             &job->cfg.calibrations, &job->cfg.sample,
                             &job->cfg.operator_name, &job->cfg.note};
    size_t n = sizeof member / sizeof *member, len = 0;
    for (size_t i = 0; i < n; i++)
        len += *member[i] ? strlen(*member[i]) + 1 : 0;
    if (!(job->text = malloc(len ? len : 1)))
        return gonio_err_set(err, ENOMEM, "out of memory");
    char *at = job->text;
    for (size_t i = 0; i < n; i++) {
        if (!*member[i])
            continue;
        size_t l = strlen(*member[i]) + 1;
        memcpy(at, *member[i], l);
        *member[i] = at;
        at += l;
    }
    return 0;
}

const struct plan_estimate *capture_job_estimate(const capture_job *job)
{
    return &job->est;
}

void capture_job_free(capture_job *job)
{
    if (!job)
        return;
    job_inputs_free(job);
    free(job->text);
    free(job);
}

int capture_prepare(const struct capture_config *cfg, const struct capture_rig *rig,
                    capture_job **out, struct gonio_err *err)
{
    *out = NULL;
    capture_job *job = calloc(1, sizeof *job);
    if (!job)
        return gonio_err_set(err, ENOMEM, "out of memory");
    int rc = copy_config(cfg, job, err);
    if (rc == 0) /* before anything is written or moved */
        rc = capture_calibration_check(&job->cfg, rig->counts, rig->detector, err);
    if (rc == 0)
        rc = resolve_inputs(&job->cfg, rig, job, err);
    if (rc == 0)
        rc = resolve_calibration(&job->cfg, job, err);
    if (rc < 0) {
        capture_job_free(job);
        return rc;
    }
    *out = job;
    return 0;
}

int capture_check(const struct capture_config *cfg, const struct capture_rig *rig,
                  struct plan_estimate *est, struct gonio_err *err)
{
    capture_job *job;
    int rc = capture_prepare(cfg, rig, &job, err);
    if (rc < 0)
        return rc;
    if (est)
        *est = job->est;
    capture_job_free(job);
    return 0;
}
