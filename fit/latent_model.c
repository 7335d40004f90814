/* The latent model as a registry model (fit/models.h): fit z with the
 * committed decoder; a model file names its decoder and the decoder's CRC,
 * so that a model is never evaluated with weights it was not fitted for. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fit/domain_weights.h"
#include "fit/latent_private.h"
#include "fit/model_file.h"
#include "fit/models.h"

int fit_latent_model_fit(const struct fit_data *data, const struct fit_model_options *opt,
                         struct fit_model_file **out, struct fit_model_report *rep,
                         struct gonio_err *err)
{
    struct fit_model_options o = opt ? *opt : fit_model_default_options();
    if (!data->n_rgb)
        return gonio_err_set(err, GONIO_EUSAGE, "latent: needs RGB samples");
    char path[4096];
    if (latent_decoder_default_path(path, sizeof path) < 0)
        return gonio_err_set(err, GONIO_EUSAGE, "latent: decoder path too long");
    struct gonio_err e = {0};
    latent_decoder *d = latent_decoder_load(path, &e);
    if (!d) {
        if (err)
            *err = e;
        return -e.code;
    }
    struct latent_fit_options lo = latent_fit_default_options();
    lo.seed = o.seed;
    lo.lower = data->rgb_lower;
    lo.domain_weights = data->domain_weights;
    if (o.max_epochs > 0) /* weighted or not */
        lo.max_iter = lo.weighted_iter = o.max_epochs;
    double z[LATENT_MAX_NZ];
    struct latent_fit_info info;
    int rc = fit_latent(d, data->rgb, data->n_rgb, &lo, z, &info, err);
    if (rc < 0) {
        latent_decoder_free(d);
        return rc;
    }
    struct fit_model_file *f = fit_model_file_new("latent", LATENT_MODEL_VERSION);
    rc = f ? 0 : -ENOMEM;
    rc = rc ? rc : fit_model_file_set(f, "decoder", "default");
    rc = rc ? rc : fit_model_file_set(f, "decoder_crc", "%08x", (unsigned)d->crc);
    rc = rc ? rc : fit_model_file_set(f, "nz", "%d", d->nz);
    rc = rc ? rc : fit_model_file_set(f, "loss", "%.6g", info.loss);
    rc = rc ? rc : fit_model_file_set(f, "seed", "%llu", (unsigned long long)o.seed);
    rc = rc ? rc : fit_model_file_set(f, "scale", "%.17g", info.scale);
    rc = rc ? rc : fit_status_file_keys(f, &info.status);
    if (!rc && info.domain_weights)
        rc = fit_model_file_set(f, "weights", FIT_DOMAIN_WEIGHTS_NOTE);
    rc = rc ? rc
            : fit_model_file_set(f, "prior",
                                 "kernel density of %zu training latents, bandwidth %.4g, "
                                 "scale %g, weight %.3g",
                                 d->n_materials, info.bandwidth, lo.prior_scale,
                                 info.prior_weight);
    rc = rc ? rc : fit_model_file_set_data(f, z, (size_t)d->nz);
    latent_decoder_free(d);
    if (rc) {
        fit_model_file_free(f);
        return gonio_err_set(err, ENOMEM, "latent: out of memory");
    }
    if (rep) {
        rep->converged = !(info.status.findings & (1u << FIT_STATUS_NOT_CONVERGED));
        rep->status = info.status;
        rep->weighted = info.domain_weights;
        snprintf(rep->note, sizeof rep->note,
                 "latent: %d starts x %d Adam steps on %zu samples (%zu dropped), mean |log "
                 "residual| %.4f, population prior weight %.2g, %.2g of the objective's fall "
                 "in the last tenth of the steps",
                 info.starts, info.iterations, info.used, info.dropped, info.loss,
                 info.prior_weight, info.gain);
    }
    *out = f;
    return 0;
}

brdf_material *fit_latent_model_open(const struct fit_model_file *f, const char *name,
                                     struct gonio_err *err)
{
    const char *path = name && !strncmp(name, "model:", 6) ? name + 6 : name ? name : "(model)";
    if (f->version != LATENT_MODEL_VERSION) {
        gonio_err_set(err, GONIO_EBADDATA, "%s: latent model version %d (this gonio reads %d)",
                      path, f->version, LATENT_MODEL_VERSION);
        return NULL;
    }
    const char *dk = fit_model_file_get(f, "decoder");
    const char *ck = fit_model_file_get(f, "decoder_crc");
    if (!dk || !ck) {
        gonio_err_set(err, GONIO_EBADDATA, "%s: latent model without decoder/decoder_crc keys",
                      path);
        return NULL;
    }
    char dpath[4096];
    if (!strcmp(dk, "default")) {
        if (latent_decoder_default_path(dpath, sizeof dpath) < 0) {
            gonio_err_set(err, GONIO_EUSAGE, "%s: decoder path too long", path);
            return NULL;
        }
    } else {
        snprintf(dpath, sizeof dpath, "%s", dk);
    }
    char *end;
    unsigned long crc = strtoul(ck, &end, 16);
    if (end == ck || *end) {
        gonio_err_set(err, GONIO_EBADDATA, "%s: decoder_crc '%s' is not hexadecimal", path, ck);
        return NULL;
    }
    /* files written before the scale normalisation have no scale: 1 */
    double scale = 1.0;
    if (fit_model_file_get(f, "scale")) {
        if (fit_model_file_get_double(f, "scale", path, &scale, err) < 0)
            return NULL;
        if (!(scale > 0) || !isfinite(scale)) {
            gonio_err_set(err, GONIO_EBADDATA, "%s: scale %g is not a positive number", path,
                          scale);
            return NULL;
        }
    }
    latent_decoder *d = latent_decoder_load(dpath, err);
    if (!d)
        return NULL;
    brdf_material *m = NULL;
    if (d->crc != (uint32_t)crc) {
        gonio_err_set(err, GONIO_EBADDATA,
                      "%s: fitted with decoder CRC %08lx, but %s has CRC %08x (retrained "
                      "decoder: refit the model)",
                      path, crc, dpath, (unsigned)d->crc);
    } else if (f->n_data != (size_t)d->nz) {
        gonio_err_set(err, GONIO_EBADDATA, "%s: %zu latent values, the decoder needs %d", path,
                      f->n_data, d->nz);
    } else {
        m = latent_material_scaled(d, f->data, scale, name ? name : "latent");
        if (!m)
            gonio_err_set(err, ENOMEM, "%s: out of memory", path);
    }
    latent_decoder_free(d);
    return m;
}
