/* The material interface and the spec parser that picks a backend. */
#include "brdf/material.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/abc.h"
#include "brdf/analytic.h"
#include "brdf/embedded.h"
#include "brdf/material_private.h"
#include "brdf/merl.h"
#include "brdf/nbrdf.h"
#include "brdf/published.h"
#include "brdf/sgd.h"
#include "brdf/spectral.h"
#include "brdf/standard.h"
#include "common/paths.h"

struct brdf_material {
    const struct brdf_material_ops *ops;
    void *priv;
    char *name;
    int anisotropic;
};

brdf_material *brdf_material_new(const struct brdf_material_ops *ops, void *priv,
                                 const char *name)
{
    brdf_material *m = malloc(sizeof *m);
    char *copy = name ? strdup(name) : strdup(ops->kind);
    if (!m || !copy) {
        free(m);
        free(copy);
        if (ops->free_priv)
            ops->free_priv(priv);
        return NULL;
    }
    m->ops = ops;
    m->priv = priv;
    m->name = copy;
    m->anisotropic = 0;
    return m;
}

size_t brdf_material_eval(const brdf_material *m, const struct brdf_pair *pairs, size_t n,
                          double *rgb)
{
    m->ops->eval(m->priv, pairs, n, rgb);
    size_t missing = 0;
    for (size_t i = 0; i < n; i++)
        if (isnan(rgb[3 * i]) || isnan(rgb[3 * i + 1]) || isnan(rgb[3 * i + 2]))
            missing++;
    return missing;
}

int brdf_material_isotropic(const brdf_material *m)
{
    return !m->anisotropic;
}

void brdf_material_set_anisotropic(brdf_material *m)
{
    m->anisotropic = 1;
}

const char *brdf_material_name(const brdf_material *m)
{
    return m->name;
}

void brdf_material_free(brdf_material *m)
{
    if (!m)
        return;
    if (m->ops->free_priv)
        m->ops->free_priv(m->priv);
    free(m->name);
    free(m);
}

const char *brdf_material_default_spec(void)
{
    return brdf_embedded_default_spec();
}

/* A NAME is taken as a file path when it names one explicitly. */
static int looks_like_path(const char *name, const char *ext)
{
    size_t n = strlen(name), e = strlen(ext);
    return strchr(name, '/') != NULL || (n > e && strcmp(name + n - e, ext) == 0);
}

static brdf_material *open_nbrdf(const char *spec, const char *arg, struct gonio_err *err)
{
    char path[4096];
    if (looks_like_path(arg, ".nbrdf")) {
        snprintf(path, sizeof path, "%s", arg);
    } else {
        const char *shared = gonio_shared_dir();
        if (!shared) {
            gonio_err_set(err, GONIO_ENOTFOUND,
                          "%s: shared data folder not found (set GONIO_SHARED)", spec);
            return NULL;
        }
        if (snprintf(path, sizeof path, "%s/data/merl/nbrdf_f32/%s.nbrdf", shared, arg) >=
            (int)sizeof path) {
            gonio_err_set(err, GONIO_EBADCONFIG, "%s: name too long", spec);
            return NULL;
        }
    }
    struct gonio_err e = {0};
    brdf_material *m = brdf_nbrdf_open(path, spec, &e);
    if (!m) {
        if (e.code == GONIO_ENOTFOUND)
            gonio_err_set(err, e.code, "%s: no such NBRDF material (%s not found)", spec, path);
        else
            gonio_err_set(err, e.code ? e.code : GONIO_EBADDATA, "%s: %s", spec, e.msg);
    }
    return m;
}

static brdf_material *open_merl(const char *spec, const char *arg, struct gonio_err *err)
{
    struct gonio_err e = {0};
    brdf_material *m = brdf_merl_open(arg, spec, &e);
    if (!m)
        gonio_err_set(err, e.code ? e.code : GONIO_EBADDATA, "%s: %s", spec, e.msg);
    return m;
}

static brdf_material *open_abc(const char *spec, const char *arg, struct gonio_err *err)
{
    struct brdf_abc p;
    struct gonio_err e = {0};
    if (brdf_published_abc(arg, &p, &e) < 0) {
        gonio_err_set(err, e.code, "%s: %s", spec, e.msg);
        return NULL;
    }
    brdf_material *m = brdf_abc_material(&p, spec);
    if (!m)
        gonio_err_set(err, ENOMEM, "%s: out of memory", spec);
    return m;
}

static brdf_material *open_sgd(const char *spec, const char *arg, struct gonio_err *err)
{
    struct brdf_sgd p;
    struct gonio_err e = {0};
    if (brdf_published_sgd(arg, &p, &e) < 0) {
        gonio_err_set(err, e.code, "%s: %s", spec, e.msg);
        return NULL;
    }
    brdf_material *m = brdf_sgd_material(&p, spec);
    if (!m)
        gonio_err_set(err, ENOMEM, "%s: out of memory", spec);
    return m;
}

static brdf_material *open_builtin(const char *spec, const char *arg, struct gonio_err *err)
{
    struct brdf_sgd p;
    if (brdf_embedded_sgd(arg, &p) < 0) {
        gonio_err_set(err, GONIO_ENOTFOUND, "%s: no embedded material '%s' (have: %s)", spec,
                      arg, brdf_embedded_names());
        return NULL;
    }
    brdf_material *m = brdf_sgd_material(&p, spec);
    if (!m)
        gonio_err_set(err, ENOMEM, "%s: out of memory", spec);
    return m;
}

static brdf_material *open_analytic(const char *spec, const char *arg, struct gonio_err *err)
{
    return brdf_analytic_open(spec, arg, err); /* brdf/analytic.h */
}

static brdf_material *open_standard(const char *spec, const char *arg, struct gonio_err *err)
{
    struct brdf_standard s;
    if (brdf_standard_load(arg, &s, err) < 0)
        return NULL;
    return brdf_standard_material(&s, spec, err); /* brdf/standard.h */
}

static brdf_material *open_spectral(const char *spec, const char *arg, struct gonio_err *err)
{
    (void)arg;
    return brdf_spectral_material_open(spec, err); /* brdf/spectral.h */
}

/* A light trap: nothing reflected, so that what a detector reads with it
 * in the sample's place is the rig's stray light. */
static void trap_eval(const void *priv, const struct brdf_pair *pairs, size_t n, double *rgb)
{
    (void)priv, (void)pairs;
    for (size_t i = 0; i < 3 * n; i++)
        rgb[i] = 0.0;
}

static const struct brdf_material_ops trap_ops = {.kind = "trap", .eval = trap_eval};
static const struct brdf_material_ops beam_ops = {.kind = "beam", .eval = trap_eval};

brdf_material *brdf_material_open(const char *spec, struct gonio_err *err)
{
    static const struct {
        const char *kind;
        brdf_material *(*open)(const char *spec, const char *arg, struct gonio_err *err);
    } kinds[] = {
        {"nbrdf", open_nbrdf}, {"merl", open_merl},       {"abc", open_abc},
        {"sgd", open_sgd},     {"builtin", open_builtin}, {"spectral", open_spectral},
        {"analytic", open_analytic}, {"standard", open_standard},
    };
    if (!spec || !*spec) {
        gonio_err_set(err, GONIO_EBADCONFIG, "material: empty specification");
        return NULL;
    }
    if (strcmp(spec, "trap") == 0)
        return brdf_material_new(&trap_ops, NULL, spec);
    /* The sample removed, nothing in its place: it reflects nothing, as a
     * trap; the simulated detector sees the direct beam where the arm faces
     * the source (sim/effects_detector.h). */
    if (strcmp(spec, "beam") == 0)
        return brdf_material_new(&beam_ops, NULL, spec);
    if (strcmp(spec, "default") == 0) {
        const char *def = brdf_embedded_default_spec();
        return open_builtin(spec, def + strlen("builtin:"), err);
    }
    const char *colon = strchr(spec, ':');
    if (colon) {
        size_t klen = (size_t)(colon - spec);
        const char *arg = colon + 1;
        for (size_t i = 0; i < sizeof kinds / sizeof kinds[0]; i++) {
            if (strlen(kinds[i].kind) != klen || strncmp(spec, kinds[i].kind, klen) != 0)
                continue;
            if (!*arg) {
                gonio_err_set(err, GONIO_EBADCONFIG, "%s: missing name after '%s:'", spec,
                              kinds[i].kind);
                return NULL;
            }
            return kinds[i].open(spec, arg, err);
        }
    }
    gonio_err_set(err, GONIO_EBADCONFIG,
                  "%s: unknown material kind (use nbrdf:NAME, merl:PATH, abc:NAME, sgd:NAME, "
                  "builtin:NAME, spectral:NAME, analytic:NAME, standard:NAME, trap, beam "
                  "or default)",
                  spec);
    return NULL;
}
