/* Streaming fit with a data-only convergence test (fit/stream.h). */
#include "fit/stream.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/domain.h"
#include "brdf/metrics.h"

struct fit_stream {
    struct fit_stream_options opt;
    struct fit_sample *samples;
    size_t n, cap;
    size_t since;              /* samples added since the latest round */
    struct brdf_domain dom;    /* in-plane reference domain: where models are compared */
    double *pred, *prev_pred;  /* 3 x dom.n predictions of the latest and previous models */
    struct brdf_abc params;
    int have_params;
    size_t cold_n; /* samples at the latest round with the full robust start */
    struct fit_stream_status st;
};

struct fit_stream_options fit_stream_default_options(void)
{
    return (struct fit_stream_options){
        .converge = 1,
        .tol = 0.008,
        .holdout_tol = 1.0,
        .rounds = 2,
        .every = 24,
        .min_points = 60,
        .fit = fit_default_options(),
    };
}

int fit_stream_new(const struct fit_stream_options *opt, fit_stream **out,
                   struct gonio_err *err)
{
    *out = NULL;
    if (!(opt->tol > 0) || !(opt->holdout_tol >= 0) || opt->rounds < 1 || opt->every < 0 ||
        opt->min_points < 0)
        return gonio_err_set(err, GONIO_EBADCONFIG,
                             "streaming fit: tol %g, holdout_tol %g, rounds %ld, every %ld, "
                             "min_points %ld: need tol > 0, rounds >= 1, the rest >= 0",
                             opt->tol, opt->holdout_tol, opt->rounds, opt->every,
                             opt->min_points);
    fit_stream *s = calloc(1, sizeof *s);
    if (!s)
        return gonio_err_set(err, ENOMEM, "streaming fit: out of memory");
    s->opt = *opt;
    s->opt.fit.warm_start = NULL;
    int rc = brdf_domain_inplane(&s->dom, err);
    if (rc < 0) {
        free(s);
        return rc;
    }
    s->pred = malloc(3 * s->dom.n * sizeof *s->pred);
    s->prev_pred = malloc(3 * s->dom.n * sizeof *s->prev_pred);
    if (!s->pred || !s->prev_pred) {
        fit_stream_free(s);
        return gonio_err_set(err, ENOMEM, "streaming fit: out of memory");
    }
    s->st.change = s->st.holdout = s->st.fit_error = NAN;
    *out = s;
    return 0;
}

void fit_stream_free(fit_stream *s)
{
    if (!s)
        return;
    brdf_domain_free(&s->dom);
    free(s->pred);
    free(s->prev_pred);
    free(s->samples);
    free(s);
}

/* Log error of the model over samples[a, b): the design's headline metric. */
static double sample_error(const struct brdf_abc *p, const struct fit_sample *samples, size_t a,
                           size_t b)
{
    struct brdf_errors_acc acc;
    brdf_errors_acc_init(&acc);
    for (size_t i = a; i < b; i++) {
        double rgb[3];
        brdf_abc_eval(p, &samples[i].g, rgb);
        brdf_errors_acc_add(&acc, &samples[i].g, samples[i].rgb, rgb, 1);
    }
    struct brdf_errors e;
    brdf_errors_acc_finish(&acc, &e);
    return e.log;
}

static void round_run(fit_stream *s)
{
    struct fit_options fo = s->opt.fit;
    fo.warm_start = s->have_params ? &s->params : NULL;
    fo.heldout = 0; /* a round's status is not read: its hold-out is below */
    struct brdf_abc next, cold;
    struct fit_info info, cold_info;
    size_t fitted_before = s->st.fitted;
    s->st.rounds++;
    s->since = 0;
    int calm = 0, ok = fit_abc(s->samples, s->n, &fo, &next, &info, NULL) == 0;
    /* A warm start only refines: a model fitted to a few dozen coarse
     * samples can hold every later round in its basin. Each time the data
     * has doubled, the full robust start runs too and the lower cost wins. */
    if (s->have_params && s->n >= 2 * s->cold_n) {
        fo.warm_start = NULL;
        if (fit_abc(s->samples, s->n, &fo, &cold, &cold_info, NULL) == 0 &&
            (!ok || cold_info.cost < info.cost)) {
            next = cold;
            ok = 1;
        }
        s->cold_n = s->n;
    } else if (!s->have_params) {
        s->cold_n = s->n;
    }
    if (!ok) {
        s->st.change = s->st.holdout = NAN;
        s->st.calm = 0;
        return;
    }
    for (size_t i = 0; i < s->dom.n; i++)
        brdf_abc_eval(&next, &s->dom.pairs[i], s->pred + 3 * i);
    if (s->have_params) {
        /* Held out: the samples the previous model was not fitted on. */
        s->st.holdout = sample_error(&s->params, s->samples, fitted_before, s->n);
        struct brdf_errors e;
        brdf_errors_compute(s->dom.pairs, s->prev_pred, s->pred, s->dom.n, &e);
        s->st.change = e.log;
        calm = s->st.change < s->opt.tol &&
               /* + tol: exact data fits to ~0 both ways */
               s->st.holdout <= (1 + s->opt.holdout_tol) * s->st.fit_error + s->opt.tol;
    }
    s->st.fit_error = sample_error(&next, s->samples, 0, s->n);
    s->st.fitted = s->n;
    s->params = next;
    s->have_params = 1;
    double *t = s->prev_pred;
    s->prev_pred = s->pred;
    s->pred = t;
    /* A round forced by a level end just after a periodic one sees a
     * handful of new samples and so a tiny change: it may reset the count
     * but not add to it. */
    size_t fresh = s->n - fitted_before;
    if (!calm)
        s->st.calm = 0;
    else if (s->opt.every <= 0 || 2 * fresh >= (size_t)s->opt.every)
        s->st.calm++;
    if (s->opt.converge && s->st.calm >= s->opt.rounds && (long)s->n >= s->opt.min_points) {
        s->st.converged = 1;
        s->st.converged_at = s->n;
    }
}

int fit_stream_add(fit_stream *s, const struct fit_sample *sample, int level_end,
                   struct gonio_err *err)
{
    if (s->n == s->cap) {
        size_t cap = s->cap ? 2 * s->cap : 256;
        struct fit_sample *m = realloc(s->samples, cap * sizeof *m);
        if (!m)
            return gonio_err_set(err, ENOMEM, "streaming fit: out of memory");
        s->samples = m;
        s->cap = cap;
    }
    s->samples[s->n++] = *sample;
    s->st.samples = s->n;
    s->since++;
    if (s->st.converged)
        return 1;
    /* Rounds before a fit is possible (9 residuals at least) would only fail. */
    int due = (s->opt.every > 0 && (long)s->since >= s->opt.every) || (level_end && s->since);
    if (due && s->n >= 3)
        round_run(s);
    return s->st.converged;
}

const struct brdf_abc *fit_stream_params(const fit_stream *s)
{
    return s->have_params ? &s->params : NULL;
}

void fit_stream_status(const fit_stream *s, struct fit_stream_status *st)
{
    *st = s->st;
}
