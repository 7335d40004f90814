/* Reflectance standards: the certificate file, its shape, and the material
 * the simulator mounts in the sample's place (brdf/standard.h). */
#include "brdf/standard.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/colour.h"
#include "brdf/material_private.h"
#include "brdf/spectral_private.h"
#include "common/cfg.h"
#include "common/paths.h"

#define MAX_BANDS BRDF_STANDARD_MAX_NM
#define STD_PI 3.14159265358979323846

static int load_rgb(const struct cfg_doc *doc, const struct cfg_node *refl,
                    struct brdf_standard *s, struct gonio_err *err)
{
    double *v = NULL, *u = NULL;
    size_t nv = 0, nu = 0;
    int rc = cfg_doubles(doc, refl, "rgb", CFG_REQUIRED, 0.0, 1.5, 3, 3, &v, &nv, err);
    if (rc >= 0)
        rc = cfg_doubles(doc, refl, "u", CFG_REQUIRED, 0.0, 0.5, 3, 3, &u, &nu, err);
    if (rc >= 0)
        for (int c = 0; c < 3; c++)
            s->rho[c] = v[c], s->u_rho[c] = u[c];
    free(v);
    free(u);
    return rc < 0 ? rc : 0;
}

/* A spectral certificate becomes RGB the way the simulator's spectral
 * materials do (D65, CIE 1931, linear sRGB; brdf/colour.h). A certificate's
 * uncertainties are correlated across wavelengths (one calibration chain),
 * so u is converted as a spectrum too: the fully correlated bound. */
static int load_spectral(const struct cfg_doc *doc, const struct cfg_node *refl,
                         struct brdf_standard *s, struct gonio_err *err)
{
    double *nm = NULL, *v = NULL, *u = NULL;
    size_t nn = 0, nv = 0, nu = 0;
    int rc = cfg_doubles(doc, refl, "wavelength_nm", CFG_REQUIRED, 200.0, 3000.0, 2,
                         MAX_BANDS, &nm, &nn, err);
    if (rc >= 0)
        rc = cfg_doubles(doc, refl, "value", CFG_REQUIRED, 0.0, 1.5, nn, nn, &v, &nv, err);
    if (rc >= 0)
        rc = cfg_doubles(doc, refl, "u", CFG_REQUIRED, 0.0, 0.5, nn, nn, &u, &nu, err);
    for (size_t k = 1; rc >= 0 && k < nn; k++)
        if (!(nm[k] > nm[k - 1]))
            rc = cfg_error(doc, cfg_get(doc, refl, "wavelength_nm"), "wavelength_nm", err,
                           "not increasing at item %zu (value %g after %g)", k + 1, nm[k],
                           nm[k - 1]);
    double xyz[3];
    for (size_t k = 0; rc >= 0 && k < nn; k++)
        s->nm[k] = nm[k], s->rho_nm[k] = v[k], s->u_nm[k] = u[k];
    if (rc >= 0)
        s->n_nm = nn;
    if (rc >= 0)
        rc = brdf_colour_spectrum_to_xyz(nm, v, nn, xyz, err);
    if (rc >= 0) {
        brdf_colour_xyz_to_srgb_linear(xyz, s->rho);
        rc = brdf_colour_spectrum_to_xyz(nm, u, nn, xyz, err);
    }
    if (rc >= 0) {
        brdf_colour_xyz_to_srgb_linear(xyz, s->u_rho);
        for (int c = 0; c < 3; c++)
            s->u_rho[c] = fabs(s->u_rho[c]);
    }
    free(nm);
    free(v);
    free(u);
    return rc < 0 ? rc : 0;
}

static int load_reflectance(const struct cfg_doc *doc, const struct cfg_node *root,
                            struct brdf_standard *s, struct gonio_err *err)
{
    const struct cfg_node *refl = cfg_get(doc, root, "reflectance");
    if (!refl)
        return cfg_error(doc, root, "reflectance", err, "missing (rgb and u, or "
                         "wavelength_nm, value and u)");
    if (cfg_is_scalar(doc, refl)) {
        double rho;
        int rc = cfg_double(doc, root, "reflectance", CFG_REQUIRED, 0.0, 1.5, &rho, err);
        if (rc < 0)
            return rc;
        for (int c = 0; c < 3; c++)
            s->rho[c] = rho, s->u_rho[c] = 0.0;
        snprintf(s->warning, sizeof s->warning,
                 "standard %s is a bare reflectance %g: used as rho/pi with no uncertainty "
                 "and no angular shape (up to ~10 %% off at large angles)", s->name, rho);
        return 1; /* bare: no shape either */
    }
    static const char *const keys[] = {"rgb", "u", "wavelength_nm", "value", NULL};
    int rc = cfg_check_keys(doc, refl, "reflectance", keys, err);
    if (rc < 0)
        return rc;
    if (cfg_get(doc, refl, "rgb"))
        return load_rgb(doc, refl, s, err);
    return load_spectral(doc, refl, s, err);
}

static int load_grid(const struct cfg_doc *doc, const struct cfg_node *ang, const char *key,
                     double lo, double hi, double *out, size_t *n, struct gonio_err *err)
{
    double *v = NULL;
    int rc = cfg_doubles(doc, ang, key, CFG_REQUIRED, lo, hi, 1, BRDF_STANDARD_MAX_GRID, &v, n,
                         err);
    for (size_t k = 1; rc >= 0 && k < *n; k++)
        if (!(v[k] > v[k - 1]))
            rc = cfg_error(doc, cfg_get(doc, ang, key), key, err,
                           "not increasing at item %zu (value %g after %g)", k + 1, v[k],
                           v[k - 1]);
    if (rc >= 0)
        memcpy(out, v, *n * sizeof *v);
    free(v);
    return rc < 0 ? rc : 0;
}

static int load_shape(const struct cfg_doc *doc, const struct cfg_node *root,
                      struct brdf_standard *s, struct gonio_err *err)
{
    const struct cfg_node *ang = NULL;
    int rc = cfg_map(doc, root, "angular", CFG_OPTIONAL, &ang, err);
    if (rc < 0)
        return rc;
    if (!ang) {
        snprintf(s->warning, sizeof s->warning,
                 "standard %s has no angular shape: used as rho/pi (Lambertian), which costs "
                 "up to ~10 %% at large angles", s->name);
        return 0;
    }
    static const char *const keys[] = {"incidence_deg", "view_deg", "factor", "u", NULL};
    if ((rc = cfg_check_keys(doc, ang, "angular", keys, err)) < 0 ||
        (rc = load_grid(doc, ang, "incidence_deg", 0.0, 89.0, s->inc_deg, &s->n_inc, err)) < 0 ||
        (rc = load_grid(doc, ang, "view_deg", -89.0, 89.0, s->view_deg, &s->n_view, err)) < 0 ||
        (rc = cfg_double(doc, ang, "u", CFG_REQUIRED, 0.0, 0.5, &s->u_shape, err)) < 0)
        return rc;
    const struct cfg_node *rows = NULL;
    if ((rc = cfg_seq(doc, ang, "factor", CFG_REQUIRED, &rows, err)) < 0)
        return rc;
    if (cfg_seq_len(doc, rows) != s->n_inc)
        return cfg_error(doc, rows, "factor", err, "%zu rows, one per incidence angle (%zu) "
                         "expected", cfg_seq_len(doc, rows), s->n_inc);
    for (size_t i = 0; i < s->n_inc; i++) {
        const struct cfg_node *row = cfg_seq_item(doc, rows, i);
        if (!cfg_is_seq(doc, row) || cfg_seq_len(doc, row) != s->n_view)
            return cfg_error(doc, row, "factor", err, "row %zu: a list of %zu factors, one per "
                             "view angle, expected", i + 1, s->n_view);
        for (size_t j = 0; j < s->n_view; j++)
            if ((rc = cfg_node_double(doc, cfg_seq_item(doc, row, j), "factor", 0.2, 3.0,
                                      &s->shape[i][j], err)) < 0)
                return rc;
    }
    return 0;
}

int brdf_standard_load(const char *path_or_name, struct brdf_standard *out,
                       struct gonio_err *err)
{
    char path[4096];
    if (gonio_config_path(path_or_name, "standards", path, sizeof path) < 0)
        return gonio_err_set(err, ENAMETOOLONG, "standard %s: name too long", path_or_name);
    struct cfg_doc *doc = NULL;
    int rc = cfg_load(path, &doc, err);
    if (rc < 0)
        return rc;
    memset(out, 0, sizeof *out);
    const struct cfg_node *root = cfg_root(doc);
    static const char *const keys[] = {"name", "description", "certificate", "reflectance",
                                       "angular", NULL};
    const char *name = NULL, *cert = NULL;
    if ((rc = cfg_check_keys(doc, root, "standard", keys, err)) < 0 ||
        (rc = cfg_string(doc, root, "name", CFG_REQUIRED, &name, err)) < 0 ||
        (rc = cfg_string(doc, root, "certificate", CFG_REQUIRED, &cert, err)) < 0)
        goto done;
    snprintf(out->name, sizeof out->name, "%s", name);
    snprintf(out->certificate, sizeof out->certificate, "%s", cert);
    if ((rc = load_reflectance(doc, root, out, err)) < 0)
        goto done;
    if (rc == 1 && cfg_get(doc, root, "angular")) {
        rc = cfg_error(doc, cfg_get(doc, root, "angular"), "angular", err,
                       "a bare reflectance has no shape: give reflectance as rgb and u");
        goto done;
    }
    rc = rc == 1 ? 0 : load_shape(doc, root, out, err);
done:
    cfg_free(doc);
    return rc < 0 ? rc : 0;
}

/* Index k and weight t of x on an increasing grid, held at the ends. */
static void locate(const double *g, size_t n, double x, size_t *k, double *t)
{
    if (n < 2 || x <= g[0]) {
        *k = 0, *t = 0.0;
        return;
    }
    if (x >= g[n - 1]) {
        *k = n - 2, *t = 1.0;
        return;
    }
    size_t i = 0;
    while (i + 2 < n && x > g[i + 1])
        i++;
    *k = i, *t = (x - g[i]) / (g[i + 1] - g[i]);
}

double brdf_standard_shape(const struct brdf_standard *s, double theta_i_deg,
                           double theta_r_deg)
{
    if (s->n_inc == 0)
        return 1.0;
    size_t i, j;
    double ti, tj;
    locate(s->inc_deg, s->n_inc, fabs(theta_i_deg), &i, &ti);
    locate(s->view_deg, s->n_view, theta_r_deg, &j, &tj);
    size_t i1 = s->n_inc > 1 ? i + 1 : i, j1 = s->n_view > 1 ? j + 1 : j;
    double a = s->shape[i][j] * (1 - tj) + s->shape[i][j1] * tj;
    double b = s->shape[i1][j] * (1 - tj) + s->shape[i1][j1] * tj;
    return a * (1 - ti) + b * ti;
}

void brdf_standard_brdf(const struct brdf_standard *s, double theta_i_deg, double theta_r_deg,
                        double rgb[3])
{
    double f = brdf_standard_shape(s, theta_i_deg, theta_r_deg) / STD_PI;
    for (int c = 0; c < 3; c++)
        rgb[c] = s->rho[c] * f;
}

void brdf_standard_as_lambertian(struct brdf_standard *s)
{
    s->n_inc = s->n_view = 0;
    s->u_shape = 0.0;
}

/* The in-plane angles the shape is read at for a pair; 0 below the
 * horizon (no light). */
static int pair_angles(const struct brdf_pair *p, double *ti, double *tr)
{
    if (p->wi[2] <= 0.0 || p->wo[2] <= 0.0)
        return 0;
    if (brdf_pair_to_inplane(p, ti, tr) < 0) {
        /* Out of plane: the polar angles, on the mirror side when the
         * two directions' azimuths are more than 90 deg apart. */
        *ti = brdf_pair_theta_i_deg(p);
        double to = brdf_pair_theta_o_deg(p);
        double dot = p->wi[0] * p->wo[0] + p->wi[1] * p->wo[1];
        *tr = dot < 0.0 ? to : -to;
    }
    return 1;
}

static void standard_eval(const void *priv, const struct brdf_pair *pairs, size_t n, double *rgb)
{
    const struct brdf_standard *s = priv;
    for (size_t k = 0; k < n; k++) {
        double ti, tr;
        if (!pair_angles(&pairs[k], &ti, &tr)) {
            rgb[3 * k] = rgb[3 * k + 1] = rgb[3 * k + 2] = 0.0;
            continue;
        }
        brdf_standard_brdf(s, ti, tr, &rgb[3 * k]);
    }
}

void brdf_standard_rho_at(const struct brdf_standard *s, double nm, double *rho, double *u)
{
    if (s->n_nm == 0) {
        brdf_spectral_from_rgb(s->rho, &nm, 1, rho);
        brdf_spectral_from_rgb(s->u_rho, &nm, 1, u);
        *u = fabs(*u);
        return;
    }
    size_t k;
    double t;
    locate(s->nm, s->n_nm, nm, &k, &t);
    size_t k1 = s->n_nm > 1 ? k + 1 : k;
    *rho = s->rho_nm[k] * (1 - t) + s->rho_nm[k1] * t;
    *u = s->u_nm[k] * (1 - t) + s->u_nm[k1] * t;
}

static void standard_spectral_eval(const void *priv, const struct brdf_pair *p,
                                   const double *lambda_nm, size_t n, double *out)
{
    const struct brdf_standard *s = priv;
    double ti, tr;
    int lit = pair_angles(p, &ti, &tr);
    double f = lit ? brdf_standard_shape(s, ti, tr) / STD_PI : 0.0;
    for (size_t k = 0; k < n; k++) {
        double rho, u;
        brdf_standard_rho_at(s, lambda_nm[k], &rho, &u);
        out[k] = rho * f;
    }
}

static const struct brdf_spectral_ops standard_spectral_ops = {
    .kind = "standard", .eval = standard_spectral_eval, .free_priv = free,
};

brdf_spectral *brdf_standard_spectral(const struct brdf_standard *s, const char *spec,
                                      struct gonio_err *err)
{
    struct brdf_standard *copy = malloc(sizeof *copy);
    if (!copy) {
        gonio_err_set(err, ENOMEM, "%s: out of memory", spec);
        return NULL;
    }
    *copy = *s;
    /* defined everywhere: beyond a certificate's rows its ends hold */
    brdf_spectral *m = brdf_spectral_new(&standard_spectral_ops, copy, spec, 200.0, 3000.0);
    if (!m)
        gonio_err_set(err, ENOMEM, "%s: out of memory", spec);
    return m;
}

static const struct brdf_material_ops standard_ops = {
    .kind = "standard", .eval = standard_eval, .free_priv = free,
};

brdf_material *brdf_standard_material(const struct brdf_standard *s, const char *spec,
                                      struct gonio_err *err)
{
    struct brdf_standard *copy = malloc(sizeof *copy);
    if (!copy) {
        gonio_err_set(err, ENOMEM, "%s: out of memory", spec);
        return NULL;
    }
    *copy = *s;
    brdf_material *m = brdf_material_new(&standard_ops, copy, spec);
    if (!m)
        gonio_err_set(err, ENOMEM, "%s: out of memory", spec);
    return m;
}
