#include "sim/standard_draw.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_randist.h>
#include <gsl/gsl_rng.h>

#include "sim/effects.h"

/* The scene's standard_draw effect, or NULL. */
static const struct sim_effect_spec *draw_effect(const struct sim_scene *scene)
{
    for (int i = 0; i < scene->n_effects; i++)
        if (scene->effects[i].kind == SIM_FX_STANDARD_DRAW)
            return &scene->effects[i];
    return NULL;
}

int sim_standard_truth(const struct sim_scene *scene, const char *name,
                       struct brdf_standard *out, struct gonio_err *err)
{
    int rc = brdf_standard_load(name, out, err);
    const struct sim_effect_spec *fx = draw_effect(scene);
    if (rc < 0 || !fx)
        return rc;
    /* The effect's own stream, as every effect's: the draw follows the
     * scene seed and nothing else the scene holds. */
    gsl_rng *rng = gsl_rng_alloc(gsl_rng_mt19937);
    if (!rng)
        return gonio_err_set(err, ENOMEM, "%s: out of memory", name);
    gsl_rng_set(rng, sim_effects_stream_seed(scene->seed, fx->index,
                                             sim_effect_name(SIM_FX_STANDARD_DRAW)));
    double z_rho = gsl_ran_gaussian(rng, 1.0), z_shape = gsl_ran_gaussian(rng, 1.0);
    gsl_rng_free(rng);
    double scale = 1.0 + out->u_shape * z_shape;
    for (int c = 0; c < 3; c++)
        out->rho[c] = (out->rho[c] + out->u_rho[c] * z_rho) * scale;
    for (size_t k = 0; k < out->n_nm; k++)
        out->rho_nm[k] = (out->rho_nm[k] + out->u_nm[k] * z_rho) * scale;
    return 0;
}

brdf_material *sim_material_open(const struct sim_scene *scene, const char *spec,
                                 struct gonio_err *err)
{
    if (strncmp(spec, "standard:", 9) != 0 || !draw_effect(scene))
        return brdf_material_open(spec, err);
    struct brdf_standard s;
    if (sim_standard_truth(scene, spec + 9, &s, err) < 0)
        return NULL;
    return brdf_standard_material(&s, spec, err);
}
