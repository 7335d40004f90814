/* The registry of fittable models: one row per model name, saying how to fit
 * it from samples and how to open its model file as a material.
 *
 * `gonio fit --model NAME` looks the name up with fit_model_find; a model
 * file (fit/model_file.h) names its kind in its header, and
 * fit_material_open looks that kind up with fit_model_for_kind. A model
 * whose fit writes another model's file (abc-pseudo writes an abc file)
 * names that kind in file_kind and leaves open NULL.
 *
 * To add a model: write its fit and open functions in its own file, declare
 * them in its own header, and add one row to the table in fit/models.c. */
#ifndef GONIO_FIT_MODELS_H
#define GONIO_FIT_MODELS_H

#include <stddef.h>
#include <stdint.h>

#include "brdf/material.h"
#include "common/err.h"
#include "fit/fit.h"

struct fit_model_file;
struct fit_auto_evidence;

/* One spectral sample: in-plane geometry (degrees, theta_r signed as in
 * brdf/angles.h), wavelength and the BRDF value (1/sr) at that wavelength. */
struct fit_spectral_sample {
    double theta_i, theta_r, wavelength_nm, value;
    int saturated; /* 1: the reading saturated, value is a lower bound (trained
                      one-sided, as fit_data.rgb_lower) */
};

/* What a fit sees. A model uses the part it needs (rgb or spectral) and
 * refuses the call (GONIO_EFIT, or GONIO_EUSAGE for the wrong kind of data)
 * when that part is empty. */
struct fit_data {
    const struct fit_sample *rgb;
    size_t n_rgb;
    const unsigned char *rgb_lower; /* NULL, or n_rgb flags: 1 for a saturated reading, a
                                       lower bound (fit_options.lower_bound): every
                                       fit takes it one-sided (censored). Callers pass
                                       it when fit_model_censors says so. */
    const struct fit_spectral_sample *spectral;
    size_t n_spectral;
    const char *material; /* the captured material (nbrdf:NAME) when known, else NULL */
    /* 1: the samples were chosen by an adaptive policy, so they are not
     * spread like the domain: the ABC and latent fits weight each by its
     * share of the domain (fit_options.domain_weights and
     * latent_fit_options.domain_weights, fit/domain_weights.h) and say so
     * in the model file ("weights"), from seven samples on
     * (fit/domain_weights.h); the in-plane MLPs and abc-pseudo fit them
     * alike. */
    int domain_weights;
    /* Per channel, the relative standard uncertainty that all samples' u
     * share (fit_options.u_systematic); {0}: none. */
    double u_systematic[3];
    /* What the capture's premise checks said, for --model auto (NULL:
     * nothing; fit/auto_evidence.h); the other models ignore it. */
    const struct fit_auto_evidence *auto_evidence;
};

struct fit_model_options {
    uint64_t seed;   /* every randomised step of a fit derives from it */
    int max_epochs;  /* iterative trainers: 0 for the model's default */
    int quiet;       /* no progress lines on stderr */
    /* A start for the fits of ABC parameters (abc, abc-prior), refined
     * from there instead of the global start search (a capture's streaming
     * fit), or NULL; warm_start_from says where it came from, recorded in
     * the model file ("warm_start"). The other models ignore it. */
    const struct brdf_abc *warm_start;
    const char *warm_start_from;
};

struct fit_model_options fit_model_default_options(void);

/* What a fit reports besides its model file. */
struct fit_model_report {
    int converged;    /* 1 when the fit met its stopping rule, not a limit */
    char note[512];   /* one line for people: iterations/epochs, stop reason */
    struct fit_status status; /* what the fit can know (fit/fit_status.h) */
    int weighted;     /* 1: the samples were weighted by their domain share */
    int measured;     /* 1: each value was weighted by its u (fit_info.measurement_weights) */
    /* The ABC fits (abc, abc-prior): their parameters and sds (has_abc 1),
     * and a warning for people (abc-prior's too few samples), else "". */
    int has_abc;
    struct brdf_abc abc;
    struct fit_uncertainty sd;
    char warning[256];
    /* fit_model_run: 1 once the fit itself succeeded (a failure after it
     * is the model file's), and its wall and CPU seconds, the fit alone. */
    int fitted;
    double fit_s, cpu_s;
    /* --model auto: the candidate it chose and what the premise checks'
     * evidence decided (fit/auto_evidence.h, "" when nothing); else "". */
    char auto_chosen[16];
    char auto_why[320];
};

struct fit_model_kind {
    const char *name;      /* `gonio fit --model NAME` */
    const char *file_kind; /* the kind written in the model file header */
    const char *summary;   /* one line for --help */
    int spectral;          /* 1: fits spectral samples, 0: RGB samples */
    /* 1: saturated readings are fitted as lower bounds (censored) unless the
     * caller says otherwise; 0: at their clipped values. The ABC family fits
     * them clipped: a lower bound says nothing of how far above it the peak
     * is, and its lobe, fitted to the shoulders, overshoots (docs/fitting.md
     * "Saturated readings"). Read through fit_model_censors, so captures,
     * the study and gonio fit take the same default. */
    int censors_saturated;
    /* Fit the data; on success *out is a new model file (caller frees with
     * fit_model_file_free). Returns 0 or a negative code with err filled. */
    int (*fit)(const struct fit_data *data, const struct fit_model_options *opt,
               struct fit_model_file **out, struct fit_model_report *rep,
               struct gonio_err *err);
    /* Build a material from a model file of kind file_kind (NULL for rows
     * that write another row's kind). name is the material's name. */
    brdf_material *(*open)(const struct fit_model_file *f, const char *name,
                           struct gonio_err *err);
};

/* How a fit takes saturated readings: the model's own default
 * (censors_saturated) or one forced for every model (`--saturated`). */
enum fit_saturated { FIT_SATURATED_DEFAULT, FIT_SATURATED_CLIPPED, FIT_SATURATED_CENSORED };

/* "default", "clipped" or "censored" into *out; -1 for anything else. */
int fit_saturated_parse(const char *s, enum fit_saturated *out);
const char *fit_saturated_name(enum fit_saturated how);

/* 1 when a fit of kind under how takes saturated readings as lower bounds. */
int fit_model_censors(const struct fit_model_kind *kind, enum fit_saturated how);

/* The row for a model name, or NULL. */
const struct fit_model_kind *fit_model_find(const char *name);

/* The RGB model a capture fits (`gonio capture --model`, goniod's capture
 * command): the row of that name, or NULL with a GONIO_EUSAGE error
 * "WHAT 'NAME': ..." that lists the RGB model names (an unknown name) or
 * says that the model fits spectral samples. */
const struct fit_model_kind *fit_model_find_rgb(const char *name, const char *what,
                                                struct gonio_err *err);

/* The row that opens model files of this kind, or NULL. */
const struct fit_model_kind *fit_model_for_kind(const char *file_kind);

/* Rows in registry order, for listings: i = 0.. until NULL. */
const struct fit_model_kind *fit_model_at(size_t i);

#endif
