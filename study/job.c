/* One study job: capture once, then fit and assess every missing model. */
#include "study/study.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <jansson.h>

#include "brdf/domain.h"
#include "brdf/material.h"
#include "brdf/metrics.h"
#include "common/paths.h"
#include "capture/capture.h"
#include "sim_source/sim_source.h"
#include "fit/journal_samples.h"
#include "journal/journal.h"
#include "fit/model_file.h"
#include "fit/model_run.h"
#include "fit/models.h"
#include "study/study_private.h"

#define BLOCK 4096

/* The true material on the two reference domains, evaluated once a job
 * and shared by its models. */
struct truth_values {
    struct brdf_domain inplane, full;
    double *v_inplane, *v_full;
};

static void truth_free(struct truth_values *t)
{
    brdf_domain_free(&t->inplane);
    brdf_domain_free(&t->full);
    free(t->v_inplane);
    free(t->v_full);
    memset(t, 0, sizeof *t);
}

static int truth_eval(const brdf_material *truth, struct truth_values *t, struct gonio_err *err)
{
    memset(t, 0, sizeof *t);
    int rc = brdf_domain_inplane(&t->inplane, err);
    if (rc >= 0)
        rc = brdf_domain_full(&t->full, err);
    if (rc < 0) {
        truth_free(t);
        return rc;
    }
    t->v_inplane = malloc(3 * t->inplane.n * sizeof *t->v_inplane);
    t->v_full = malloc(3 * t->full.n * sizeof *t->v_full);
    if (!t->v_inplane || !t->v_full) {
        truth_free(t);
        return gonio_err_set(err, ENOMEM, "out of memory");
    }
    brdf_material_eval(truth, t->inplane.pairs, t->inplane.n, t->v_inplane);
    brdf_material_eval(truth, t->full.pairs, t->full.n, t->v_full);
    return 0;
}

/* The model against truth values on a domain, block by block (the sums run
 * in domain order, as brdf_errors_material's do). */
static int domain_errors(const brdf_material *model, const struct brdf_domain *d,
                         const double *truth, struct brdf_errors *out, struct gonio_err *err)
{
    struct brdf_errors_acc acc;
    brdf_errors_acc_init(&acc);
    double *pred = malloc(3 * BLOCK * sizeof *pred);
    if (!pred)
        return gonio_err_set(err, ENOMEM, "out of memory");
    for (size_t i = 0; i < d->n; i += BLOCK) {
        size_t m = d->n - i < BLOCK ? d->n - i : BLOCK;
        brdf_material_eval(model, d->pairs + i, m, pred);
        brdf_errors_acc_add(&acc, d->pairs + i, truth + 3 * i, pred, m);
    }
    free(pred);
    brdf_errors_acc_finish(&acc, out);
    return 0;
}

/* A JSON number, or null for NaN/inf. */
static json_t *num(double v)
{
    return isfinite(v) ? json_real(v) : json_null();
}

/* Commas and line breaks cannot stand in a CSV field of ours. */
static void clean_note(char *s)
{
    for (; *s; s++) {
        if (*s == ',')
            *s = ';';
        else if (*s == '\n' || *s == '\r' || *s == '"')
            *s = ' ';
    }
}

struct row_capture {
    const char *job_id, *material, *material_spec, *scene, *plan;
    const struct capture_summary *sum;
    long plan_points;
    double calibration_s; /* the calibration's rig time; NAN: none */
};

struct row_fit {
    const char *model, *status;
    double wall_s, cpu_s;
    int converged;
    struct fit_status fit; /* the fit's status (fit/fit_status.h) */
    struct brdf_errors plan, inplane, full;
    char note[600];
};

/* The row object: exactly the keys of study_cols, in their order. */
static json_t *row_json(const struct row_capture *c, const struct row_fit *f)
{
    char row_id[512], model_file[512], samples_file[512];
    snprintf(row_id, sizeof row_id, "%s.%s", c->job_id, f->model);
    snprintf(model_file, sizeof model_file, "jobs/%s/%s.model", c->job_id, f->model);
    snprintf(samples_file, sizeof samples_file, "jobs/%s/samples.csv", c->job_id);
    int ok = !strcmp(f->status, "ok");
    /* A model without a value at some full-domain node (the in-plane mlp)
     * has no full-domain error: the mean over the nodes it covers would
     * read as one. */
    int full_ok = ok && f->full.n_skipped == 0;
    json_t *o = json_object();
    json_object_set_new(o, "row_id", json_string(row_id));
    json_object_set_new(o, "material", json_string(c->material));
    json_object_set_new(o, "material_spec", json_string(c->material_spec));
    json_object_set_new(o, "scene", json_string(c->scene));
    json_object_set_new(o, "plan", json_string(c->plan));
    json_object_set_new(o, "model", json_string(f->model));
    json_object_set_new(o, "status", json_string(f->status));
    json_object_set_new(o, "samples", json_integer((json_int_t)c->sum->samples));
    json_object_set_new(o, "plan_points", json_integer(c->plan_points));
    json_object_set_new(o, "stop_reason", json_string(c->sum->stop_reason));
    json_object_set_new(o, "rig_time_s", num(c->sum->rig_time_s));
    json_object_set_new(o, "move_s", num(c->sum->move_s));
    json_object_set_new(o, "settle_s", num(c->sum->settle_s));
    json_object_set_new(o, "integration_s", num(c->sum->integration_s));
    json_object_set_new(o, "calibration_s", num(c->calibration_s));
    /* The checks' verdicts and rig time: the isotropy check's is the
     * capture's, for every row; the out-of-plane check's only in the row of
     * the model the capture fitted and checked. */
    const struct capture_summary *sum = c->sum;
    int oop = sum->has_oop && !strcmp(f->model, sum->model);
    json_object_set_new(o, "isotropy",
                        sum->has_isotropy ? json_string(sum->isotropy.verdict) : json_null());
    json_object_set_new(o, "isotropy_s", num(sum->has_isotropy ? sum->isotropy.rig_time_s : NAN));
    json_object_set_new(o, "oop", oop ? json_string(sum->oop.verdict) : json_null());
    json_object_set_new(o, "oop_s", num(oop ? sum->oop.rig_time_s : NAN));
    json_object_set_new(o, "fit_wall_s", num(f->wall_s));
    json_object_set_new(o, "fit_cpu_s", num(f->cpu_s));
    json_object_set_new(o, "fit_converged", json_integer(f->converged));
    study_row_status(o, ok ? &f->fit : NULL);
    json_object_set_new(o, "plan_log", num(ok ? f->plan.log : NAN));
    json_object_set_new(o, "plan_rel_rmse", num(ok ? f->plan.rel_rmse : NAN));
    json_object_set_new(o, "plan_n", ok ? json_integer((json_int_t)f->plan.n_used) : json_null());
    json_object_set_new(o, "inplane_log", num(ok ? f->inplane.log : NAN));
    json_object_set_new(o, "inplane_rel_rmse", num(ok ? f->inplane.rel_rmse : NAN));
    json_object_set_new(o, "inplane_n",
                        ok ? json_integer((json_int_t)f->inplane.n_used) : json_null());
    json_object_set_new(o, "full_log", num(full_ok ? f->full.log : NAN));
    json_object_set_new(o, "full_rel_rmse", num(full_ok ? f->full.rel_rmse : NAN));
    json_object_set_new(o, "full_n", ok ? json_integer((json_int_t)f->full.n_used) : json_null());
    json_object_set_new(o, "full_skipped",
                        ok ? json_integer((json_int_t)f->full.n_skipped) : json_null());
    json_object_set_new(o, "model_file", ok ? json_string(model_file) : json_null());
    json_object_set_new(o, "samples_file", json_string(samples_file));
    json_object_set_new(o, "note", json_string(f->note));
    return o;
}

static int write_json_atomic(const char *path, json_t *o, struct gonio_err *err)
{
    char *text = json_dumps(o, JSON_INDENT(1) | JSON_REAL_PRECISION(17));
    if (!text)
        return gonio_err_set(err, ENOMEM, "out of memory");
    size_t len = strlen(text);
    char *withnl = realloc(text, len + 2);
    if (!withnl) {
        free(text);
        return gonio_err_set(err, ENOMEM, "out of memory");
    }
    withnl[len] = '\n';
    withnl[len + 1] = '\0';
    int rc = gonio_write_file_atomic(path, withnl, len + 1, err);
    free(withnl);
    return rc;
}

/* Fit one model, write its model file, measure it, fill f. A fit that
 * refuses the samples is a row of its own (status fit-failed); only
 * failures of the machinery are errors. */
static int fit_one(const struct study_spec *s, size_t mi, const char *jobdir,
                   const struct fit_journal_data *jd, int chosen, const char *material_spec,
                   const struct truth_values *t, struct row_fit *f, struct gonio_err *err)
{
    const struct fit_model_kind *kind = fit_model_find(s->models[mi].name);
    memset(f, 0, sizeof *f);
    f->model = s->models[mi].name;
    f->status = "ok";
    f->plan.log = f->inplane.log = f->full.log = NAN;
    if (!kind)
        return gonio_err_set(err, GONIO_EUSAGE, "unknown model '%s'", s->models[mi].name);
    /* an adaptive policy's samples are fitted as the capture fits them */
    struct fit_data data = fit_journal_data_for(jd, kind, s->saturated, material_spec, chosen);
    struct fit_model_options mo = fit_model_default_options();
    struct fit_model_report rep = {0};
    struct gonio_err fe = {0};
    char path[4300];
    snprintf(path, sizeof path, "%.4000s/%s.model", jobdir, f->model);
    /* Assessed as written: what a reader of the model file gets. */
    brdf_material *m = NULL;
    int rc = fit_model_run(kind, &data, &mo, path, &rep, &m, &fe);
    f->wall_s = rep.fit_s;
    f->cpu_s = rep.cpu_s;
    if (rc < 0 && !rep.fitted) {
        f->status = "fit-failed";
        snprintf(f->note, sizeof f->note, "%s", fe.msg[0] ? fe.msg : gonio_strerror(rc));
        clean_note(f->note);
        return 0;
    }
    if (rc < 0) { /* the model file's failure, not the fit's */
        if (err)
            *err = fe;
        return rc;
    }
    f->converged = rep.converged;
    f->fit = rep.status;
    snprintf(f->note, sizeof f->note, "%s", rep.note);
    clean_note(f->note);
    rc = fit_sample_errors(m, jd->rgb, jd->n, &f->plan, err);
    if (rc == 0)
        rc = domain_errors(m, &t->inplane, t->v_inplane, &f->inplane, err);
    if (rc == 0)
        rc = domain_errors(m, &t->full, t->v_full, &f->full, err);
    brdf_material_free(m);
    return rc;
}

static long plan_points(const char *jobdir)
{
    char path[4200];
    snprintf(path, sizeof path, "%.4000s/plan.json", jobdir);
    json_t *root = json_load_file(path, 0, NULL);
    json_t *count = root ? json_object_get(root, "count") : NULL;
    long n = json_is_integer(count) ? (long)json_integer_value(count) : -1;
    json_decref(root);
    return n;
}

/* An exclusive lock on the job folder, held until the process ends or
 * the descriptor is closed. */
static int lock_job(const char *jobdir, const char *id, int *fd, struct gonio_err *err)
{
    char path[4200];
    snprintf(path, sizeof path, "%.4000s/lock", jobdir);
    *fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (*fd < 0)
        return gonio_err_set(err, errno, "%s: %s", path, strerror(errno));
    struct flock fl = {.l_type = F_WRLCK, .l_whence = SEEK_SET};
    if (fcntl(*fd, F_SETLK, &fl) != 0) {
        close(*fd);
        *fd = -1;
        return gonio_err_set(err, GONIO_EUSAGE,
                             "job %s is being run by another gonio study process (%s locked)",
                             id, path);
    }
    return 0;
}

/* The host's stop request, as the capture engine asks for it. */
struct stop_check {
    int (*stop)(void);
};

static enum capture_control stop_control(void *user)
{
    const struct stop_check *sc = user;
    return sc->stop() ? CAPTURE_ABORT : CAPTURE_GO;
}

/* cfg's budget: the named plan's rig time as a capture of it on cfg's
 * scene and material would estimate it (what that plan would cost this
 * job, for a budget "of DS4's rig time"). */
static int budget_of(struct capture_config *cfg, const char *scene, const char *plan,
                     struct gonio_err *err)
{
    /* the job's calibration: a scene of counts is refused without one */
    struct capture_config c = {.plan = plan, .material = cfg->material, .model = "abc",
                               .calibrations = cfg->calibrations};
    struct plan_estimate est;
    int rc = sim_source_check(scene, &c, &est, err);
    if (rc == 0)
        cfg->budget_min = est.total_s / 60;
    return rc;
}

int study_job_run(const struct study_spec *s, const struct study_job *job, const char *dir,
                  int (*stop)(void), struct gonio_err *err)
{
    struct study_plan plan_buf;
    const struct study_plan *plan = &plan_buf;
    const struct study_item *mat = &s->materials[job->material], *scene = &s->scenes[job->scene];
    if (study_plan_of(&s->plans[job->plan], &plan_buf) < 0)
        return gonio_err_set(err, GONIO_EUSAGE, "unknown plan '%s'", s->plans[job->plan].name);
    char jobdir[4096];
    if (snprintf(jobdir, sizeof jobdir, "%s/jobs/%s", dir, job->id) >= (int)sizeof jobdir)
        return gonio_err_set(err, GONIO_EUSAGE, "%s: path too long", dir);
    int rc = gonio_mkdir_p(jobdir, err);
    if (rc < 0)
        return rc;
    int lock_fd = -1;
    if ((rc = lock_job(jobdir, job->id, &lock_fd, err)) < 0)
        return rc;

    /* The capture: a rerun resumes it from its journal (or finds it done). */
    struct capture_config cfg = {
        .plan = plan->file, .material = mat->spec,
        .model = plan->model ? plan->model : "abc", /* the adaptive policy's */
        .out_dir = jobdir, .order = plan->order, .stop = plan->stop, .quiet = 1,
        .measure_only = 1, .lazy_journal = 1, .budget_min = plan->budget_min,
        .checks = s->checks, .rig = s->rig[0] ? s->rig : NULL,
    };
    /* The out-of-plane check judges a fitted model: the capture fits the
     * study's first model (or the adaptive policy's) and checks it. */
    if (s->checks & CAPTURE_CHECK_OUT_OF_PLANE) {
        cfg.measure_only = 0;
        if (!plan->model)
            cfg.model = s->models[0].name;
    }

    struct capture_summary sum;
    struct fit_journal_data jd = {0};
    struct journal_sample *js = NULL;
    size_t n = 0;
    brdf_material *truth = NULL;
    struct truth_values t = {0};
    int written = 0;
    char path[4200];
    struct stop_check sc = {stop};
    struct capture_hooks hooks = {.control = stop ? stop_control : NULL, .user = &sc};
    /* A detector of counts is calibrated first, as on hardware. */
    char cal_root[4200];
    double cal_s = NAN;
    rc = study_calibrate(scene->spec, plan->file, jobdir, cal_root, sizeof cal_root, &cal_s,
                         err);
    if (rc == 0 && cal_root[0])
        cfg.calibrations = cal_root;
    else
        cal_s = NAN;
    if (rc == 0 && plan->budget_of)
        rc = budget_of(&cfg, scene->spec, plan->budget_of, err);
    if (rc == 0)
        rc = sim_source_capture(scene->spec, &cfg, &hooks, &sum, err);
    if (rc == 0 && !strcmp(sum.stop_reason, "aborted"))
        rc = gonio_err_set(err, EINTR, "interrupted; its journal is kept for the rerun");
    if (rc == 0) {
        snprintf(path, sizeof path, "%s/samples.csv", jobdir);
        rc = journal_read(path, &js, &n, err);
    }
    if (rc == 0)
        rc = fit_data_from_journal(js, n, &jd, err);
    size_t saturated = jd.saturated;
    if (rc == 0 && !(truth = brdf_material_open(mat->spec, err)))
        rc = -abs(err && err->code ? err->code : GONIO_ENOTFOUND);
    if (rc == 0)
        rc = truth_eval(truth, &t, err);
    struct row_capture rc_info = {
        .job_id = job->id, .material = mat->name, .material_spec = mat->spec,
        .scene = scene->name, .plan = plan->name, .sum = &sum,
        .plan_points = plan_points(jobdir), .calibration_s = cal_s,
    };
    for (size_t m = 0; rc == 0 && m < s->n_models; m++) {
        study_row_path(dir, job->id, s->models[m].name, path, sizeof path);
        if (access(path, F_OK) == 0)
            continue; /* finished by an earlier run */
        struct row_fit f;
        rc = fit_one(s, m, jobdir, &jd, sum.adaptive, mat->spec, &t, &f, err);
        if (rc < 0)
            break;
        if (sum.adaptive && !strcmp(f.model, sum.policy.model)) { /* its own prediction */
            char note[sizeof f.note];
            snprintf(note, sizeof note, "adaptive: predicted full log error %.4g; %.520s",
                     sum.policy.predicted_error, f.note);
            memcpy(f.note, note, sizeof note);
        }
        if (saturated) { /* say how the fit took the clipped values */
            char note[sizeof f.note];
            snprintf(note, sizeof note, "%zu saturated samples (%s); %.520s", saturated,
                     fit_model_censors(fit_model_find(f.model), s->saturated)
                         ? "lower bounds"
                         : "at their clipped values",
                     f.note);
            memcpy(f.note, note, sizeof note);
        }
        json_t *row = row_json(&rc_info, &f);
        rc = row ? write_json_atomic(path, row, err) : gonio_err_set(err, ENOMEM, "out of memory");
        json_decref(row);
        if (rc == 0)
            written++;
    }
    if (rc < 0 && err) { /* name the job the message is about */
        char msg[GONIO_ERR_MSG_MAX];
        snprintf(msg, sizeof msg, "%s", err->msg);
        gonio_err_set(err, err->code, "job %s: %s", job->id, msg);
    }
    truth_free(&t);
    brdf_material_free(truth);
    fit_journal_data_free(&jd);
    free(js);
    close(lock_fd);
    return rc < 0 ? rc : written;
}
