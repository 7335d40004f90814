/* The model registry (fit/models.h). Add a row per model. */
#include "fit/models.h"

#include <stdio.h>
#include <string.h>

#include "fit/abc_model.h"
#include "fit/aniso_ggx_model.h"
#include "fit/auto_model.h"
#include "fit/abc_prior.h"
#include "fit/latent.h"
#include "fit/mlp.h"
#include "fit/pseudo.h"

static const struct fit_model_kind models[] = {
    {"abc", "abc", "ABC microfacet model, Levenberg-Marquardt (fit/fit.h)", 0, 0,
     fit_abc_model_fit, fit_abc_model_open},
    {"abc-prior", "abc", "ABC with a population prior (MAP), for few samples (fit/abc_prior.h)",
     0, 0, fit_abc_prior_model_fit, NULL},
    {"abc-pseudo", "abc", "ABC fitted to the capture densified by the RGB MLP on DS1", 0, 0,
     fit_abc_pseudo_fit, NULL},
    {"aniso-ggx", "aniso-ggx",
     "anisotropic GGX (ax, ay, orientation), from samples at several sample azimuths "
     "(fit/aniso_ggx_model.h)",
     0, 1, fit_aniso_ggx_model_fit, fit_aniso_ggx_model_open},
    {"mlp", "mlp", "RGB MLP on (theta_i, theta_r), in-plane only", 0, 1, fit_mlp_rgb_fit,
     fit_mlp_rgb_open},
    {"mlp-spectral", "mlp-spectral", "spectral MLP on (theta_i, theta_r, wavelength)", 1, 1,
     fit_mlp_spectral_fit, fit_mlp_spectral_open},
    {"latent", "latent", "latent-code neural BRDF: frozen decoder, z fitted (docs/latent.md)",
     0, 1, fit_latent_model_fit, fit_latent_model_open},
    {"auto", "abc|latent|aniso-ggx",
     "the out-of-plane model (abc, abc-prior, latent) of lowest 5-fold CV log error "
     "(fit/auto_model.h)",
     0, 1, fit_auto_model_fit, NULL},
};

#define N_MODELS (sizeof models / sizeof models[0])

struct fit_model_options fit_model_default_options(void)
{
    return (struct fit_model_options){.seed = 1, .max_epochs = 0, .quiet = 1};
}

static const char *const saturated_names[] = {"default", "clipped", "censored"};

int fit_saturated_parse(const char *s, enum fit_saturated *out)
{
    for (size_t i = 0; i < sizeof saturated_names / sizeof *saturated_names; i++)
        if (!strcmp(s, saturated_names[i])) {
            *out = (enum fit_saturated)i;
            return 0;
        }
    return -1;
}

const char *fit_saturated_name(enum fit_saturated how)
{
    return saturated_names[how];
}

int fit_model_censors(const struct fit_model_kind *kind, enum fit_saturated how)
{
    return how == FIT_SATURATED_DEFAULT ? kind->censors_saturated
                                        : how == FIT_SATURATED_CENSORED;
}

const struct fit_model_kind *fit_model_find(const char *name)
{
    for (size_t i = 0; i < N_MODELS; i++)
        if (!strcmp(models[i].name, name))
            return &models[i];
    return NULL;
}

const struct fit_model_kind *fit_model_find_rgb(const char *name, const char *what,
                                                struct gonio_err *err)
{
    char list[256] = "";
    size_t len = 0, n_rgb = 0, k = 0;
    for (size_t i = 0; i < N_MODELS; i++)
        n_rgb += !models[i].spectral;
    for (size_t i = 0; i < N_MODELS && len < sizeof list; i++) {
        if (models[i].spectral)
            continue;
        k++;
        len += (size_t)snprintf(list + len, sizeof list - len, "%s%s",
                                k == 1 ? "" : k == n_rgb ? " or " : ", ", models[i].name);
    }
    const struct fit_model_kind *kind = fit_model_find(name);
    if (kind && !kind->spectral)
        return kind;
    if (kind)
        gonio_err_set(err, GONIO_EUSAGE,
                      "%s '%s': a spectral model, and a capture fits RGB samples; use %s "
                      "(or gonio fit --model %s on its spectra.csv)",
                      what, name, list, name);
    else
        gonio_err_set(err, GONIO_EUSAGE, "%s '%s': unknown model; use %s", what, name, list);
    return NULL;
}

const struct fit_model_kind *fit_model_for_kind(const char *file_kind)
{
    for (size_t i = 0; i < N_MODELS; i++)
        if (models[i].open && !strcmp(models[i].file_kind, file_kind))
            return &models[i];
    return NULL;
}

const struct fit_model_kind *fit_model_at(size_t i)
{
    return i < N_MODELS ? &models[i] : NULL;
}
