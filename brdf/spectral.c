/* The spectral material interface, the RGB lift and the RGB view. */
#include "brdf/spectral.h"

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <gsl/gsl_linalg.h>

#include "brdf/colour.h"
#include "brdf/material_private.h"
#include "brdf/spectral_private.h"

/* DESIGN.md's XYZ -> linear sRGB matrix (brdf/colour.h applies it too). */
static void xyz_to_rgb_row(const double xyz[3], double rgb[3])
{
    brdf_colour_xyz_to_srgb_linear(xyz, rgb);
}

int brdf_spectral_rgb_weights(const double *lambda_nm, size_t n, double *w,
                              struct gonio_err *err)
{
    int rc = brdf_colour_weights(lambda_nm, n, w, err);
    if (rc < 0)
        return rc;
    for (size_t k = 0; k < n; k++) {
        double rgb[3];
        xyz_to_rgb_row(w + 3 * k, rgb); /* linear: the matrix applies per band */
        memcpy(w + 3 * k, rgb, sizeof rgb);
    }
    return 0;
}

static double logistic(double x)
{
    return 1.0 / (1.0 + exp(-x));
}

void brdf_spectral_basis(double lambda_nm, double b[3])
{
    b[0] = 1.0 - logistic((lambda_nm - 490.0) / 15.0);
    b[2] = logistic((lambda_nm - 590.0) / 15.0);
    b[1] = 1.0 - b[0] - b[2];
}

/* M^-1, with M[c][j] the linear sRGB channel c of basis j on the 5 nm CIE
 * grid; computed once (the tables are constant), thread-safely since
 * goniod captures on a worker thread. */
static double lift_inverse[3][3];
static pthread_once_t lift_once = PTHREAD_ONCE_INIT;

static void lift_compute(void)
{
    double lambda[BRDF_CIE_COUNT], w[3 * BRDF_CIE_COUNT];
    for (int k = 0; k < BRDF_CIE_COUNT; k++)
        lambda[k] = BRDF_CIE_FIRST_NM + BRDF_CIE_STEP_NM * k;
    brdf_spectral_rgb_weights(lambda, BRDF_CIE_COUNT, w, NULL);
    double m[9] = {0}, inv[9];
    for (int k = 0; k < BRDF_CIE_COUNT; k++) {
        double b[3];
        brdf_spectral_basis(lambda[k], b);
        for (int c = 0; c < 3; c++)
            for (int j = 0; j < 3; j++)
                m[3 * c + j] += w[3 * k + c] * b[j];
    }
    gsl_matrix_view mv = gsl_matrix_view_array(m, 3, 3);
    gsl_matrix_view iv = gsl_matrix_view_array(inv, 3, 3);
    gsl_permutation *perm = gsl_permutation_alloc(3);
    int sign;
    gsl_linalg_LU_decomp(&mv.matrix, perm, &sign);
    gsl_linalg_LU_invert(&mv.matrix, perm, &iv.matrix);
    gsl_permutation_free(perm);
    for (int i = 0; i < 9; i++)
        lift_inverse[i / 3][i % 3] = inv[i];
}

static void lift_init(void)
{
    pthread_once(&lift_once, lift_compute);
}

void brdf_spectral_from_rgb(const double rgb[3], const double *lambda_nm, size_t n, double *out)
{
    lift_init();
    double c[3];
    for (int j = 0; j < 3; j++)
        c[j] = lift_inverse[j][0] * rgb[0] + lift_inverse[j][1] * rgb[1] +
               lift_inverse[j][2] * rgb[2];
    for (size_t k = 0; k < n; k++) {
        double b[3];
        brdf_spectral_basis(lambda_nm[k], b);
        out[k] = c[0] * b[0] + c[1] * b[1] + c[2] * b[2];
    }
}

/* ---- the interface ------------------------------------------------------- */

brdf_spectral *brdf_spectral_new(const struct brdf_spectral_ops *ops, void *priv,
                                 const char *name, double lo_nm, double hi_nm)
{
    brdf_spectral *m = calloc(1, sizeof *m);
    if (!m) {
        if (ops->free_priv)
            ops->free_priv(priv);
        return NULL;
    }
    m->ops = ops;
    m->priv = priv;
    m->lo_nm = lo_nm;
    m->hi_nm = hi_nm;
    snprintf(m->name, sizeof m->name, "%s", name);
    return m;
}

void brdf_spectral_eval(const brdf_spectral *m, const struct brdf_pair *p,
                        const double *lambda_nm, size_t n, double *out)
{
    m->ops->eval(m->priv, p, lambda_nm, n, out);
}

void brdf_spectral_range(const brdf_spectral *m, double *lo_nm, double *hi_nm)
{
    *lo_nm = m->lo_nm;
    *hi_nm = m->hi_nm;
}

const char *brdf_spectral_name(const brdf_spectral *m)
{
    return m->name;
}

void brdf_spectral_free(brdf_spectral *m)
{
    if (!m)
        return;
    if (m->ops->free_priv)
        m->ops->free_priv(m->priv);
    free(m);
}

/* ---- the lift ------------------------------------------------------------ */

static void lift_eval(const void *priv, const struct brdf_pair *p, const double *lambda_nm,
                      size_t n, double *out)
{
    double rgb[3];
    brdf_material_eval(priv, p, 1, rgb);
    brdf_spectral_from_rgb(rgb, lambda_nm, n, out);
}

static const struct brdf_spectral_ops lift_ops = {.kind = "lift", .eval = lift_eval};

brdf_spectral *brdf_spectral_lift(const brdf_material *rgb, struct gonio_err *err)
{
    char name[600];
    snprintf(name, sizeof name, "lift:%s", brdf_material_name(rgb));
    brdf_spectral *m = brdf_spectral_new(&lift_ops, (void *)rgb, name, BRDF_CIE_FIRST_NM,
                                         BRDF_CIE_FIRST_NM + BRDF_CIE_STEP_NM *
                                                                 (BRDF_CIE_COUNT - 1));
    if (!m)
        gonio_err_set(err, ENOMEM, "%s: out of memory", name);
    return m;
}

/* ---- the RGB view -------------------------------------------------------- */

#define VIEW_BANDS 31

struct rgb_view {
    brdf_spectral *m;
    double lambda[VIEW_BANDS];
    double w[3 * VIEW_BANDS];
};

static void view_eval(const void *priv, const struct brdf_pair *pairs, size_t n, double *rgb)
{
    const struct rgb_view *v = priv;
    double s[VIEW_BANDS];
    for (size_t i = 0; i < n; i++) {
        brdf_spectral_eval(v->m, &pairs[i], v->lambda, VIEW_BANDS, s);
        double c[3] = {0, 0, 0};
        for (int k = 0; k < VIEW_BANDS; k++)
            for (int j = 0; j < 3; j++)
                c[j] += v->w[3 * k + j] * s[k];
        memcpy(rgb + 3 * i, c, sizeof c);
    }
}

static void view_free(void *priv)
{
    struct rgb_view *v = priv;
    brdf_spectral_free(v->m);
    free(v);
}

static const struct brdf_material_ops view_ops = {
    .kind = "spectral", .eval = view_eval, .free_priv = view_free};

brdf_material *brdf_spectral_material_open(const char *spec, struct gonio_err *err)
{
    brdf_spectral *m = brdf_spectral_open(spec, err);
    if (!m)
        return NULL;
    struct rgb_view *v = malloc(sizeof *v);
    if (!v) {
        brdf_spectral_free(m);
        gonio_err_set(err, ENOMEM, "%s: out of memory", spec);
        return NULL;
    }
    v->m = m;
    for (int k = 0; k < VIEW_BANDS; k++)
        v->lambda[k] = 400 + 10 * k;
    brdf_spectral_rgb_weights(v->lambda, VIEW_BANDS, v->w, NULL);
    brdf_material *out = brdf_material_new(&view_ops, v, spec);
    if (!out)
        gonio_err_set(err, ENOMEM, "%s: out of memory", spec);
    return out;
}
