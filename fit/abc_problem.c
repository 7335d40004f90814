/* The ABC least-squares problem: parametrisation, log-space residuals and
 * their analytic Jacobian. */
#include "fit/abc_problem.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define ABC_PI 3.14159265358979323846

int abc_problem_init(struct abc_problem *pb, const struct fit_sample *s, const size_t *idx,
                     size_t n)
{
    memset(pb, 0, sizeof *pb);
    pb->n = n;
    pb->x = malloc(n * sizeof *pb->x);
    pb->vh = malloc(n * sizeof *pb->vh);
    pb->gterm = malloc(n * sizeof *pb->gterm);
    pb->cosi = malloc(n * sizeof *pb->cosi);
    pb->f = malloc(3 * n * sizeof *pb->f);
    pb->y = malloc(3 * n * sizeof *pb->y);
    if (!pb->x || !pb->vh || !pb->gterm || !pb->cosi || !pb->f || !pb->y) {
        abc_problem_free(pb);
        return -1;
    }
    for (size_t k = 0; k < n; k++) {
        const struct fit_sample *sk = &s[idx ? idx[k] : k];
        struct brdf_abc_geom geo;
        brdf_abc_geometry(&sk->g, &geo);
        pb->x[k] = geo.x;
        pb->vh[k] = geo.vh;
        pb->gterm[k] = geo.gterm;
        pb->cosi[k] = sk->g.wi[2];
        for (int c = 0; c < 3; c++) {
            pb->f[3 * k + c] = sk->rgb[c];
            pb->y[3 * k + c] = log1p(sk->rgb[c] * pb->cosi[k]);
        }
    }
    return 0;
}

void abc_problem_free(struct abc_problem *pb)
{
    free(pb->x);
    free(pb->vh);
    free(pb->gterm);
    free(pb->cosi);
    free(pb->f);
    free(pb->y);
    free(pb->s);
    memset(pb, 0, sizeof *pb);
}

int abc_problem_set_loss(struct abc_problem *pb, enum fit_loss loss)
{
    if (loss != FIT_LOSS_LOG && loss != FIT_LOSS_RELATIVE && loss != FIT_LOSS_COS_L2)
        return -1;
    pb->loss = loss;
    if (loss == FIT_LOSS_LOG)
        return 0;
    if (!pb->s && !(pb->s = malloc((pb->n ? 3 * pb->n : 1) * sizeof *pb->s)))
        return -1;
    for (size_t row = 0; row < 3 * pb->n; row++)
        pb->s[row] = loss == FIT_LOSS_RELATIVE ? 1.0 / (fabs(pb->f[row]) + FIT_REL_FLOOR)
                                               : pb->cosi[row / 3];
    return 0;
}

size_t abc_problem_nres(const struct abc_problem *pb)
{
    return 3 * pb->n + (pb->prior ? ABC_NPAR : 0);
}

/* exp of a clamped log; *d receives d value / d t (0 beyond the clamp). */
static double clamped_exp(double t, double lo, double hi, double *d)
{
    int inside = 1;
    if (!(t >= lo)) { /* also catches NaN */
        t = lo;
        inside = 0;
    } else if (t > hi) {
        t = hi;
        inside = 0;
    }
    double v = exp(t);
    if (d)
        *d = inside ? v : 0.0;
    return v;
}

static double eta_of(double e, double *d)
{
    int inside = 1;
    if (!(e >= ABC_E_MIN)) {
        e = ABC_E_MIN;
        inside = 0;
    } else if (e > ABC_E_MAX) {
        e = ABC_E_MAX;
        inside = 0;
    }
    double s = 1.0 / (1.0 + exp(-e));
    if (d)
        *d = inside ? (ABC_ETA_MAX - 1.0) * s * (1.0 - s) : 0.0;
    return 1.0 + (ABC_ETA_MAX - 1.0) * s;
}

void abc_theta_to_params(const double th[ABC_NPAR], struct brdf_abc *p)
{
    for (int c = 0; c < 3; c++) {
        p->kd[c] = clamped_exp(th[c], ABC_LOGKD_MIN, ABC_LOGKD_MAX, NULL);
        p->A[c] = clamped_exp(th[3 + c], ABC_LOGA_MIN, ABC_LOGA_MAX, NULL);
    }
    p->B = clamped_exp(th[6] - th[7], ABC_LOGB_MIN, ABC_LOGB_MAX, NULL);
    p->C = clamped_exp(th[7], ABC_LOGC_MIN, ABC_LOGC_MAX, NULL);
    p->eta = eta_of(th[8], NULL);
}

static double clamp(double v, double lo, double hi)
{
    return v < lo ? lo : v > hi ? hi : v;
}

static double safe_log(double v, double lo, double hi)
{
    return v > 0 ? clamp(log(v), lo, hi) : lo;
}

void abc_params_to_theta(const struct brdf_abc *p, double th[ABC_NPAR])
{
    for (int c = 0; c < 3; c++) {
        th[c] = safe_log(p->kd[c], ABC_LOGKD_MIN, ABC_LOGKD_MAX);
        th[3 + c] = safe_log(p->A[c], ABC_LOGA_MIN, ABC_LOGA_MAX);
    }
    th[7] = safe_log(p->C, ABC_LOGC_MIN, ABC_LOGC_MAX);
    th[6] = safe_log(p->B, ABC_LOGB_MIN, ABC_LOGB_MAX) + th[7];
    /* invert the sigmoid; an eta outside (1, ETA_MAX) lands on the clamp */
    double s = (p->eta - 1.0) / (ABC_ETA_MAX - 1.0);
    if (!(s > 1e-13))
        s = 1e-13;
    if (s > 1.0 - 1e-13)
        s = 1.0 - 1e-13;
    th[8] = clamp(log(s / (1.0 - s)), ABC_E_MIN, ABC_E_MAX);
}

void abc_problem_eval(const struct abc_problem *pb, const double th[ABC_NPAR], double *r,
                      double *J)
{
    double kd[3], dkd[3], A[3], dA[3], dBt, dCt, detat;
    for (int c = 0; c < 3; c++) {
        kd[c] = clamped_exp(th[c], ABC_LOGKD_MIN, ABC_LOGKD_MAX, &dkd[c]);
        A[c] = clamped_exp(th[3 + c], ABC_LOGA_MIN, ABC_LOGA_MAX, &dA[c]);
    }
    /* theta[6] = log(B C), theta[7] = log C: see abc_problem.h */
    double B = clamped_exp(th[6] - th[7], ABC_LOGB_MIN, ABC_LOGB_MAX, &dBt);
    double C = clamped_exp(th[7], ABC_LOGC_MIN, ABC_LOGC_MAX, &dCt);
    double eta = eta_of(th[8], &detat);

    for (size_t k = 0; k < pb->n; k++) {
        double dF, dDB, dDC;
        double F = brdf_abc_fresnel(eta, pb->vh[k], J ? &dF : NULL);
        double D = brdf_abc_distribution(B, C, pb->x[k], J ? &dDB : NULL, J ? &dDC : NULL);
        double gt = pb->gterm[k], ci = pb->cosi[k];
        double S = F * gt * D; /* specular shape shared by the channels */
        for (int c = 0; c < 3; c++) {
            double fhat = kd[c] / ABC_PI + A[c] * S;
            size_t row = 3 * k + (size_t)c;
            int lin = pb->loss != FIT_LOSS_LOG;
            if (r)
                r[row] = lin ? (fhat - pb->f[row]) * pb->s[row] : log1p(fhat * ci) - pb->y[row];
            if (!J)
                continue;
            /* w = dr/dfhat: d log(1 + fhat cos) = cos / (1 + fhat cos) d fhat */
            double w = lin ? pb->s[row] : ci / (1.0 + fhat * ci);
            double *jr = J + row * ABC_NPAR;
            memset(jr, 0, ABC_NPAR * sizeof *jr);
            jr[c] = w * dkd[c] / ABC_PI;
            jr[3 + c] = w * dA[c] * S;
            double ag = w * A[c] * gt;
            jr[6] = ag * F * dDB * dBt;
            jr[7] = ag * F * (dDC * dCt - dDB * dBt);
            jr[8] = ag * D * dF * detat;
        }
    }
    if (pb->prior) {
        /* Linear in theta (unclamped): the prior keeps pulling a parameter
         * that sits beyond a clamp, where the data no longer move it. */
        const struct abc_prior_term *pt = pb->prior;
        for (int i = 0; i < ABC_NPAR; i++) {
            size_t row = 3 * pb->n + (size_t)i;
            if (r) {
                double v = 0;
                for (int j = 0; j < ABC_NPAR; j++)
                    v += pt->W[i * ABC_NPAR + j] * (th[j] - pt->mean[j]);
                r[row] = v;
            }
            if (J)
                memcpy(J + row * ABC_NPAR, pt->W + i * ABC_NPAR, ABC_NPAR * sizeof *J);
        }
    }
}

double abc_problem_cost(const struct abc_problem *pb, const double th[ABC_NPAR])
{
    size_t m = abc_problem_nres(pb);
    double *r = malloc(m * sizeof *r);
    if (!r)
        return INFINITY;
    abc_problem_eval(pb, th, r, NULL);
    double s = 0;
    for (size_t i = 0; i < m; i++)
        s += r[i] * r[i];
    free(r);
    return 0.5 * s;
}
