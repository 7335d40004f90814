/* The parametric analytic materials' spec parser (brdf/analytic_spec.h):
 * one table of parameters per kind, each with its range and default, so
 * that every error names the parameter and the value it refused. */
#include "brdf/analytic_spec.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/material_private.h"

#define MAX_PARAMS 8

struct param {
    const char *key;
    int rgb;        /* 1: one value or R:G:B */
    int required;
    double min, max, def;
};

struct kind {
    const char *name;
    struct param params[MAX_PARAMS];
};

static const struct kind aniso_kind = {
    "aniso-ggx",
    {{"ax", 0, 1, 0.001, 1, 0},
     {"ay", 0, 1, 0.001, 1, 0},
     {"phi", 0, 0, -360, 360, 0},
     {"rho_d", 1, 0, 0, 1, 0.05},
     {"f0", 1, 0, 0, 1, 0.9},
     {NULL, 0, 0, 0, 0, 0}}};

static const struct kind two_lobe_kind = {
    "two-lobe",
    {{"a1", 0, 1, 0.001, 1, 0},
     {"w1", 0, 1, 0, 10, 0},
     {"a2", 0, 1, 0.001, 1, 0},
     {"w2", 0, 1, 0, 10, 0},
     {"rho_d", 1, 0, 0, 1, 0.1},
     {"eta", 0, 0, 1.01, 4, 1.5},
     {NULL, 0, 0, 0, 0, 0}}};

static const struct kind *const kinds[] = {&aniso_kind, &two_lobe_kind};

static const struct kind *kind_of(const char *name)
{
    size_t n = strcspn(name, "?");
    for (size_t i = 0; i < sizeof kinds / sizeof *kinds; i++)
        if (strlen(kinds[i]->name) == n && !strncmp(name, kinds[i]->name, n))
            return kinds[i];
    return NULL;
}

int brdf_analytic_spec_is_parametric(const char *name)
{
    return kind_of(name) != NULL;
}

static void key_list(const struct kind *k, char *buf, size_t size)
{
    size_t len = 0;
    buf[0] = '\0';
    for (int i = 0; k->params[i].key && len < size; i++)
        len += (size_t)snprintf(buf + len, size - len, "%s%s", i ? ", " : "",
                                k->params[i].key);
}

/* One number of a value, whole token [s, end) consumed. */
static int number(const char *s, const char *end, double *v)
{
    char buf[64];
    size_t n = (size_t)(end - s);
    if (n == 0 || n >= sizeof buf)
        return -1;
    memcpy(buf, s, n);
    buf[n] = '\0';
    char *stop;
    errno = 0;
    *v = strtod(buf, &stop);
    return *stop || errno || !isfinite(*v) ? -1 : 0;
}

static int value(const char *spec, const struct param *p, const char *s, const char *end,
                 double out[3], struct gonio_err *err)
{
    int n = 0;
    const char *t = s;
    for (;;) {
        const char *sep = p->rgb ? memchr(t, ':', (size_t)(end - t)) : NULL;
        const char *stop = sep ? sep : end;
        if (n == 3 || number(t, stop, &out[n]) < 0 || out[n] < p->min || out[n] > p->max)
            return gonio_err_set(err, GONIO_EBADCONFIG,
                                 "%s: parameter '%s': value '%.*s' is not %s in %g..%g", spec,
                                 p->key, (int)(end - s), s,
                                 p->rgb ? "one number or R:G:B" : "a number", p->min, p->max);
        n++;
        if (!sep)
            break;
        t = sep + 1;
    }
    if (n == 2)
        return gonio_err_set(err, GONIO_EBADCONFIG,
                             "%s: parameter '%s': value '%.*s' is not one number or R:G:B",
                             spec, p->key, (int)(end - s), s);
    if (n == 1)
        out[1] = out[2] = out[0];
    return 0;
}

/* Parse name's parameters of kind k into vals[i][3], in the table's order. */
static int parse(const char *spec, const char *name, const struct kind *k,
                 double vals[MAX_PARAMS][3], struct gonio_err *err)
{
    int seen[MAX_PARAMS] = {0};
    char keys[128];
    key_list(k, keys, sizeof keys);
    const char *q = strchr(name, '?');
    for (const char *s = q ? q + 1 : NULL; s && *s;) {
        const char *end = s + strcspn(s, "&");
        const char *eq = memchr(s, '=', (size_t)(end - s));
        int i = 0;
        size_t klen = (size_t)((eq ? eq : end) - s);
        while (k->params[i].key &&
               (strlen(k->params[i].key) != klen || strncmp(s, k->params[i].key, klen)))
            i++;
        if (!k->params[i].key)
            return gonio_err_set(err, GONIO_EBADCONFIG,
                                 "%s: parameter '%.*s' unknown (%s takes %s)", spec, (int)klen,
                                 s, k->name, keys);
        if (!eq)
            return gonio_err_set(err, GONIO_EBADCONFIG, "%s: parameter '%s' has no value "
                                 "(write %s=VALUE)", spec, k->params[i].key, k->params[i].key);
        if (seen[i]++)
            return gonio_err_set(err, GONIO_EBADCONFIG, "%s: parameter '%s' given twice", spec,
                                 k->params[i].key);
        int rc = value(spec, &k->params[i], eq + 1, end, vals[i], err);
        if (rc < 0)
            return rc;
        s = *end ? end + 1 : end;
    }
    for (int i = 0; k->params[i].key; i++) {
        if (seen[i])
            continue;
        if (k->params[i].required)
            return gonio_err_set(err, GONIO_EBADCONFIG, "%s: parameter '%s' missing (%s requires "
                                 "it; takes %s)", spec, k->params[i].key, k->name, keys);
        vals[i][0] = vals[i][1] = vals[i][2] = k->params[i].def;
    }
    return 0;
}

int brdf_analytic_spec_aniso(const char *spec, const char *name, struct brdf_aniso_ggx *out,
                             struct gonio_err *err)
{
    double v[MAX_PARAMS][3];
    if (kind_of(name) != &aniso_kind)
        return gonio_err_set(err, GONIO_EBADCONFIG, "%s: not an aniso-ggx material", spec);
    int rc = parse(spec, name, &aniso_kind, v, err);
    if (rc < 0)
        return rc;
    *out = (struct brdf_aniso_ggx){.ax = v[0][0], .ay = v[1][0], .phi_deg = v[2][0]};
    memcpy(out->rho, v[3], sizeof out->rho);
    memcpy(out->f0, v[4], sizeof out->f0);
    return 0;
}

int brdf_analytic_spec_two_lobe(const char *spec, const char *name, struct brdf_analytic *out,
                                struct gonio_err *err)
{
    double v[MAX_PARAMS][3];
    if (kind_of(name) != &two_lobe_kind)
        return gonio_err_set(err, GONIO_EBADCONFIG, "%s: not a two-lobe material", spec);
    int rc = parse(spec, name, &two_lobe_kind, v, err);
    if (rc < 0)
        return rc;
    *out = (struct brdf_analytic){.name = "two-lobe",
                                  .summary = "Lambert base and two isotropic GGX lobes",
                                  .eta = v[5][0],
                                  .lobes = 2,
                                  .alpha = {v[0][0], v[2][0]},
                                  .weight = {v[1][0], v[3][0]}};
    memcpy(out->rho, v[4], sizeof out->rho);
    return 0;
}

static void two_lobe_material_eval(const void *priv, const struct brdf_pair *pairs, size_t n,
                                   double *rgb)
{
    for (size_t i = 0; i < n; i++)
        brdf_analytic_eval(priv, &pairs[i], rgb + 3 * i);
}

static const struct brdf_material_ops two_lobe_ops = {
    .kind = "analytic",
    .eval = two_lobe_material_eval,
    .free_priv = free,
};

brdf_material *brdf_analytic_spec_open(const char *spec, const char *name,
                                       struct gonio_err *err)
{
    const struct kind *k = kind_of(name);
    brdf_material *m = NULL;
    if (k == &aniso_kind) {
        struct brdf_aniso_ggx a;
        if (brdf_analytic_spec_aniso(spec, name, &a, err) < 0)
            return NULL;
        m = brdf_aniso_ggx_material(&a, spec);
    } else if (k == &two_lobe_kind) {
        struct brdf_analytic *a = malloc(sizeof *a);
        if (a && brdf_analytic_spec_two_lobe(spec, name, a, err) < 0) {
            free(a);
            return NULL;
        }
        m = a ? brdf_material_new(&two_lobe_ops, a, spec) : NULL;
    } else {
        gonio_err_set(err, GONIO_EBADCONFIG, "%s: not a parametric analytic material", spec);
        return NULL;
    }
    if (!m)
        gonio_err_set(err, ENOMEM, "%s: out of memory", spec);
    return m;
}
