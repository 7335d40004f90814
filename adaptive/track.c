/* The latent model followed alongside the ensemble (adaptive/track.h). */
#include "adaptive/track.h"

#include <math.h>

#include "brdf/metrics.h"
#include "fit/model_run.h"

/* Fewer Adam steps than a capture's final fit (300): the tracked fit only
 * measures how well the decoder can follow the samples, and runs inside a
 * decision that must stay well below the rig's settle. */
#define TRACK_ITER 150

int track_init(struct track *t, struct gonio_err *err)
{
    *t = (struct track){.in_sample = NAN};
    char path[4096];
    if (latent_decoder_default_path(path, sizeof path) < 0)
        return gonio_err_set(err, GONIO_EUSAGE, "adaptive: the latent decoder's path is too long");
    t->dec = latent_decoder_load(path, err);
    return t->dec ? 0 : -(err && err->code ? err->code : GONIO_EBADDATA);
}

void track_free(struct track *t)
{
    latent_decoder_free(t->dec);
    t->dec = NULL;
}

int track_update(struct track *t, const struct fit_sample *s, size_t n, uint64_t seed)
{
    if (n < 6 || 4 * n < 5 * t->fitted)
        return 0;
    struct latent_fit_options o = latent_fit_default_options();
    o.max_iter = TRACK_ITER;
    o.seed = seed;
    double z[LATENT_MAX_NZ];
    struct latent_fit_info info;
    if (fit_latent(t->dec, s, n, &o, z, &info, NULL) < 0)
        return -GONIO_EFIT;
    brdf_material *m = latent_material_scaled(t->dec, z, info.scale, "latent");
    if (!m)
        return -GONIO_EFIT;
    struct brdf_errors e;
    int rc = fit_sample_errors(m, s, n, &e, NULL);
    brdf_material_free(m);
    if (rc < 0)
        return rc;
    t->fitted = n;
    t->in_sample = e.log;
    return 1;
}
