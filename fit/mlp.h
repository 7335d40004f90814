/* Small multilayer perceptrons trained in plain C (docs/models.md).
 *
 * A network maps normalised inputs x_k = (u_k - offset_k) * scale_k through
 * hidden ReLU layers to outputs z that stand for log(1 + f) per output f.
 * Training minimises the mean squared log error of the metrics
 * (brdf/metrics.h): (log(1 + expm1(z) c) - log(1 + f c))^2 with
 * c = cos theta_i, with Adam on seeded mini-batches, He-uniform initial
 * weights, and early stopping on a held-out split. Everything random comes
 * from splitmix64 (brdf_splitmix64) seeded with the caller's seed, so a seed
 * gives bit-identical weights on a given build.
 *
 * Training allocates once, before the first epoch; the epoch loop does not
 * allocate. */
#ifndef GONIO_FIT_MLP_H
#define GONIO_FIT_MLP_H

#include <stddef.h>
#include <stdint.h>

#include "brdf/material.h"
#include "common/err.h"
#include "fit/fit.h"
#include "fit/models.h"

#define FIT_MLP_MAX_LAYERS 8 /* weight layers */
#define FIT_MLP_MAX_WIDTH 64

struct fit_mlp {
    int n_layers;                       /* weight layers (hidden + 1) */
    int width[FIT_MLP_MAX_LAYERS + 1];  /* width[0] inputs ... width[n_layers] outputs */
    double offset[FIT_MLP_MAX_WIDTH], scale[FIT_MLP_MAX_WIDTH]; /* input normalisation */
    size_t n_params;
    /* Layer l: W_l (width[l+1] x width[l], row-major) then b_l (width[l+1]). */
    double *params;
};

/* Allocate a network of these widths (n_layers + 1 entries) with zero
 * weights, offset 0 and scale 1. Returns 0 or a negative code. */
int fit_mlp_init(struct fit_mlp *net, int n_layers, const int *width, struct gonio_err *err);
void fit_mlp_free(struct fit_mlp *net);

/* z[n * outputs] for n raw (unnormalised) input rows u[n * inputs]. */
void fit_mlp_forward(const struct fit_mlp *net, const double *u, size_t n, double *z);

struct fit_mlp_train_options {
    uint64_t seed;
    int batch;          /* mini-batch size (default 32) */
    double lr;          /* Adam step (default 2e-3), halved whenever the training loss
                           has not improved for a third of the patience */
    double beta1, beta2, eps; /* Adam (0.9, 0.999, 1e-8) */
    int max_epochs;     /* default 0: from max_steps */
    long max_steps;     /* with max_epochs 0: epochs = max_steps / batches per epoch */
    int patience;       /* epochs without a held-out improvement before stopping */
    long min_patience_steps; /* ...but at least this many steps (default 10000) */
    double holdout;     /* fraction of rows held out for early stopping (0.15);
                           no hold-out (and no early stop) below 8 rows */
    int quiet;
    /* NULL, or twin[i] = the row that is the same measurement as row i seen
     * another way (SIZE_MAX: none); twins are held out together. */
    const size_t *twin;
    /* NULL, or lower[i] 1 when row i's targets are lower bounds (a saturated
     * reading): censored, no loss while the output is above them. */
    const unsigned char *lower;
};

struct fit_mlp_train_options fit_mlp_default_train_options(void);

struct fit_mlp_train_report {
    int epochs;             /* epochs run */
    int best_epoch;         /* epoch whose weights were kept (1-based) */
    int early_stopped;      /* 1: stopped by patience before max_epochs */
    double train_loss0;     /* mean loss on the training rows before training */
    double train_loss;      /* mean loss on the training rows, kept weights */
    double val_loss;        /* the same on the held-out rows (NAN: none) */
    size_t n_train, n_val;
    double seconds;         /* wall time of the epoch loop */
};

/* Train a network from its current shape: He-uniform initial weights, the
 * input normalisation from the inputs' ranges (mapped to [-1, 1]), then
 * Adam. u[n * inputs], f[n * outputs] targets (1/sr), c[n] the cosine of
 * theta_i of each row. Rows with a non-finite value are refused. */
int fit_mlp_train(struct fit_mlp *net, const double *u, const double *f, const double *c,
                  size_t n, const struct fit_mlp_train_options *opt,
                  struct fit_mlp_train_report *rep, struct gonio_err *err);

/* Mean of the per-value loss over n rows (as minimised by training). */
double fit_mlp_loss(const struct fit_mlp *net, const double *u, const double *f,
                    const double *c, size_t n);

/* Output z to a BRDF value: expm1(z) clamped to [0, 1e30], so that every
 * finite or infinite z gives a finite, non-negative value. */
double fit_mlp_value(double z);

/* Model file round trip of a network (kind, version and extra keys are the
 * caller's). */
int fit_mlp_to_file(const struct fit_mlp *net, struct fit_model_file *f);
int fit_mlp_from_file(const struct fit_model_file *f, const char *path, struct fit_mlp *net,
                      struct gonio_err *err);

/* The two models of the registry. RGB: inputs (theta_i, theta_r) in
 * degrees, 5 hidden layers of 20, outputs log(1 + f) for r, g, b; trained
 * on the in-plane samples (out-of-plane ones are left out). Spectral:
 * inputs (theta_i, theta_r, wavelength_nm), 3 hidden layers of 10, one
 * output. */
int fit_mlp_rgb_fit(const struct fit_data *data, const struct fit_model_options *opt,
                    struct fit_model_file **out, struct fit_model_report *rep,
                    struct gonio_err *err);
int fit_mlp_spectral_fit(const struct fit_data *data, const struct fit_model_options *opt,
                         struct fit_model_file **out, struct fit_model_report *rep,
                         struct gonio_err *err);

/* Train the RGB network (fresh, shape as above) on the usable in-plane
 * samples: out-of-plane pairs, pairs below the horizon and non-finite
 * values are left out and counted in *left_out (may be NULL); *geometries
 * (may be NULL) receives the distinct (theta_i, theta_r) of those used.
 * max_epochs 0: the default budget. lower: NULL, or n flags, 1 for a
 * saturated reading, trained as a lower bound (fit_data.rgb_lower). On
 * success net is allocated (fit_mlp_free). */
int fit_mlp_rgb_train_samples(const struct fit_sample *s, size_t n, const unsigned char *lower,
                              uint64_t seed,
                              int max_epochs, int quiet, struct fit_mlp *net,
                              struct fit_mlp_train_report *rep, size_t *left_out,
                              size_t *geometries, struct gonio_err *err);

/* Materials. The RGB network is defined on the incidence plane only: a pair
 * in the plane (brdf_pair_to_inplane) is evaluated at its in-plane angles,
 * an out-of-plane pair has no data (NAN). The spectral network is turned
 * into RGB through brdf/colour.h over 400-700 nm in 10 nm steps, with the
 * same in-plane rule. */
brdf_material *fit_mlp_rgb_open(const struct fit_model_file *f, const char *name,
                                struct gonio_err *err);
brdf_material *fit_mlp_spectral_open(const struct fit_model_file *f, const char *name,
                                     struct gonio_err *err);

/* In-plane angles of a pair (degrees) when its two directions and the
 * normal are coplanar, turned about the normal into the x-z plane first
 * (isotropic materials); -1 for a pair out of its incidence plane. tol:
 * the largest sine of the angle by which the direction nearer the normal
 * may leave the plane of the other (0: coplanar to rounding); the pair is
 * projected onto the plane, theta_i and theta_o kept. */
int fit_mlp_inplane_angles(const struct brdf_pair *p, double tol, double *theta_i_deg,
                           double *theta_r_deg);

/* The training tolerance: sin(0.05 deg). A rig settles a few hundredths of
 * a degree from its target (the lab scene's jitter is 0.02 deg), which
 * takes a commanded in-plane pair out of its plane; left out, the
 * out-of-plane plans' in-plane samples shrank to the specular ridge
 * (docs/fitting.md "Saturated readings"). Projecting changes an isotropic
 * material's value by the second order of that angle. */
#define FIT_MLP_PLANE_TOL 8.7266e-4

/* Read a spectral samples CSV (docs/models.md): a header line naming the
 * columns theta_i,theta_r,wavelength_nm,value (in that order; further
 * columns ignored, but for spectra.csv's acquisition,integration_s,saturated,
 * whose saturated flag marks a lower bound), then one sample a line. *out is malloc'd. Returns the
 * count or a negative code with err naming file:line. */
int fit_spectral_samples_read(const char *path, struct fit_spectral_sample **out, size_t *n,
                              struct gonio_err *err);

/* Spectral evaluation: n rows of (theta_i, theta_r, wavelength_nm) into
 * value[n] (1/sr). */
void fit_mlp_spectral_eval(const struct fit_mlp *net, const double *u, size_t n,
                           double *value);

#endif
