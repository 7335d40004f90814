#include "capture/capture_files.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <jansson.h>

#include "capture/verdicts.h"
#include "common/paths.h"

static int write_json(const char *dir, const char *name, json_t *root, struct gonio_err *err)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    char *text = root ? json_dumps(root, JSON_INDENT(2) | JSON_REAL_PRECISION(12)) : NULL;
    json_decref(root);
    if (!text)
        return gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    size_t len = strlen(text);
    text[len] = '\n'; /* json_dumps leaves room for the NUL we replace */
    int rc = gonio_write_file_atomic(path, text, len + 1, err);
    free(text);
    return rc;
}

/* Read a whole small file; NULL (errno set) when it is not there. */
static char *slurp(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    char *buf = NULL;
    size_t len = 0, cap = 0;
    for (;;) {
        if (len + 4096 + 1 > cap) {
            cap = cap ? 2 * cap : 65536;
            char *grown = realloc(buf, cap);
            if (!grown) {
                free(buf);
                fclose(f);
                return NULL;
            }
            buf = grown;
        }
        size_t r = fread(buf + len, 1, cap - len - 1, f);
        len += r;
        if (r == 0)
            break;
    }
    fclose(f);
    buf[len] = '\0';
    return buf;
}

static json_t *axis_json(const struct rig_axis *ax)
{
    return json_pack("{s:f,s:f,s:f,s:f}", "speed", ax->speed, "accel", ax->accel, "min",
                     ax->min, "max", ax->max);
}

/* The operator's metadata, in setup.json and results.json alike. */
static const char *const meta_keys[] = {"sample", "operator", "note"};

static json_t *setup_json(const struct capture_setup *su)
{
    const struct rig_profile *rig = su->rig;
    json_t *root = json_pack("{s:s,s:s,s:{s:s,s:{s:o,s:o,s:o},s:b,s:f,s:f,s:f,s:f,s:f}}",
                             "driver", su->driver, "detector", su->detector, "rig", "name",
                             rig->name, "axes", "sample", axis_json(&rig->sample), "arm",
                             axis_json(&rig->arm), "azimuth", axis_json(&rig->azimuth),
                             "out_of_plane", rig->out_of_plane, "blind_deg", rig->blind_deg,
                             "settle_s", rig->settle_s, "integration_s", rig->integration_s,
                             "auto_min_s", rig->auto_min_s, "auto_max_s", rig->auto_max_s);
    /* The band the journal's records were checked in: a resume and `gonio
     * journal check` hold them to it (capture/journal_plan.h). */
    if (root)
        json_object_set_new(json_object_get(root, "rig"), "in_position_deg",
                            json_real(rig->mech.in_position_deg));
    if (root && su->source) {
        json_error_t jerr;
        json_t *more = json_loads(su->source, 0, &jerr);
        if (!json_is_object(more) || json_object_update(root, more) < 0) {
            json_decref(root);
            root = NULL;
        }
        json_decref(more);
    }
    if (root && su->material)
        json_object_set_new(root, "material", json_string(su->material));
    if (root && su->ladder) { /* a detector of counts, auto-ranged */
        json_t *ladder = json_array();
        for (size_t i = 0; i < su->n_ladder; i++)
            json_array_append_new(ladder, json_real(su->ladder[i]));
        json_object_set_new(root, "counts",
                            json_pack("{s:f,s:f,s:o}", "full_scale", su->full_scale,
                                      "nonlinearity", su->nonlinearity, "integration_ladder",
                                      ladder));
    }
    /* The operator's metadata, null when not given; not compared on a
     * resume, which keeps the file as the capture began. */
    const char *meta_value[] = {su->sample, su->operator_name, su->note};
    for (size_t i = 0; root && i < sizeof meta_keys / sizeof *meta_keys; i++)
        json_object_set_new(root, meta_keys[i], meta_value[i] && meta_value[i][0]
                                                    ? json_string(meta_value[i])
                                                    : json_null());
    /* A resume reduces with the calibration the capture began with. */
    if (root && su->calibration)
        json_object_set_new(root, "calibration", json_string(su->calibration));
    /* A resumed adaptive capture must decide as it began (docs/formats.md). */
    const struct adaptive_options *po = su->policy;
    if (root && po)
        json_object_set_new(root, "adaptive",
                            json_pack("{s:s,s:f,s:f,s:b,s:f,s:I}", "model", po->model,
                                      "budget_s", po->budget_s, "target", po->target,
                                      "converge", po->converge, "gain_tol", po->gain_tol, "seed",
                                      (json_int_t)po->seed));
    return root;
}

/* How setup.json names a value: a string, or an object's name. */
static const char *setup_label(json_t *v)
{
    return json_is_string(v) ? json_string_value(v)
                             : json_string_value(json_object_get(v, "name"));
}

/* A scene is the same wherever its file was named from. */
static int same_value(json_t *a, json_t *b)
{
    if (!json_is_object(a) || !json_is_object(b))
        return json_equal(a, b);
    json_t *ca = json_deep_copy(a), *cb = json_deep_copy(b);
    json_object_del(ca, "path");
    json_object_del(cb, "path");
    if (!json_object_get(ca, "in_position_deg")) /* a setup.json from before the band */
        json_object_del(cb, "in_position_deg");
    int same = json_equal(ca, cb);
    json_decref(ca);
    json_decref(cb);
    return same;
}

/* What a resume compares, in the order a difference is named: the rig
 * source's own members (the simulator's scene), then these. */
static const char *const setup_keys[] = {"material", "rig", "detector", "calibration"};

static int setup_key_known(const char *key)
{
    if (!strcmp(key, "driver") || !strcmp(key, "adaptive"))
        return 1;
    for (size_t i = 0; i < sizeof meta_keys / sizeof *meta_keys; i++)
        if (!strcmp(key, meta_keys[i]))
            return 1;
    for (size_t i = 0; i < sizeof setup_keys / sizeof *setup_keys; i++)
        if (!strcmp(key, setup_keys[i]))
            return 1;
    return 0;
}

/* The keys a resume compares: the source's members of either file, then
 * setup_keys. At most max; returns the count. */
static size_t compared_keys(json_t *was, json_t *now, const char **keys, size_t max)
{
    size_t n = 0;
    const char *key;
    json_t *v;
    json_object_foreach(now, key, v)
        if (!setup_key_known(key) && n < max)
            keys[n++] = key;
    json_object_foreach(was, key, v)
        if (!setup_key_known(key) && !json_object_get(now, key) && n < max)
            keys[n++] = key;
    for (size_t i = 0; i < sizeof setup_keys / sizeof *setup_keys && n < max; i++)
        keys[n++] = setup_keys[i];
    return n;
}

/* A resume continues the capture setup.json describes: the same source
 * members, material, rig and detector (older setup.json files keep the
 * detector in the scene), else one line naming the first difference. */
static int check_same_setup(const char *dir, json_t *was, json_t *now, struct gonio_err *err)
{
    json_t *pa = json_object_get(was, "adaptive"), *pb = json_object_get(now, "adaptive");
    if (pa && pb && !json_equal(pa, pb)) {
        char *ta = json_dumps(pa, JSON_COMPACT | JSON_SORT_KEYS),
             *tb = json_dumps(pb, JSON_COMPACT | JSON_SORT_KEYS);
        gonio_err_set(err, GONIO_EUSAGE,
                      "%s: setup.json has adaptive %s, this capture asks for %s; a resumed "
                      "adaptive capture keeps its model, budget, target and stop rule (or use "
                      "a new directory)",
                      dir, ta ? ta : "?", tb ? tb : "?");
        free(ta);
        free(tb);
        return -GONIO_EUSAGE;
    }
    const char *keys[32];
    size_t nkeys = compared_keys(was, now, keys, sizeof keys / sizeof *keys);
    for (size_t i = 0; i < nkeys; i++) {
        json_t *a = json_object_get(was, keys[i]), *b = json_object_get(now, keys[i]);
        if (!a && !strcmp(keys[i], "detector"))
            a = json_object_get(json_object_get(was, "scene"), "detector");
        if ((!a && !b) || (a && b && same_value(a, b)))
            continue;
        const char *la = setup_label(a), *lb = setup_label(b);
        if (la && lb && !strcmp(la, lb))
            return gonio_err_set(err, GONIO_EUSAGE,
                                 "%s: setup.json has %s '%s' with other settings than this "
                                 "capture's; use a new directory",
                                 dir, keys[i], la);
        char has[600], asks[600];
        snprintf(has, sizeof has, a ? "%s '%s'" : "no %s", keys[i], la ? la : "?");
        snprintf(asks, sizeof asks, b ? "asks for '%s'" : "names none", lb ? lb : "?");
        return gonio_err_set(err, GONIO_EUSAGE,
                             "%s: setup.json has %s, this capture %s; use a new directory", dir,
                             has, asks);
    }
    return 0;
}

/* One writer per capture directory: a POSIX lock on DIR/lock, which the
 * kernel drops with its holder (a killed goniod frees the directory). */
static int lock_dir(const char *dir, int *lock_fd, struct gonio_err *err)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/lock", dir);
    int fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0)
        return gonio_err_set(err, errno, "%s: cannot open: %s", path, strerror(errno));
    struct flock fl = {.l_type = F_WRLCK, .l_whence = SEEK_SET};
    if (fcntl(fd, F_SETLK, &fl) == 0) {
        *lock_fd = fd;
        return 0;
    }
    int e = errno;
    struct flock who = {.l_type = F_WRLCK, .l_whence = SEEK_SET};
    long pid = fcntl(fd, F_GETLK, &who) == 0 && who.l_type != F_UNLCK ? (long)who.l_pid : 0;
    close(fd);
    if (e == EACCES || e == EAGAIN)
        return gonio_err_set(err, EBUSY, "%s: capture directory is in use by pid %ld", dir, pid);
    return gonio_err_set(err, e, "%s: cannot lock: %s", path, strerror(e));
}

void capture_files_unlock(int lock_fd)
{
    if (lock_fd >= 0)
        close(lock_fd); /* closing drops the lock */
}

/* The checks and writes of capture_files_prepare, under the lock. */
static int prepare_locked(const char *dir, const char *text, json_t *setup,
                          struct gonio_err *err)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/plan.json", dir);
    char *existing = slurp(path);
    if (existing) {
        int differs = strcmp(existing, text) != 0;
        free(existing);
        if (differs)
            return gonio_err_set(err, GONIO_EUSAGE,
                                 "%s: holds a capture of another plan or order (plan.json "
                                 "differs); choose a new --out directory",
                                 dir);
        snprintf(path, sizeof path, "%s/setup.json", dir);
        json_t *was = json_load_file(path, 0, NULL);
        if (!was) /* cut off between plan.json and setup.json: write it now */
            return write_json(dir, "setup.json", json_incref(setup), err);
        int rc = check_same_setup(dir, was, setup, err);
        json_decref(was);
        return rc; /* resuming: the directory is already set up */
    }
    snprintf(path, sizeof path, "%s/samples.csv", dir);
    struct stat st;
    if (stat(path, &st) == 0)
        return gonio_err_set(err, GONIO_EUSAGE,
                             "%s: has samples.csv but no plan.json; not a gonio capture to "
                             "resume, choose a new --out directory",
                             dir);
    snprintf(path, sizeof path, "%s/plan.json", dir);
    int rc = gonio_write_file_atomic(path, text, strlen(text), err);
    if (rc == 0)
        rc = write_json(dir, "setup.json", json_incref(setup), err);
    return rc;
}

int capture_files_plan_start(const char *dir, struct rig_axes *start)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/plan.json", dir);
    json_t *doc = json_load_file(path, 0, NULL);
    json_t *at = json_object_get(doc, "start");
    int found = json_is_object(at);
    if (found)
        *start = (struct rig_axes){json_number_value(json_object_get(at, "s")),
                                   json_number_value(json_object_get(at, "a")),
                                   json_number_value(json_object_get(at, "az"))};
    json_decref(doc);
    return found;
}

int capture_files_plan_rewrite(const char *dir, const struct plan *plan,
                               const struct rig_profile *rig, struct gonio_err *err)
{
    struct plan_estimate est;
    plan_estimate(plan, rig, &est);
    char *text = plan_json_text(plan, &est);
    if (!text)
        return gonio_err_set(err, ENOMEM, "out of memory");
    char path[4096];
    snprintf(path, sizeof path, "%s/plan.json", dir);
    int rc = gonio_write_file_atomic(path, text, strlen(text), err);
    free(text);
    return rc;
}

int capture_files_prepare(const char *dir, const struct capture_setup *su, int *lock_fd,
                          struct gonio_err *err)
{
    *lock_fd = -1;
    struct plan_estimate est;
    plan_estimate(su->plan, su->rig, &est);
    char *text = plan_json_text(su->plan, &est);
    json_t *setup = setup_json(su);
    int rc = text && setup ? gonio_mkdir_p(dir, err) : gonio_err_set(err, ENOMEM, "out of memory");
    if (rc == 0)
        rc = lock_dir(dir, lock_fd, err);
    if (rc == 0)
        rc = prepare_locked(dir, text, setup, err);
    if (rc < 0) {
        capture_files_unlock(*lock_fd);
        *lock_fd = -1;
    }
    free(text);
    json_decref(setup);
    return rc;
}

static json_t *errors_json(const struct brdf_errors *e)
{
    /* NaN is not JSON: a domain with no usable pair reports null. */
    json_t *log = isfinite(e->log) ? json_real(e->log) : json_null();
    json_t *rel = isfinite(e->rel_rmse) ? json_real(e->rel_rmse) : json_null();
    return json_pack("{s:o,s:o,s:I}", "log", log, "rel_rmse", rel, "n",
                     (json_int_t)e->n_used);
}

static json_t *rgb_json(const double v[3])
{
    return json_pack("[f,f,f]", v[0], v[1], v[2]);
}

static json_t *num_or_null(double v)
{
    return isfinite(v) ? json_real(v) : json_null();
}

static json_t *str_or_null(const char *v)
{
    return v[0] ? json_string(v) : json_null();
}

static json_t *uncertainty_json(const struct fit_uncertainty *u, const char *warning,
                                int measured)
{
    json_t *o = json_object();
    /* what the sds rest on (docs/fitting.md "Measurement weights") */
    json_object_set_new(o, "from", json_string(measured ? "uncertainties" : "residuals"));
    json_t *kd = json_array(), *a = json_array();
    for (int c = 0; c < 3; c++) {
        json_array_append_new(kd, num_or_null(u->log_kd[c]));
        json_array_append_new(a, num_or_null(u->log_A[c]));
    }
    json_object_set_new(o, "sd_log_kd", kd);
    json_object_set_new(o, "sd_log_A", a);
    json_object_set_new(o, "sd_log_B", num_or_null(u->log_B));
    json_object_set_new(o, "sd_log_C", num_or_null(u->log_C));
    json_object_set_new(o, "sd_eta", num_or_null(u->eta));
    json_object_set_new(o, "sd_pred_log", num_or_null(u->pred_log));
    if (warning && warning[0])
        json_object_set_new(o, "warning", json_string(warning));
    return o;
}

/* The final fit's status and the figures behind it (fit/fit_status.h,
 * docs/fitting.md "Fit status"); null for a figure not computed. */
static json_t *status_json(const struct fit_status *st)
{
    char findings[96];
    fit_status_findings(st, findings, sizeof findings);
    json_t *o = json_object();
    json_object_set_new(o, "status", json_string(fit_status_name(fit_status_code(st))));
    json_object_set_new(o, "findings", json_string(findings));
    json_object_set_new(o, "geometries", json_integer((json_int_t)st->geometries));
    json_object_set_new(o, "params", st->params >= 0 ? json_integer(st->params) : json_null());
    json_object_set_new(o, "rank", st->rank >= 0 ? json_integer(st->rank) : json_null());
    json_object_set_new(o, "condition", num_or_null(st->cond));
    json_object_set_new(o, "at_bound", json_string(st->at_bound));
    json_object_set_new(o, "rms_log_insample", num_or_null(st->insample));
    json_object_set_new(o, "rms_log_heldout", num_or_null(st->heldout));
    return o;
}

/* The adaptive order's policy at the stop: its prediction of the model's
 * full-domain log error (with every sample in), what more rig time would
 * buy, why it stopped, and what its decisions cost (docs/formats.md). */
static json_t *adaptive_json(const struct capture_summary *s)
{
    const struct adaptive_status *st = &s->policy;
    json_t *o = json_object();
    json_object_set_new(o, "model", json_string(st->model));
    json_object_set_new(o, "predicted_error", num_or_null(st->predicted_error));
    json_object_set_new(o, "prediction_rough",
                        json_boolean(adaptive_prediction_rough(st->samples)));
    json_object_set_new(o, "predicted_next", num_or_null(st->predicted_next));
    json_object_set_new(o, "predicted_next_s", num_or_null(st->predicted_next_s));
    json_object_set_new(o, "gain_per_min", num_or_null(st->gain_per_min));
    json_object_set_new(o, "stop", json_string(st->stop));
    json_object_set_new(o, "budget_s", s->budget_s > 0 ? json_real(s->budget_s) : json_null());
    json_object_set_new(o, "target", s->target > 0 ? json_real(s->target) : json_null());
    json_object_set_new(o, "converge", json_boolean(s->converge));
    json_object_set_new(o, "decisions", json_integer((json_int_t)s->decisions));
    json_object_set_new(o, "decision_mean_s", json_real(s->decision_mean_s));
    json_object_set_new(o, "decision_max_s", json_real(s->decision_max_s));
    json_object_set_new(o, "decision_wait_s", json_real(s->decision_wait_s));
    return o;
}

static json_t *share_of(double part, double whole)
{
    return whole > 0 ? json_real(part / whole) : json_null();
}

/* The in-plane sufficiency check's verdict, figures and worst pair. */
static json_t *oop_json(const struct oop_check_result *c, double rig_time_s)
{
    const struct oop_check_pair *w = &c->worst;
    json_t *worst = isnan(c->ratio) ? json_null()
                                    : json_pack("{s:f,s:f,s:f,s:f,s:f}", "theta_i", w->theta_i,
                                                "theta_o", w->theta_o, "phi_o", w->phi_o,
                                                "error", c->worst_error, "predicted",
                                                w->predicted);
    json_t *o = json_pack("{s:s,s:s,s:I,s:I,s:o,s:o,s:o,s:f,s:f,s:o,s:f,s:o,s:o,s:f,s:b}", "verdict",
                     c->verdict, "why", c->why, "pairs", (json_int_t)c->pairs, "measurements",
                     (json_int_t)c->measurements, "error_oop", num_or_null(c->error_oop),
                     "error_inplane", num_or_null(c->error_inplane), "ratio",
                     num_or_null(c->ratio), "threshold", c->threshold, "error_floor",
                     OOP_CHECK_FLOOR, "worst", worst, "rig_time_s", c->rig_time_s,
                     "rig_time_share", share_of(c->rig_time_s, rig_time_s), "lobe_deg",
                     num_or_null(c->lobe_deg), "resolution_deg", c->resolution_deg,
                     "lobe_unresolved", c->unresolved);
    /* the estimate of the fit's full-domain error (capture/oop_estimate.h) */
    const struct oop_estimate *f = &c->full;
    json_t *interval = isnan(f->error) ? json_null()
                                       : json_pack("[f,f]", f->low, f->high);
    json_object_set_new(o, "error_full", num_or_null(f->error));
    json_object_set_new(o, "error_full_interval", interval);
    json_object_set_new(o, "domain_pairs", json_integer((json_int_t)f->pairs));
    json_object_set_new(o, "domain_pairs_used", json_integer((json_int_t)f->used));
    return o;
}

/* The checks' verdicts with their evidence and rig time (docs/checks.md). */
json_t *capture_files_checks(const struct capture_summary *s)
{
    json_t *o = json_object();
    if (s->has_oop)
        json_object_set_new(o, "out_of_plane", oop_json(&s->oop, s->rig_time_s));
    if (!s->has_isotropy)
        return o;
    const struct iso_check_result *c = &s->isotropy;
    json_t *worst = c->max_deviation > 0 || c->pairs
                        ? json_pack("{s:f,s:f,s:f}", "theta_i", c->worst.theta_i, "theta_r",
                                    c->worst.theta_r, "rotation_deg", c->worst_rotation_deg)
                        : json_null();
    json_t *iso = json_pack("{s:s,s:s,s:I,s:I,s:f,s:o,s:o,s:o,s:o,s:f,s:o,s:f,s:o}", "verdict",
                            c->verdict, "why", c->why, "pairs", (json_int_t)c->pairs,
                            "measurements", (json_int_t)c->measurements, "max_deviation",
                            c->max_deviation, "significance", num_or_null(c->significance),
                            "threshold", num_or_null(c->threshold), "noise",
                            num_or_null(c->noise), "detectable", num_or_null(c->detectable),
                            "false_alarm_rate", c->alpha, "worst", worst, "rig_time_s",
                            c->rig_time_s, "rig_time_share",
                            s->rig_time_s > 0 ? json_real(c->rig_time_s / s->rig_time_s)
                                              : json_null());
    json_object_set_new(o, "isotropy", iso);
    return o;
}

/* results.json names the capture as setup.json does: the metadata it began
 * with, whichever run (a resume, a refit, a recalibration) writes it. */
static void copy_metadata(const char *dir, json_t *root)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/setup.json", dir);
    json_t *setup = json_load_file(path, 0, NULL);
    for (size_t i = 0; i < sizeof meta_keys / sizeof *meta_keys; i++) {
        json_t *v = json_object_get(setup, meta_keys[i]);
        json_object_set_new(root, meta_keys[i], json_is_string(v) ? json_incref(v) : json_null());
    }
    json_decref(setup);
}

int capture_files_results(const char *dir, const struct capture_summary *s,
                          struct gonio_err *err)
{
    json_t *errors = json_pack("{s:o}", "plan", errors_json(&s->err_plan));
    if (errors && s->has_truth) {
        json_object_set_new(errors, "inplane", errors_json(&s->err_inplane));
        json_object_set_new(errors, "full", errors_json(&s->err_full));
    }
    /* ABC's parameters and their sds (also in its model file); null for the
     * other models, whose parameters are only in their model file
     * (docs/formats.md). */
    json_t *params = s->has_params
                         ? json_pack("{s:o,s:o,s:f,s:f,s:f,s:s}", "kd", rgb_json(s->params.kd),
                                     "A", rgb_json(s->params.A), "B", s->params.B, "C",
                                     s->params.C, "eta", s->params.eta, "convention",
                                     "A without the 1/pi of the published MERL fits "
                                     "(docs/fitting.md)")
                         : json_null();
    json_t *root = json_pack("{s:s,s:o,s:s,s:I,s:f,s:{s:f,s:f,s:f},s:f,s:b,s:o,s:o}", "plan",
                             s->plan, "material", str_or_null(s->material), "model", s->model,
                             "samples",
                             (json_int_t)s->samples, "rig_time_s", s->rig_time_s, "rig_time",
                             "move_s", s->move_s, "settle_s", s->settle_s, "integration_s",
                             s->integration_s, "fit_time_s", s->fit_time_s, "converged",
                             s->converged, "params", params, "errors", errors);
    if (root) { /* the reference of the inplane and full errors, null without one */
        json_object_set_new(root, "truth", str_or_null(s->truth));
        json_object_set_new(root, "paused_s", json_real(s->paused_s));
    }
    if (root)
        json_object_set_new(root, "model_file", s->model_file[0] ? json_string(s->model_file)
                                                                  : json_null());
    if (root)
        json_object_set_new(root, "saturated", json_integer((json_int_t)s->saturated));
    if (root) /* what the axes' mechanics cost this run (drivers/drivers.h) */
        json_object_set_new(root, "mechanics",
                            json_pack("{s:I,s:I,s:I,s:I}", "moves", (json_int_t)s->mech.moves,
                                      "recommands", (json_int_t)s->mech.recommands,
                                      "alarms_recovered", (json_int_t)s->mech.alarms_recovered,
                                      "rehomes", (json_int_t)s->mech.rehomes));
    if (root) /* parameter sds from the fit's Jacobian, natural units (fit/fit.h) */
        json_object_set_new(root, "uncertainty",
                            s->has_params ? uncertainty_json(&s->sd, s->warning, s->sd_measured)
                                          : json_null());
    if (root)
        json_object_set_new(root, "fit_status", status_json(&s->status));
    if (root) { /* why nothing was fitted (counts, uncalibrated); auto-ranging's cost */
        json_object_set_new(root, "not_fitted",
                            s->not_fitted[0] ? json_string(s->not_fitted) : json_null());
        json_object_set_new(root, "ranging",
                            json_pack("{s:I,s:I}", "darks", (json_int_t)s->darks, "retakes",
                                      (json_int_t)s->retakes));
    }
    if (root)
        copy_metadata(dir, root);
    if (root) {
        json_object_set_new(root, "stop_reason", json_string(s->stop_reason));
        json_object_set_new(root, "adaptive", s->adaptive ? adaptive_json(s) : json_null());
        json_object_set_new(root, "checks", capture_files_checks(s));
        json_object_set_new(root, "auto", capture_verdicts_auto(s));
    }
    return write_json(dir, "results.json", root, err);
}
