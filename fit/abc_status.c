/* The ABC Jacobian at a fit's optimum: its square root (for the parameter
 * covariance, fit/abc_covariance.c) and what it says about the fit's status
 * (fit/fit_status.h): parameters on a bound, the rank and the condition
 * number of the free parameters. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include <gsl/gsl_linalg.h>
#include <gsl/gsl_matrix.h>

#include "fit/abc_problem.h"
#include "fit/fit_status.h"

/* A square root of J^T J at theta: rows K (nk x 9, row-major) with
 * K^T K = J^T J, and cn[j] > 0 exactly when J's column j is not zero (its
 * largest |entry|). The
 * data rows of channel c have non-zeros only in columns c, 3 + c, 6, 7, 8
 * (an n x 5 block J_c, abc_problem_jblock), so K stacks the R of each
 * block's QR (J^T J = sum_c R_c^T R_c; below 5 samples the block itself)
 * and the prior rows. QR is backward stable, so the pivoted QR of K
 * decides the rank as J's own would, for a fraction of the work (J's
 * 3n x 9 pivoted QR and its scalar evaluation were a tenth of a DS1 fit).
 * Returns nk (>= 9), 0 on no memory. */
size_t abc_jacobian_root(const struct abc_problem *pb, const double th[ABC_NPAR], double *K,
                         double cn[ABC_NPAR])
{
    static const int col[5] = {0, 3, 6, 7, 8}; /* + c for the first two */
    size_t n = pb->n, rows = n >= 5 ? 5 : n, nk = 0;
    struct abc_cache c;
    gsl_matrix *Jc = gsl_matrix_alloc(n, 5);
    gsl_vector *tau = gsl_vector_alloc(5);
    int ok = Jc && tau && abc_cache_init(&c, pb) == 0;
    if (ok) {
        abc_problem_resid(pb, th, NULL, &c);
        for (int j = 0; j < ABC_NPAR; j++)
            cn[j] = 0.0;
        for (int ch = 0; ch < 3 && ok; ch++) {
            abc_problem_jblock(pb, th, &c, ch, Jc->data);
            for (size_t k = 0; k < n; k++) /* cn only tells zero columns apart */
                for (size_t j = 0; j < 5; j++) {
                    int at = col[j] + (j < 2 ? ch : 0);
                    double a = fabs(Jc->data[5 * k + j]);
                    if (a > cn[at])
                        cn[at] = a;
                }
            if (n >= 5 && gsl_linalg_QR_decomp(Jc, tau) != GSL_SUCCESS) {
                ok = 0;
                break;
            }
            for (size_t i = 0; i < rows; i++, nk++) {
                double *out = K + nk * ABC_NPAR;
                for (int j = 0; j < ABC_NPAR; j++)
                    out[j] = 0.0;
                for (size_t j = n >= 5 ? i : 0; j < 5; j++) /* R: the upper triangle */
                    out[col[j] + (j < 2 ? ch : 0)] = gsl_matrix_get(Jc, i, j);
            }
        }
        abc_cache_free(&c);
    }
    if (ok && pb->prior) /* the prior rows: W */
        for (int i = 0; i < ABC_NPAR; i++, nk++)
            memcpy(K + nk * ABC_NPAR, pb->prior->W + i * ABC_NPAR, ABC_NPAR * sizeof *K);
    gsl_matrix_free(Jc);
    gsl_vector_free(tau);
    return ok ? nk : 0;
}

/* A parameter is on a bound within this fraction of its range (in the
 * fitter's coordinates: the logs, and the sigmoid of eta). */
#define BOUND_MARGIN 1e-3

/* Singular values below this fraction of the largest (unit columns) count
 * as zero: cond(J^T J) 1e16, double's precision. */
#define RANK_TOL 1e-8

static int near(double v, double lo, double hi, int upper)
{
    double m = BOUND_MARGIN * (hi - lo);
    return upper ? v >= hi - m : v <= lo + m;
}

/* Append a parameter's name to st->at_bound. */
static void name(struct fit_status *st, size_t *at, const char *s)
{
    if (*at < sizeof st->at_bound)
        *at += (size_t)snprintf(st->at_bound + *at, sizeof st->at_bound - *at, "%s%s",
                                *at ? "," : "", s);
}

void abc_status_figures(const double th[ABC_NPAR], double *K, size_t nk, struct fit_status *st)
{
    static const char *const amp[6] = {"kd_r", "kd_g", "kd_b", "A_r", "A_g", "A_b"};
    int bound[ABC_NPAR] = {0}, absent = 0;
    size_t at = 0;
    st->at_bound[0] = '\0';
    /* kd or A at the lower clamp is a term that is absent (0, the bound of a
     * non-negative amplitude, as a linear solve would give): not free, and
     * no finding. Their upper clamps, and any clamp of B, C and eta, are
     * the fitter's own limits: at-bound. */
    for (int j = 0; j < 6; j++) {
        double lo = j < 3 ? ABC_LOGKD_MIN : ABC_LOGA_MIN, hi = j < 3 ? ABC_LOGKD_MAX : ABC_LOGA_MAX;
        bound[j] = near(th[j], lo, hi, 0) || near(th[j], lo, hi, 1);
        if (near(th[j], lo, hi, 1))
            name(st, &at, amp[j]);
        absent += j >= 3 && near(th[j], lo, hi, 0);
    }
    double logb = th[6] - th[7], sg = 1.0 / (1.0 + exp(-th[8]));
    bound[6] = near(logb, ABC_LOGB_MIN, ABC_LOGB_MAX, 0) || near(logb, ABC_LOGB_MIN, ABC_LOGB_MAX, 1);
    bound[7] = near(th[7], ABC_LOGC_MIN, ABC_LOGC_MAX, 0) || near(th[7], ABC_LOGC_MIN, ABC_LOGC_MAX, 1);
    bound[8] = near(sg, 0.0, 1.0, 0) || near(sg, 0.0, 1.0, 1);
    /* Without a lobe (A absent in every channel) B, C and eta shape
     * nothing: free parameters the data say nothing about, wherever the
     * solver left them. */
    int no_lobe = absent == 3;
    static const char *const shape[3] = {"B", "C", "eta"};
    for (int j = 6; j < ABC_NPAR; j++) {
        bound[j] = bound[j] && !no_lobe;
        if (bound[j])
            name(st, &at, shape[j - 6]);
    }

    /* Rank and condition of the data rows (a prior's rows would hide what
     * the data cannot tell) on the free columns scaled to unit length, so
     * that the figures do not depend on units or on the data's scale. */
    int free_col[ABC_NPAR], nf = 0;
    for (int j = 0; j < ABC_NPAR; j++)
        if (!bound[j])
            free_col[nf++] = j;
    if (no_lobe)
        for (size_t i = 0; i < nk; i++)
            for (int j = 6; j < ABC_NPAR; j++)
                K[i * ABC_NPAR + j] = 0.0;
    st->params = nf;
    st->rank = -1;
    st->cond = NAN;
    if (!nk || !nf)
        return;
    size_t rows = nk > (size_t)nf ? nk : (size_t)nf;
    gsl_matrix *M = gsl_matrix_calloc(rows, (size_t)nf), *V = gsl_matrix_alloc((size_t)nf, (size_t)nf);
    gsl_vector *s = gsl_vector_alloc((size_t)nf), *w = gsl_vector_alloc((size_t)nf);
    if (M && V && s && w) {
        for (int c = 0; c < nf; c++) {
            double norm = 0;
            for (size_t i = 0; i < nk; i++)
                norm += K[i * ABC_NPAR + free_col[c]] * K[i * ABC_NPAR + free_col[c]];
            norm = sqrt(norm);
            for (size_t i = 0; i < nk && norm > 0; i++)
                gsl_matrix_set(M, i, (size_t)c, K[i * ABC_NPAR + free_col[c]] / norm);
        }
        if (gsl_linalg_SV_decomp(M, V, s, w) == GSL_SUCCESS) {
            double smax = gsl_vector_get(s, 0), smin = gsl_vector_get(s, (size_t)nf - 1);
            int rank = 0;
            for (int c = 0; c < nf; c++)
                rank += gsl_vector_get(s, (size_t)c) > RANK_TOL * smax;
            st->rank = rank;
            st->cond = rank == nf ? (smax / smin) * (smax / smin) : INFINITY;
        }
    }
    gsl_matrix_free(M);
    gsl_matrix_free(V);
    gsl_vector_free(s);
    gsl_vector_free(w);
}
