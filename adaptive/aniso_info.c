/* The aniso-ggx posterior of the adaptive policy (adaptive/aniso_info.h). */
#include "adaptive/aniso_info.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_linalg.h>

#include "brdf/analytic_aniso.h"
#include "fit/aniso_ggx_model.h"

#define NPAR ANISO_INFO_NPAR
/* The step of the forward differences, in the fit's coordinates. */
#define STEP 1e-5

void aniso_info_init(struct aniso_info *ai)
{
    memset(ai, 0, sizeof *ai);
}

static double value(const double *x, const struct brdf_pair *p)
{
    struct brdf_aniso_ggx a;
    double rgb[3];
    fit_aniso_ggx_to_params(x, &a);
    brdf_aniso_ggx_eval(&a, p, rgb);
    double v = 0;
    for (int k = 0; k < 3; k++)
        v += log1p(fmax(rgb[k] * p->wi[2], 0));
    return v / 3;
}

/* dv/dx at p, into g. */
static void gradient(const double *x, const struct brdf_pair *p, double g[NPAR])
{
    double v0 = value(x, p), y[NPAR];
    memcpy(y, x, sizeof y);
    for (int j = 0; j < NPAR; j++) {
        y[j] = x[j] + STEP;
        g[j] = (value(y, p) - v0) / STEP;
        y[j] = x[j];
    }
}

/* cov = (sum g g^T / s2 + I / prior^2)^-1 over the usable samples. */
static int posterior(struct aniso_info *ai, const struct fit_sample *s, size_t n)
{
    double f[NPAR * NPAR] = {0}, g[NPAR];
    for (size_t i = 0; i < n; i++) {
        if (!fit_aniso_ggx_usable(&s[i]))
            continue;
        gradient(ai->x, &s[i].g, g);
        for (int j = 0; j < NPAR; j++)
            for (int k = 0; k < NPAR; k++)
                f[j * NPAR + k] += g[j] * g[k] / ai->s2;
    }
    for (int j = 0; j < NPAR; j++)
        f[j * NPAR + j] += 1 / (ANISO_INFO_PRIOR_SD * ANISO_INFO_PRIOR_SD);
    gsl_matrix_view fv = gsl_matrix_view_array(f, NPAR, NPAR);
    if (gsl_linalg_cholesky_decomp1(&fv.matrix) != GSL_SUCCESS ||
        gsl_linalg_cholesky_invert(&fv.matrix) != GSL_SUCCESS)
        return -GONIO_EFIT;
    memcpy(ai->cov, f, sizeof ai->cov);
    return 0;
}

int aniso_info_update(struct aniso_info *ai, const struct fit_sample *s, size_t n)
{
    gsl_set_error_handler_off();
    int cold = !ai->ok || n >= 2 * ai->cold_n;
    double x[NPAR], rms;
    memcpy(x, ai->x, sizeof x);
    int rc = fit_aniso_ggx_solve(s, n, cold, x, &rms);
    if (rc == 0) {
        memcpy(ai->x, x, sizeof x);
        ai->s2 = fmax(rms * rms, ANISO_INFO_NOISE_FLOOR * ANISO_INFO_NOISE_FLOOR);
        ai->cold_n = cold ? n : ai->cold_n;
        rc = posterior(ai, s, n);
    }
    ai->ok = rc == 0;
    return rc;
}

double aniso_info_domain(struct aniso_info *ai, const struct brdf_pair *pairs, size_t n)
{
    double sd = 0, mg[NPAR][NPAR] = {{0}};
    for (size_t i = 0; i < n; i++) {
        double g[NPAR], v = 0;
        gradient(ai->x, &pairs[i], g);
        for (int j = 0; j < NPAR; j++)
            for (int k = 0; k < NPAR; k++) {
                mg[j][k] += g[j] * g[k] / (double)n;
                v += g[j] * ai->cov[j][k] * g[k];
            }
        sd += sqrt(fmax(v, 0));
    }
    double t[NPAR][NPAR] = {{0}};
    for (int j = 0; j < NPAR; j++)
        for (int k = 0; k < NPAR; k++)
            for (int l = 0; l < NPAR; l++)
                t[j][k] += ai->cov[j][l] * mg[l][k];
    for (int j = 0; j < NPAR; j++)
        for (int k = 0; k < NPAR; k++) {
            ai->dom[j][k] = 0;
            for (int l = 0; l < NPAR; l++)
                ai->dom[j][k] += t[j][l] * ai->cov[l][k];
        }
    return n ? sd / (double)n : 0;
}

double aniso_info_alc(const struct aniso_info *ai, const struct brdf_pair *p)
{
    double g[NPAR], q = 0, v = 0;
    gradient(ai->x, p, g);
    for (int j = 0; j < NPAR; j++)
        for (int k = 0; k < NPAR; k++) {
            q += g[j] * ai->dom[j][k] * g[k];
            v += g[j] * ai->cov[j][k] * g[k];
        }
    return q / (ai->s2 + fmax(v, 0));
}
