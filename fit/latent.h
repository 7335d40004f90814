/* The latent-code BRDF model, in the spirit of neural layered BRDFs and of
 * auto-decoders (DeepSDF): one MLP decoder, trained once across a library
 * of materials, maps (direction encoding, latent vector z) to RGB; a new
 * material is described by its z alone. The decoder knows the whole
 * hemisphere, so z fitted to in-plane samples gives an out-of-plane BRDF.
 *
 * Decoder (docs/latent.md):
 *   x  = (sin th, 0, cos th, sin td cos pd, sin td sin pd, cos td)   (NBRDF encoding)
 *   a1 = relu([x, z] W1 + b1), ak = relu(a(k-1) Wk + bk), o = aL Wo + bo
 *   f  = max(0, exp(o) - 1)                                            (1/sr, RGB)
 *
 * Training (latent_train) fits the decoder weights and one z per training
 * material jointly, with Adam, on the loss |log(1 + f cos ti) - log(1 +
 * fhat cos ti)| at random direction pairs of each material's NBRDF network.
 * Fitting (fit_latent) freezes the decoder and fits z only. */
#ifndef GONIO_FIT_LATENT_H
#define GONIO_FIT_LATENT_H

#include <stddef.h>
#include <stdint.h>

#include "brdf/material.h"
#include "common/err.h"
#include "fit/fit.h"

#define LATENT_FILE_VERSION 1
#define LATENT_NIN 6          /* direction encoding */
#define LATENT_NOUT 3         /* RGB */
#define LATENT_MAX_LAYERS 4   /* hidden layers */
#define LATENT_MAX_WIDTH 256  /* hidden units per layer */
#define LATENT_MAX_NZ 64
#define LATENT_NAME_MAX 64

/* The 10 study materials: never trained on, used for acceptance. */
extern const char *const latent_heldout_materials[10];

typedef struct latent_decoder latent_decoder;

/* Shape and training settings. */
struct latent_train_options {
    int nz;               /* latent dimension */
    int layers;           /* hidden layers */
    int width;            /* units per hidden layer */
    long steps;           /* Adam steps; each sees every material */
    int samples_per_step; /* random pairs per material per step */
    double lr, lr_z;      /* Adam step sizes of weights and latents (cosine decay) */
    double lambda_z;      /* weight of the mean of z^2 in the loss (latent prior) */
    double z_noise;       /* sd of Gaussian noise added to z at each use (0: none) */
    double inplane;       /* fraction of training pairs drawn in the incidence plane */
    uint64_t seed;        /* initial weights, latents and every sample */
    int threads;          /* worker threads (results do not depend on it) */
    /* Progress, called every twentieth of the steps and at the last with
     * the steps done and the running loss; the caller shows it (gonio
     * train-decoder: cli/progress.h). NULL: none. */
    void (*on_progress)(void *ctx, long done, long steps, double loss);
    void *progress_ctx;
};

struct latent_train_options latent_train_default_options(void);

/* Train a decoder on the named materials (brdf_material_open("nbrdf:NAME")
 * each). Names of the held-out list are refused. Deterministic: the same
 * options and materials give bit-identical weights whatever the thread
 * count. Returns 0 or a negative code with err set. */
int latent_train(const char *const *materials, size_t n, const struct latent_train_options *opt,
                 latent_decoder **out, struct gonio_err *err);

/* The NBRDF materials of the shared folder minus the held-out ones, sorted
 * by name: the default training set. *names (free with latent_names_free)
 * and the count. */
int latent_default_training_set(char ***names, size_t *n, struct gonio_err *err);
void latent_names_free(char **names, size_t n);

/* Save / load the versioned weight file (docs/latent.md). Load refuses a
 * damaged file (bad magic/version/sizes, short or long data, CRC mismatch,
 * non-finite weight) with err naming the file. */
int latent_decoder_save(const latent_decoder *d, const char *path, struct gonio_err *err);
latent_decoder *latent_decoder_load(const char *path, struct gonio_err *err);

/* <gonio_config_dir()>/models/latent-decoder.gld: the committed decoder. */
int latent_decoder_default_path(char *buf, size_t size);

void latent_decoder_free(latent_decoder *d);

/* Accessors. */
int latent_decoder_nz(const latent_decoder *d);
size_t latent_decoder_n_materials(const latent_decoder *d);
const char *latent_decoder_material(const latent_decoder *d, size_t i);
/* Training material i's latent (nz values), or NULL. */
const double *latent_decoder_latent(const latent_decoder *d, size_t i);
/* Index of a training material by name, or -1. */
long latent_decoder_find(const latent_decoder *d, const char *name);
/* The mean of the training latents (nz values). */
const double *latent_decoder_mean_latent(const latent_decoder *d);
/* Kernel bandwidth of the population prior of fits: the one that maximises
 * the training latents' leave-one-out likelihood (fit_latent). */
double latent_decoder_prior_bandwidth(const latent_decoder *d);
/* CRC-32 of the weight file's data block: identifies the decoder in model
 * files. */
uint32_t latent_decoder_crc(const latent_decoder *d);
uint64_t latent_decoder_seed(const latent_decoder *d);

/* Evaluate the decoder for latent z at n pairs into rgb[3n] (1/sr). */
void latent_decoder_eval(const latent_decoder *d, const double *z, const struct brdf_pair *pairs,
                         size_t n, double *rgb);

/* A material: the decoder (copied) with latent z. name may be NULL
 * ("latent"). NULL on out of memory. */
brdf_material *latent_material(const latent_decoder *d, const double *z, const char *name);
/* The same material multiplied by scale (a fit of data not in 1/sr). */
brdf_material *latent_material_scaled(const latent_decoder *d, const double *z, double scale,
                                      const char *name);

/* Laplace scale b of the log residuals that the population prior assumes:
 * the prior enters a fit of n samples with weight b / (3 n) (docs/latent.md
 * says how b was chosen: on the training materials, not the held-out ones). */
#define LATENT_PRIOR_SCALE 0.03

struct latent_fit_options {
    int max_iter;         /* Adam iterations per start */
    int weighted_iter;    /* the same when the fit weighs its samples (domain_weights, at
                             least FIT_DOMAIN_WEIGHTS_MIN_SAMPLES of them); 0: max_iter.
                             The weighted objective, led by a few samples that stand
                             for much of the domain, converges slower: tungsten-carbide's
                             adaptive lab capture 0.0605 full-domain log error after 300
                             steps, 0.0374 after 1000, 0.0376 after 3000 */
    int n_starts;         /* starts: best training latents by initial loss, plus the mean */
    int weighted_starts;  /* the same when the fit weighs its samples; 0: n_starts. The
                             weighted objective can have a second basin that both of two
                             starts end in: gold-metallic-paint's adaptive lab capture
                             0.0255 full-domain log error from 2 starts, 0.0207 from 4
                             (docs/notes/adaptive.md "Four starts for the weighted latent fit") */
    size_t max_samples;   /* larger inputs use a seeded random subset of this size */
    double lr;            /* Adam step size (cosine decay to lr / 20) */
    double lambda_z;      /* weight of the prior mean(z^2); < 0: the decoder's
                             training value (the training objective) */
    double prior_scale;   /* b of the population prior (LATENT_PRIOR_SCALE); 0: no
                             population prior */
    double bandwidth;     /* its kernel bandwidth; <= 0: the decoder's (leave-one-out
                             maximum likelihood over the training latents) */
    uint64_t seed;
    const unsigned char *lower; /* NULL, or one flag per sample: 1 for a saturated
                                   reading, fitted as a lower bound (censored) */
    int domain_weights;   /* 1: each sample's residuals weighted by its share of the
                             full domain (fit/domain_weights.h; fit_options has the
                             same), for samples an adaptive policy chose; the loss and
                             the status's residuals are then weighted means; fewer than
                             FIT_DOMAIN_WEIGHTS_MIN_SAMPLES are fitted unweighted */
};

struct latent_fit_options latent_fit_default_options(void);

struct latent_fit_info {
    double loss;          /* final mean |log residual| over used samples and channels */
    double start_loss;    /* the same at the winning start */
    int iterations;
    int starts;
    size_t used;          /* samples in the fit (after dropping and subsetting) */
    size_t dropped;       /* non-finite, below the horizon, or 1 + f cos <= 0 */
    double prior_weight;  /* weight of the population prior's -log density: b / (3 used) */
    double bandwidth;     /* its kernel bandwidth */
    double gain;          /* share of the objective's fall that came in the last tenth
                             of the winning start's steps */
    double scale;         /* the data were divided by it (fit_data_scale, fit/fit.h): the
                             material is scale times the decoder at z */
    int domain_weights;   /* 1: the samples were weighted by their domain share */
    struct fit_status status; /* fit/fit_status.h: params nz; held-out from a refit
                                 without every 5th sample; not-converged when the
                                 objective still fell by more than LATENT_FIT_GAIN_TOL
                                 over the last tenth of the Adam steps */
};

/* Share of the objective's fall in the last tenth of a fit's steps above
 * which the fit has not converged: the cosine schedule ended in the middle
 * of a descent. The default 300 steps end at 2e-5 (nylon DS1) to 0.0023
 * (brass DS4) on the study materials; brass DS2 at 5, 10, 30 steps: 0.058,
 * 0.018, 0.0051. */
#define LATENT_FIT_GAIN_TOL 0.01

/* Fit z (nz values, written to z) to n samples with the decoder frozen: the
 * MAP estimate under Laplace noise of scale b on log(1 + f cos ti) and a
 * kernel-density prior over the training latents, on top of the training
 * objective (docs/latent.md). Six samples do not pin 12 latent numbers; the
 * prior keeps z near real materials then, and fades as 1 / n with more data.
 * Fewer than 3 usable samples is a GONIO_EFIT error. opt and info may be
 * NULL. Deterministic for opt->seed, and independent of the samples' order
 * (fit/sample_order.h). */
int fit_latent(const latent_decoder *d, const struct fit_sample *samples, size_t n,
               const struct latent_fit_options *opt, double *z, struct latent_fit_info *info,
               struct gonio_err *err);

/* The registry row (fit/models.h): `gonio fit --model latent` fits z with
 * the committed decoder and writes a model file of kind "latent" (version
 * LATENT_MODEL_VERSION): keys decoder (path, or "default" for
 * latent_decoder_default_path), decoder_crc (hex), nz, loss; data = z. Open
 * refuses a model whose decoder file is missing or has another CRC. */
#define LATENT_MODEL_VERSION 1
struct fit_data;
struct fit_model_options;
struct fit_model_file;
struct fit_model_report;
int fit_latent_model_fit(const struct fit_data *data, const struct fit_model_options *opt,
                         struct fit_model_file **out, struct fit_model_report *rep,
                         struct gonio_err *err);
brdf_material *fit_latent_model_open(const struct fit_model_file *f, const char *name,
                                     struct gonio_err *err);

#endif
