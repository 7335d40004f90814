/* --model auto: the candidate with the lowest K-fold cross-validated log
 * error, fitted to all samples (fit/auto_model.h). */
#include "fit/auto_model.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/domain.h"
#include "fit/domain_weights.h"
#include "fit/model_file.h"
#include "fit/sample_order.h"

#define AUTO_PI 3.14159265358979323846
/* The folds' draw is kept apart from the draws of the fits (same seed). */
#define AUTO_SEED_SALT UINT64_C(0x6175746f2d637631)

/* 1 when a sample's incidence lies off the sample's x-z plane: the sample
 * was turned (a plan's sample_azimuths), and the samples see the lobe along
 * more than one of its directions, which the anisotropic model needs. */
static int turned_samples(const struct fit_sample *s, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (fabs(s[i].g.wi[1]) > 1e-9)
            return 1;
    return 0;
}

struct geo_key {
    double k[3];
    size_t i;
};

static int same_geometry(const struct geo_key *x, const struct geo_key *y)
{
    return x->k[0] == y->k[0] && x->k[1] == y->k[1] && x->k[2] == y->k[2];
}

/* By geometry, then by sample index: the same order on every machine. */
static int key_cmp(const void *a, const void *b)
{
    const struct geo_key *x = a, *y = b;
    for (int c = 0; c < 3; c++)
        if (x->k[c] != y->k[c])
            return x->k[c] < y->k[c] ? -1 : 1;
    return x->i < y->i ? -1 : x->i > y->i;
}

/* fold[i] for every sample: its geometry group's fold, or -1 for a sample
 * with a non-finite geometry (left in every training set, where the fits
 * drop it, and never scored). Returns the number of groups, or (size_t)-1
 * when out of memory. */
static size_t assign_folds(const struct fit_sample *s, size_t n, uint64_t seed, int *fold)
{
    struct geo_key *keys = malloc((n ? n : 1) * sizeof *keys);
    size_t *gfold = malloc((n ? n : 1) * sizeof *gfold);
    size_t *order = malloc((n ? n : 1) * sizeof *order);
    if (!keys || !gfold || !order) {
        free(keys);
        free(gfold);
        free(order);
        return (size_t)-1;
    }
    size_t m = 0;
    for (size_t i = 0; i < n; i++) {
        const struct brdf_pair *g = &s[i].g;
        fold[i] = -1;
        if (!isfinite(g->theta_h) || !isfinite(g->theta_d) || !isfinite(g->phi_d))
            continue;
        /* phi_d and phi_d + pi are one geometry for a reciprocal model */
        double pd = nearbyint(fmod(g->phi_d + 2 * AUTO_PI, AUTO_PI) * 1e9);
        if (pd >= nearbyint(AUTO_PI * 1e9))
            pd = 0;
        keys[m++] = (struct geo_key){{nearbyint(g->theta_h * 1e9), nearbyint(g->theta_d * 1e9),
                                      pd},
                                     i};
    }
    qsort(keys, m, sizeof *keys, key_cmp);
    size_t groups = 0;
    for (size_t t = 0; t < m; t++)
        groups += t == 0 || !same_geometry(&keys[t], &keys[t - 1]);
    /* a seeded Fisher-Yates shuffle of the groups, dealt round-robin */
    uint64_t st = seed ^ AUTO_SEED_SALT;
    for (size_t g = 0; g < groups; g++)
        order[g] = g;
    for (size_t g = groups; g > 1; g--) {
        size_t j = (size_t)(brdf_splitmix64(&st) % g), tmp = order[g - 1];
        order[g - 1] = order[j];
        order[j] = tmp;
    }
    for (size_t p = 0; p < groups; p++)
        gfold[order[p]] = p % FIT_AUTO_FOLDS;
    for (size_t t = 0, g = 0; t < m; t++) {
        g += t > 0 && !same_geometry(&keys[t], &keys[t - 1]);
        fold[keys[t].i] = (int)gfold[g];
    }
    free(keys);
    free(gfold);
    free(order);
    return groups;
}

/* Add the held-out log errors of m at the samples of fold k, each counted
 * by its sample's weight w[i] (NULL: 1) in *sum, *sum2 and *count. */
static int score(const brdf_material *m, const struct fit_sample *s,
                 const unsigned char *lower, const double *w, const int *fold, int k, size_t n,
                 double *sum, double *sum2, double *count)
{
    size_t nk = 0;
    for (size_t i = 0; i < n; i++)
        nk += fold[i] == k;
    struct brdf_pair *pairs = malloc((nk ? nk : 1) * sizeof *pairs);
    double *pred = malloc(3 * (nk ? nk : 1) * sizeof *pred);
    if (!pairs || !pred) {
        free(pairs);
        free(pred);
        return -ENOMEM;
    }
    for (size_t i = 0, j = 0; i < n; i++)
        if (fold[i] == k)
            pairs[j++] = s[i].g;
    brdf_material_eval(m, pairs, nk, pred);
    for (size_t i = 0, j = 0; i < n; i++) {
        if (fold[i] != k)
            continue;
        double c = s[i].g.wi[2];
        for (int ch = 0; ch < 3; ch++) {
            double y = s[i].rgb[ch], p = pred[3 * j + ch];
            /* what the metrics skip: below the horizon, no value, 1 + f c <= 0 */
            if (!(c > 0) || !isfinite(y) || !(1 + y * c > 0))
                continue;
            /* a model with no prediction, or an impossible one, is wrong */
            double d = isfinite(p) && 1 + p * c > 0 ? fabs(log1p(p * c) - log1p(y * c)) : 1e3;
            if (lower && lower[i] && isfinite(p) && p >= y)
                d = 0; /* above a lower bound: consistent with it */
            double wi = w ? w[i] : 1;
            *sum += wi * d;
            *sum2 += wi * d * d;
            *count += wi;
        }
        j++;
    }
    free(pairs);
    free(pred);
    return 0;
}

/* Fit one candidate to the training samples and open what it wrote. */
static brdf_material *fit_open(const struct fit_model_kind *kind, const struct fit_data *d,
                               const struct fit_model_options *o, struct gonio_err *err)
{
    struct fit_model_file *mf = NULL;
    struct fit_model_report rep = {0};
    if (kind->fit(d, o, &mf, &rep, err) < 0)
        return NULL;
    const struct fit_model_kind *reader = kind->open ? kind : fit_model_for_kind(mf->kind);
    brdf_material *m = reader ? reader->open(mf, kind->name, err) : NULL;
    if (!reader)
        gonio_err_set(err, GONIO_EBADDATA, "%s wrote a model of kind %s, which nothing opens",
                      kind->name, mf->kind);
    fit_model_file_free(mf);
    return m;
}

/* The domain share of every sample a fit can use (a geometry above the
 * horizon, finite values; 0 for the others) into w. Returns 0, -1 when out
 * of memory. */
static int held_out_weights(const struct fit_sample *s, const int *fold, size_t n, double *w)
{
    size_t *idx = malloc(n * sizeof *idx), nv = 0;
    double *wv = malloc(n * sizeof *wv);
    int rc = idx && wv ? 0 : -1;
    for (size_t i = 0; i < n && rc == 0; i++) {
        w[i] = 0;
        int ok = fold[i] >= 0 && s[i].g.wi[2] > 0 && s[i].g.wo[2] > 0;
        for (int ch = 0; ch < 3 && ok; ch++)
            ok = isfinite(s[i].rgb[ch]);
        if (ok)
            idx[nv++] = i;
    }
    if (rc == 0 && (rc = fit_domain_weights(s, idx, nv, wv)) == 0)
        for (size_t k = 0; k < nv; k++)
            w[idx[k]] = wv[k];
    free(idx);
    free(wv);
    return rc;
}

/* fit_auto_cross_validate on samples in canonical order (fit/sample_order.h):
 * the folds' scores are sums over the samples. */
static int cross_validate(const struct fit_data *data, struct fit_model_options o,
                          struct fit_auto_cv *out, struct gonio_err *err)
{
    size_t n = data->n_rgb;
    if (!n)
        return gonio_err_set(err, GONIO_EUSAGE, "auto: needs RGB samples");
    memset(out, 0, sizeof *out);
    int *fold = malloc(n * sizeof *fold);
    struct fit_sample *train = malloc(n * sizeof *train);
    unsigned char *tlower = malloc(n);
    double *w = NULL; /* the held-out samples' shares, when the scores weigh them */
    double sum[FIT_AUTO_MAX_CANDIDATES] = {0}, sum2[FIT_AUTO_MAX_CANDIDATES] = {0},
           count[FIT_AUTO_MAX_CANDIDATES] = {0};
    int rc = 0;
    if (!fold || !train || !tlower) {
        rc = gonio_err_set(err, ENOMEM, "auto: out of memory");
        goto done;
    }
    out->geometries = assign_folds(data->rgb, n, o.seed, fold);
    if (out->geometries == (size_t)-1) {
        rc = gonio_err_set(err, ENOMEM, "auto: out of memory");
        goto done;
    }
    /* Weighted data: each held-out error counts by its sample's share of
     * the domain, as in the weighted candidates' own losses, so that the
     * choice estimates the full-domain error, not the error where an
     * adaptive capture's samples crowd. Only when every training set is
     * large enough to be fitted weighted (fit/domain_weights.h): the
     * candidates and their scores weigh alike. */
    size_t in_fold[FIT_AUTO_FOLDS] = {0}, largest = 0;
    for (size_t i = 0; i < n; i++)
        if (fold[i] >= 0 && ++in_fold[fold[i]] > largest)
            largest = in_fold[fold[i]];
    int weigh = data->domain_weights && n - largest >= FIT_DOMAIN_WEIGHTS_MIN_SAMPLES;
    if (weigh && (!(w = malloc(n * sizeof *w)) || held_out_weights(data->rgb, fold, n, w) < 0)) {
        rc = gonio_err_set(err, ENOMEM, "auto: out of memory");
        goto done;
    }
    if (out->geometries < FIT_AUTO_MIN_GEOMETRIES) {
        rc = gonio_err_set(err, GONIO_EFIT,
                           "auto: %zu distinct geometries among %zu samples; choosing a model "
                           "by %d-fold cross-validation needs at least %d (fit abc-prior or "
                           "latent instead)",
                           out->geometries, n, FIT_AUTO_FOLDS, FIT_AUTO_MIN_GEOMETRIES);
        goto done;
    }
    const size_t nc = fit_auto_candidates(turned_samples(data->rgb, n), data->auto_evidence,
                                          out->model, out->why, sizeof out->why);
    out->n = nc;
    for (int k = 0; k < FIT_AUTO_FOLDS; k++) {
        size_t nt = 0;
        for (size_t i = 0; i < n; i++)
            if (fold[i] != k) {
                train[nt] = data->rgb[i];
                tlower[nt++] = data->rgb_lower ? data->rgb_lower[i] : 0;
            }
        for (size_t c = 0; c < nc; c++) {
            if (out->failed[c][0])
                continue;
            const struct fit_model_kind *kind = fit_model_find(out->model[c]);
            struct fit_data d = {
                .rgb = train,
                .n_rgb = nt,
                .rgb_lower = data->rgb_lower && fit_model_censors(kind, FIT_SATURATED_DEFAULT)
                                 ? tlower
                                 : NULL,
                .material = data->material,
                .domain_weights = weigh};
            struct gonio_err e = {0};
            brdf_material *m = fit_open(kind, &d, &o, &e);
            if (!m) {
                snprintf(out->failed[c], sizeof out->failed[c], "%.150s",
                         e.msg[0] ? e.msg : "failed");
                continue;
            }
            rc = score(m, data->rgb, data->rgb_lower, w, fold, k, n, &sum[c], &sum2[c],
                       &count[c]);
            brdf_material_free(m);
            if (rc < 0) {
                rc = gonio_err_set(err, ENOMEM, "auto: out of memory");
                goto done;
            }
        }
    }
    int failed[FIT_AUTO_MAX_CANDIDATES];
    for (size_t c = 0; c < nc; c++) {
        int none = !(count[c] > 0);
        out->cv[c] = out->failed[c][0] || none ? INFINITY : sum[c] / count[c];
        out->cv_rms[c] = out->failed[c][0] || none ? INFINITY : sqrt(sum2[c] / count[c]);
        if (!out->failed[c][0] && none)
            snprintf(out->failed[c], sizeof out->failed[c], "no held-out value to score");
        failed[c] = out->failed[c][0] != '\0';
    }
    char oop_why[FIT_AUTO_WHY_MAX];
    size_t best = fit_auto_rank(out->model, out->cv, failed, nc, data->auto_evidence, oop_why,
                                sizeof oop_why);
    out->chosen = best < nc ? best : 0;
    if (oop_why[0]) {
        size_t at = strlen(out->why);
        snprintf(out->why + at, sizeof out->why - at, "%s%s", at ? "; " : "", oop_why);
    }
    if (best == nc) {
        char line[512];
        fit_auto_line(out, o.seed, line, sizeof line);
        rc = gonio_err_set(err, GONIO_EFIT, "%s", line);
    }
done:
    free(fold);
    free(train);
    free(tlower);
    free(w);
    return rc;
}

int fit_auto_cross_validate(const struct fit_data *data, const struct fit_model_options *opt,
                            struct fit_auto_cv *out, struct gonio_err *err)
{
    struct fit_model_options o = opt ? *opt : fit_model_default_options();
    o.quiet = 1;
    /* Every fold starts cold: a start fitted to all the samples would
     * carry the held-out ones into the score. */
    o.warm_start = NULL;
    struct fit_data sd = *data;
    struct fit_sample *sorted;
    unsigned char *lower;
    if (fit_samples_canonical(data->rgb, data->rgb_lower, data->n_rgb, &sorted, &lower) < 0)
        return gonio_err_set(err, ENOMEM, "auto: out of memory");
    sd.rgb = sorted;
    sd.rgb_lower = lower;
    int rc = cross_validate(&sd, o, out, err);
    free(sorted);
    free(lower);
    return rc;
}

void fit_auto_line(const struct fit_auto_cv *cv, unsigned long long seed, char *buf, size_t len)
{
    size_t at = (size_t)snprintf(buf, len, "auto:");
    int any = 0;
    for (size_t c = 0; c < cv->n && at < len; c++) {
        if (cv->failed[c][0])
            at += (size_t)snprintf(buf + at, len - at, "%s %s failed (%.120s)", c ? "," : "",
                                   cv->model[c], cv->failed[c]);
        else
            at += (size_t)snprintf(buf + at, len - at, "%s %s cv %.4f", c ? "," : "",
                                   cv->model[c], cv->cv[c]);
        any |= !cv->failed[c][0];
    }
    if (at < len)
        snprintf(buf + at, len - at, " -> %s (%d folds over %zu geometries, seed %llu)",
                 any ? cv->model[cv->chosen] : "none", FIT_AUTO_FOLDS, cv->geometries, seed);
}

int fit_auto_model_fit(const struct fit_data *data, const struct fit_model_options *opt,
                       struct fit_model_file **out, struct fit_model_report *rep,
                       struct gonio_err *err)
{
    struct fit_model_options o = opt ? *opt : fit_model_default_options();
    o.warm_start = NULL; /* the chosen model is fitted as cross-validation scored it */
    struct fit_auto_cv cv;
    int rc = fit_auto_cross_validate(data, &o, &cv, err);
    if (rc < 0)
        return rc;
    const struct fit_model_kind *kind = fit_model_find(cv.model[cv.chosen]);
    struct fit_data d = *data;
    if (!fit_model_censors(kind, FIT_SATURATED_DEFAULT))
        d.rgb_lower = NULL;
    struct fit_model_report r = {0};
    if ((rc = kind->fit(&d, &o, out, &r, err)) < 0)
        return rc;
    /* The chosen model's held-out figure is its cross-validation: K folds
     * of every sample, a better estimate than the candidate's own refit. */
    r.status.heldout = cv.cv_rms[cv.chosen];
    r.status.findings &= ~(1u << FIT_STATUS_POOR_FIT);
    fit_status_decide(&r.status);
    char line[400];
    fit_auto_line(&cv, o.seed, line, sizeof line);
    rc = fit_status_file_keys(*out, &r.status);
    rc = rc ? rc : fit_model_file_set(*out, "auto", "%s", line);
    for (size_t c = 0; rc == 0 && c < cv.n; c++) {
        char key[FIT_MODEL_KEY_MAX];
        snprintf(key, sizeof key, "auto_cv_%s", cv.model[c]);
        rc = fit_model_file_set(*out, key, "%.6g", cv.cv[c]);
    }
    if (rc == 0 && cv.why[0])
        rc = fit_model_file_set(*out, "auto_why", "%s", cv.why);
    if (rc < 0) {
        fit_model_file_free(*out);
        *out = NULL;
        return gonio_err_set(err, ENOMEM, "auto: out of memory");
    }
    if (rep) {
        *rep = r;
        /* A model of its own: not reported as an ABC fit whatever it chose
         * (the model file says which, docs/formats.md) */
        rep->has_abc = 0;
        rep->warning[0] = '\0';
        snprintf(rep->note, sizeof rep->note, "%.300s; %s: %.180s", line, kind->name, r.note);
        snprintf(rep->auto_chosen, sizeof rep->auto_chosen, "%s", kind->name);
        snprintf(rep->auto_why, sizeof rep->auto_why, "%s", cv.why);
    }
    return 0;
}
