/* The ABC fit's uncertainties at its optimum (fit/abc_covariance.h): the
 * parameter covariance from the root of J^T J (abc_jacobian_root), the
 * sandwich of a weighted fit, and what the covariance means for the
 * predicted BRDF. */
#include "fit/abc_covariance.h"

#include <math.h>
#include <pthread.h>
#include <stdlib.h>

#include <gsl/gsl_blas.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_matrix.h>
#include <gsl/gsl_multifit_nlinear.h>

/* The in-plane grid of predictive_sd (theta_i 0..80 step 10, theta_r
 * -80..80 step 4, blind zone 5 degrees; its first 153 pairs), built once
 * per process: the same for every fit. */
#define PRED_GRID_MAX (17 * 9)
static struct fit_sample pred_grid[PRED_GRID_MAX];
static size_t pred_grid_n;
static pthread_once_t pred_grid_once = PTHREAD_ONCE_INIT;

static void pred_grid_build(void)
{
    size_t n = 0;
    for (int i = 0; i <= 8; i++)
        for (int r = -20; r <= 20; r++) {
            double ti = 10.0 * i, tr = 4.0 * r;
            if (fabs(ti + tr) < 5 || n >= PRED_GRID_MAX)
                continue;
            brdf_pair_inplane(ti, tr, &pred_grid[n].g);
            pred_grid[n].rgb[0] = pred_grid[n].rgb[1] = pred_grid[n].rgb[2] = 0;
            n++;
        }
    pred_grid_n = n;
}

/* Mean over the in-plane grid (pred_grid) and the channels of the standard
 * deviation of the predicted log(1 + f cos theta_i): g^T cov g with g its
 * gradient in theta. Parameters GSL found undetermined have zero
 * covariance and add nothing: they do not move the prediction. */
static double predictive_sd(const double th[ABC_NPAR], double c[ABC_NPAR][ABC_NPAR])
{
    pthread_once(&pred_grid_once, pred_grid_build);
    size_t n = pred_grid_n;
    struct abc_problem pb;
    double *J = malloc(3 * n * ABC_NPAR * sizeof *J);
    if (!J || abc_problem_init(&pb, pred_grid, NULL, n) < 0) {
        free(J);
        return NAN;
    }
    abc_problem_eval(&pb, th, NULL, J);
    double sum = 0;
    for (size_t row = 0; row < 3 * n; row++) {
        const double *g = J + row * ABC_NPAR;
        /* a row has 5 non-zeros; the zero terms add nothing (c is finite) */
        int nz[ABC_NPAR], m = 0;
        for (int a = 0; a < ABC_NPAR; a++)
            if (g[a] != 0)
                nz[m++] = a;
        double v = 0;
        for (int i = 0; i < m; i++)
            for (int j = 0; j < m; j++)
                v += g[nz[i]] * c[nz[i]][nz[j]] * g[nz[j]];
        sum += sqrt(fmax(v, 0.0));
    }
    abc_problem_free(&pb);
    free(J);
    return sum / (double)(3 * n);
}

/* The residual variance of a fit of cost (half the sum of squared, weighted
 * residuals) over pb's rows: their mean square with ABC_NPAR degrees of
 * freedom spent. Weighted rows count as Kish's effective number,
 * (sum w)^2 / sum w^2, all of them when the weights are equal: samples of
 * weight 0 add nothing to what the residuals can tell. NAN for no more
 * (effective) rows than parameters. */
double abc_residual_variance(const struct abc_problem *pb, double cost)
{
    double rows = 3.0 * (double)pb->n;
    if (!pb->sw)
        return rows > ABC_NPAR ? 2.0 * cost / (rows - ABC_NPAR) : NAN;
    double sw = 0, sw2 = 0;
    for (size_t k = 0; k < pb->n; k++) {
        double w = pb->sw[k] * pb->sw[k];
        sw += w;
        sw2 += w * w;
    }
    double eff = sw2 > 0 ? 3.0 * sw * sw / sw2 : 0;
    return eff > ABC_NPAR ? 2.0 * cost / (3.0 * sw) * eff / (eff - ABC_NPAR) : NAN;
}

/* A weighted fit's covariance, up to s2: the sandwich H^-1 (J^T W^2 J)
 * H^-1 with hinv = H^-1 = (J^T W J)^-1, into hinv. J^T W^2 J (with the
 * prior's rows, as in H) is the Gram matrix of pb's Jacobian with its rows
 * scaled by the weights themselves instead of their square roots. Returns
 * 0, -1 on no memory. */
static int sandwich(const struct abc_problem *pb, const double th[ABC_NPAR], gsl_matrix *hinv)
{
    struct abc_problem sq = *pb;
    double K[(15 + ABC_NPAR) * ABC_NPAR], cn[ABC_NPAR];
    double *w = malloc((pb->n ? pb->n : 1) * sizeof *w);
    if (!w)
        return -1;
    for (size_t k = 0; k < pb->n; k++)
        w[k] = pb->sw[k] * pb->sw[k];
    sq.sw = w;
    size_t nk = abc_jacobian_root(&sq, th, K, cn);
    free(w);
    gsl_matrix *meat = gsl_matrix_alloc(ABC_NPAR, ABC_NPAR);
    gsl_matrix *half = gsl_matrix_alloc(ABC_NPAR, ABC_NPAR);
    int rc = nk && meat && half ? 0 : -1;
    if (rc == 0) {
        gsl_matrix_const_view Kv = gsl_matrix_const_view_array(K, nk, ABC_NPAR);
        gsl_blas_dgemm(CblasTrans, CblasNoTrans, 1.0, &Kv.matrix, &Kv.matrix, 0.0, meat);
        gsl_blas_dgemm(CblasNoTrans, CblasNoTrans, 1.0, hinv, meat, 0.0, half);
        gsl_blas_dgemm(CblasNoTrans, CblasNoTrans, 1.0, half, hinv, 0.0, meat);
        gsl_matrix_memcpy(hinv, meat);
    }
    gsl_matrix_free(meat);
    gsl_matrix_free(half);
    return rc;
}

/* The shift of theta per unit relative scale error s of channel ch's
 * values (f -> f (1 + s)), to first order: d theta / ds = H^-1 J~^T (w dr/df f), J~
 * the weighted Jacobian, w each row's weight root, H^-1 = hinv (before any
 * sandwich). A parameter the scale moves (kd, A: their logs by about 1) has
 * a component; the lobe's shape (B, C, eta) next to none where f cos << 1.
 * Returns 0, -1 on no memory. */
static int scale_shift(const struct abc_problem *pb, const double th[ABC_NPAR],
                       const gsl_matrix *hinv, int ch, double g[ABC_NPAR])
{
    size_t nres = abc_problem_nres(pb);
    double *v = calloc(nres ? nres : 1, sizeof *v);
    struct abc_cache c;
    if (!v || abc_cache_init(&c, pb) < 0) {
        free(v);
        return -1;
    }
    for (size_t k = 0; k < pb->n; k++) {
        size_t row = 3 * k + (size_t)ch;
        double ci = pb->cosi[k];
        double slope = pb->loss == FIT_LOSS_LOG ? ci / (1.0 + pb->f[row] * ci) : pb->s[row];
        v[row] = abc_row_weight(pb, k, ch) * slope * pb->f[row];
    }
    double jv[ABC_NPAR];
    abc_problem_normal(pb, th, 1, v, jv, NULL, &c);
    abc_cache_free(&c);
    free(v);
    for (int i = 0; i < ABC_NPAR; i++) {
        g[i] = 0;
        for (int j = 0; j < ABC_NPAR; j++)
            g[i] += gsl_matrix_get(hinv, (size_t)i, (size_t)j) * jv[j];
    }
    return 0;
}

/* Parameter standard deviations at theta: covariance s2 (J^T J)^-1 from
 * GSL, mapped to natural units. Weighted samples (pb->sw) are not weighted
 * by their precision but by the share of the domain they stand for, and a
 * sample standing for more of it is no less noisy: their covariance is the
 * sandwich s2 H^-1 (J^T W^2 J) H^-1, H = J^T W J, which the equal weights
 * of an unweighted fit reduce to s2 (J^T J)^-1 (importance weights
 * inflate the variance by about mean(w^2), Kish's design effect). A
 * parameter whose column of J is zero (clamped, or without influence) is
 * undetermined: INFINITY. K (nk rows) and cn: the root of J^T J at theta
 * (abc_jacobian_root). */
void abc_uncertainty(const struct abc_problem *pb, const double th[ABC_NPAR], double s2,
                     const double u_sys[3], const double *K, size_t nk, const double cn[ABC_NPAR],
                     struct fit_uncertainty *u)
{
    double *sd = (double *)u; /* 10 doubles in the order of the struct */
    for (int i = 0; i < 10; i++)
        sd[i] = NAN;
    if (!isfinite(s2))
        return;
    gsl_matrix *cov = gsl_matrix_alloc(ABC_NPAR, ABC_NPAR);
    if (!cov || nk < ABC_NPAR)
        goto done;
    gsl_matrix_const_view Kv = gsl_matrix_const_view_array(K, nk, ABC_NPAR);
    if (gsl_multifit_nlinear_covar(&Kv.matrix, 1e-12, cov) != GSL_SUCCESS)
        goto done;
    /* GSL zeroes the rows and columns of the parameters it found dependent */
    double c[ABC_NPAR][ABC_NPAR];
    int undet[ABC_NPAR];
    for (int i = 0; i < ABC_NPAR; i++)
        undet[i] = !(cn[i] > 0) || !(gsl_matrix_get(cov, (size_t)i, (size_t)i) > 0);
    double g[3][ABC_NPAR] = {{0}}, us[3] = {0}; /* per channel */
    for (int ch = 0; u_sys && ch < 3; ch++) {
        us[ch] = u_sys[ch] > 0 ? u_sys[ch] : 0.0;
        if (us[ch] > 0 && scale_shift(pb, th, cov, ch, g[ch]) < 0)
            goto done;
    }
    if (pb->sw && sandwich(pb, th, cov) < 0)
        goto done;
    for (int i = 0; i < ABC_NPAR; i++)
        for (int j = 0; j < ABC_NPAR; j++)
            c[i][j] = s2 * gsl_matrix_get(cov, (size_t)i, (size_t)j) +
                      (us[0] * us[0] * g[0][i] * g[0][j] + us[1] * us[1] * g[1][i] * g[1][j] +
                       us[2] * us[2] * g[2][i] * g[2][j]);
    for (int k = 0; k < 3; k++) {
        u->log_kd[k] = undet[k] ? INFINITY : sqrt(c[k][k]);
        u->log_A[k] = undet[3 + k] ? INFINITY : sqrt(c[3 + k][3 + k]);
    }
    /* log B = theta6 - theta7 */
    u->log_B = undet[6] || undet[7] ? INFINITY : sqrt(fmax(0.0, c[6][6] + c[7][7] - 2 * c[6][7]));
    /* C beyond its clamp moves nothing, but theta7 still moves B (log B =
     * theta6 - theta7): columns 6 and 7 are then exactly opposite, and
     * which of the two the pivoted QR drops is a tie decided by rounding.
     * C itself is undetermined either way. */
    int c_clamped = !(th[7] >= ABC_LOGC_MIN && th[7] <= ABC_LOGC_MAX);
    u->log_C = undet[7] || c_clamped ? INFINITY : sqrt(c[7][7]);
    double sg = 1.0 / (1.0 + exp(-th[8]));
    double deta = (ABC_ETA_MAX - 1.0) * sg * (1.0 - sg); /* d eta / d theta8 */
    u->eta = undet[8] ? INFINITY : deta * sqrt(c[8][8]);
    u->pred_log = predictive_sd(th, c);
done:
    gsl_matrix_free(cov);
}
