#include "render/scene.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/cfg.h"
#include "common/paths.h"
#include "rig/rig.h"

#define RS_PI 3.14159265358979323846

static const char *const effect_names[RENDER_FX_KINDS] = {
    [RENDER_FX_DIRECT] = "direct",
    [RENDER_FX_ENVIRONMENT] = "environment",
};

const char *render_effect_name(enum render_effect_kind kind)
{
    return (unsigned)kind < RENDER_FX_KINDS ? effect_names[kind] : NULL;
}

int render_scene_has(const struct render_scene *sc, enum render_effect_kind kind)
{
    for (int i = 0; i < sc->n_effects; i++)
        if (sc->effects[i] == kind)
            return 1;
    return 0;
}

static void set3(double v[3], double a, double b, double c)
{
    v[0] = a;
    v[1] = b;
    v[2] = c;
}

/* The defaults of every parameter; also what an effect named without
 * parameters gets. The light comes from the upper left, in front; its
 * irradiance of pi makes a white diffuser facing it radiance 1. */
static void defaults(struct render_scene *sc)
{
    memset(sc, 0, sizeof *sc);
    snprintf(sc->name, sizeof sc->name, "default");
    double d = 1 / sqrt(3.0);
    set3(sc->direct.direction, -d, d, d);
    set3(sc->direct.irradiance, RS_PI, RS_PI, RS_PI);
    set3(sc->env.sky, 0.25, 0.35, 0.55);
    set3(sc->env.horizon, 0.6, 0.6, 0.6);
    set3(sc->env.ground, 0.15, 0.13, 0.11);
    sc->env.samples = 64;
    sc->env.seed = 1;
    sc->exposure = 1.0;
    sc->curve = RENDER_CURVE_REINHARD;
}

void render_scene_default(struct render_scene *sc)
{
    defaults(sc);
    sc->n_effects = 2;
    sc->effects[0] = RENDER_FX_DIRECT;
    sc->effects[1] = RENDER_FX_ENVIRONMENT;
}

/* An optional [r, g, b] of linear values in 0..hi. */
static int rgb(const struct cfg_doc *doc, const struct cfg_node *map, const char *key, double hi,
               double out[3], struct gonio_err *err)
{
    double *v;
    size_t n;
    int rc = cfg_doubles(doc, map, key, CFG_OPTIONAL, 0, hi, 3, 3, &v, &n, err);
    if (rc <= 0)
        return rc;
    memcpy(out, v, 3 * sizeof *v);
    free(v);
    return 1;
}

static int parse_direct(const struct cfg_doc *doc, const struct cfg_node *item,
                        struct render_direct *d, struct gonio_err *err)
{
    double *v;
    size_t n;
    int rc = cfg_doubles(doc, item, "direction", CFG_OPTIONAL, -1e6, 1e6, 3, 3, &v, &n, err);
    if (rc < 0)
        return rc;
    if (rc > 0) {
        double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        if (!(len > 1e-9)) {
            rc = cfg_error(doc, cfg_get(doc, item, "direction"), "direction", err,
                           "zero vector (value [%g, %g, %g]; give a direction towards the "
                           "light)",
                           v[0], v[1], v[2]);
            free(v);
            return rc;
        }
        for (int c = 0; c < 3; c++)
            d->direction[c] = v[c] / len;
        free(v);
    }
    return rgb(doc, item, "irradiance", 1e6, d->irradiance, err);
}

static int parse_environment(const struct cfg_doc *doc, const struct cfg_node *item,
                             struct render_environment *e, struct gonio_err *err)
{
    long samples = e->samples, seed = (long)e->seed;
    int rc;
    if ((rc = rgb(doc, item, "sky", 1e6, e->sky, err)) < 0 ||
        (rc = rgb(doc, item, "horizon", 1e6, e->horizon, err)) < 0 ||
        (rc = rgb(doc, item, "ground", 1e6, e->ground, err)) < 0 ||
        (rc = cfg_int(doc, item, "samples", CFG_OPTIONAL, 1, RENDER_ENV_MAX_SAMPLES, &samples,
                      err)) < 0 ||
        (rc = cfg_int(doc, item, "seed", CFG_OPTIONAL, 0, 4294967295L, &seed, err)) < 0)
        return rc;
    e->samples = (int)samples;
    e->seed = (unsigned long)seed;
    return 0;
}

static int parse_effects(const struct cfg_doc *doc, const struct cfg_node *root,
                         struct render_scene *sc, struct gonio_err *err)
{
    static const char *const direct_keys[] = {"name", "direction", "irradiance", NULL};
    static const char *const env_keys[] = {"name", "sky", "horizon", "ground", "samples", "seed",
                                           NULL};
    const struct cfg_node *list;
    int rc = cfg_seq(doc, root, "effects", CFG_REQUIRED, &list, err);
    if (rc < 0)
        return rc;
    size_t n = cfg_seq_len(doc, list);
    int seen[RENDER_FX_KINDS] = {0};
    for (size_t i = 0; i < n; i++) {
        const struct cfg_node *item = cfg_seq_item(doc, list, i), *name_node;
        int kind = cfg_named_item(doc, item, "effects", "effect", effect_names, RENDER_FX_KINDS,
                                  &name_node, err);
        if (kind < 0)
            return kind;
        const char *name = effect_names[kind];
        if (seen[kind])
            return cfg_error(doc, name_node, "name", err, "effect '%s' named twice", name);
        seen[kind] = 1;
        sc->effects[sc->n_effects++] = (enum render_effect_kind)kind;
        if (!cfg_is_map(doc, item))
            continue; /* a bare name takes the defaults */
        if (kind == RENDER_FX_DIRECT) {
            if ((rc = cfg_check_keys(doc, item, name, direct_keys, err)) < 0 ||
                (rc = parse_direct(doc, item, &sc->direct, err)) < 0)
                return rc;
        } else if ((rc = cfg_check_keys(doc, item, name, env_keys, err)) < 0 ||
                   (rc = parse_environment(doc, item, &sc->env, err)) < 0) {
            return rc;
        }
    }
    return 0;
}

static int parse_tonemap(const struct cfg_doc *doc, const struct cfg_node *root,
                         struct render_scene *sc, struct gonio_err *err)
{
    static const char *const keys[] = {"exposure", "curve", NULL};
    static const char *const curves[] = {"reinhard", "clamp", NULL};
    const struct cfg_node *tm;
    int rc = cfg_map(doc, root, "tonemap", CFG_OPTIONAL, &tm, err);
    if (rc < 0 || !tm)
        return rc < 0 ? rc : 0;
    int curve = (int)sc->curve;
    if ((rc = cfg_check_keys(doc, tm, "tonemap", keys, err)) < 0 ||
        (rc = cfg_double(doc, tm, "exposure", CFG_OPTIONAL, 1e-6, 1e6, &sc->exposure, err)) < 0 ||
        (rc = cfg_enum(doc, tm, "curve", CFG_OPTIONAL, curves, &curve, err)) < 0)
        return rc;
    sc->curve = (enum render_curve)curve;
    return 0;
}

int render_scene_load(const char *path_or_name, struct render_scene *sc, struct gonio_err *err)
{
    static const char *const keys[] = {"name", "description", "effects", "background", "tonemap",
                                       NULL};
    defaults(sc);
    if (gonio_config_path(path_or_name, "render", sc->path, sizeof sc->path) < 0)
        return gonio_err_set(err, GONIO_EBADCONFIG, "%s: scene path too long", path_or_name);
    struct cfg_doc *doc;
    int rc = cfg_load(sc->path, &doc, err);
    if (rc < 0) {
        if (rc == -GONIO_ENOTFOUND && !strchr(path_or_name, '/'))
            gonio_err_set(err, GONIO_ENOTFOUND, "%s: no such render scene (looked for %s)",
                          path_or_name, sc->path);
        return rc;
    }
    const struct cfg_node *root = cfg_root(doc);
    const char *name = NULL;
    if ((rc = cfg_check_keys(doc, root, "render scene", keys, err)) < 0 ||
        (rc = cfg_string(doc, root, "name", CFG_OPTIONAL, &name, err)) < 0 ||
        (rc = rgb(doc, root, "background", 1e6, sc->background, err)) < 0 ||
        (rc = parse_tonemap(doc, root, sc, err)) < 0 ||
        (rc = parse_effects(doc, root, sc, err)) < 0) {
        cfg_free(doc);
        return rc;
    }
    if (name && strlen(name) >= sizeof sc->name)
        rc = cfg_error(doc, cfg_get(doc, root, "name"), "name", err,
                       "value longer than %zu characters", sizeof sc->name - 1);
    else if (name)
        snprintf(sc->name, sizeof sc->name, "%s", name);
    else {
        const char *base = strrchr(sc->path, '/');
        base = base ? base + 1 : sc->path;
        size_t len = strcspn(base, ".");
        if (len >= sizeof sc->name)
            len = sizeof sc->name - 1;
        memcpy(sc->name, base, len);
        sc->name[len] = '\0';
    }
    cfg_free(doc);
    return rc < 0 ? rc : 0;
}
