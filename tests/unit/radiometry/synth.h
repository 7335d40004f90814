/* A synthetic rig for the radiometry tests: a glossy sample and a
 * reference standard read by a detector with gain, offset, dark signal,
 * shot and read noise and a nonlinearity, under a drifting lamp that a
 * monitor follows, on axes that rest anywhere within their in-position
 * band. Every quantity the budget claims to know is drawn here from the
 * distribution the budget assumes, so z-scores of an honest budget are
 * standard normal; noise can be switched off for exact checks. */
#ifndef GONIO_TEST_RADIOMETRY_SYNTH_H
#define GONIO_TEST_RADIOMETRY_SYNTH_H

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "radiometry/reduce.h"

#define SYN_PI 3.14159265358979323846
#define SYN_MAX 256

struct syn_rig {
    int noisy;                 /* 0: every noise and error off */
    uint64_t rng;
    double gain;               /* ADU per electron */
    double offset, dark_e_per_s, read_sd;
    double full_scale, k_stated, k_true;
    double drift_per_s;        /* the lamp's relative drift */
    double monitor_per_s, monitor_rel_sd;
    double band_deg;
    double responsivity;       /* electrons per second per (1/sr) */
    double geometry_true;      /* the sample's placement factor (1: as the standard's) */
    struct brdf_standard cert; /* what the certificate says */
    struct brdf_standard truth;/* what the plaque is */
    double t_now;
};

static inline double syn_uniform(struct syn_rig *r)
{
    /* splitmix64 */
    uint64_t z = (r->rng += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return ((double)(z >> 11) + 0.5) * 0x1p-53;
}

static inline double syn_normal(struct syn_rig *r)
{
    if (!r->noisy)
        return 0.0;
    double u1 = syn_uniform(r), u2 = syn_uniform(r);
    return sqrt(-2.0 * log(u1)) * cos(2.0 * SYN_PI * u2);
}

/* The sample's true BRDF: a Lambertian base and a lobe about the mirror. */
static inline double syn_sample_brdf(double ti, double tr, int c)
{
    const double rho[3] = {0.35, 0.25, 0.15};
    double d = (tr - ti) / 12.0;
    return rho[c] / SYN_PI * (1.0 + 3.0 * exp(-d * d));
}

/* A standard with a smooth non-Lambertian shape and a 0.5 % certificate. */
static inline void syn_standard(struct brdf_standard *s)
{
    memset(s, 0, sizeof *s);
    snprintf(s->name, sizeof s->name, "synthetic");
    const double inc[] = {0, 30, 60}, view[] = {-80, -40, 0, 40, 80};
    s->n_inc = 3, s->n_view = 5;
    for (int i = 0; i < 3; i++)
        s->inc_deg[i] = inc[i];
    for (int j = 0; j < 5; j++) {
        s->view_deg[j] = view[j];
        for (int i = 0; i < 3; i++)
            s->shape[i][j] = 1.01 - 0.2 * (view[j] / 80) * (view[j] / 80) +
                             0.05 * (inc[i] / 60) * (view[j] / 80);
    }
    for (int c = 0; c < 3; c++)
        s->rho[c] = 0.99, s->u_rho[c] = 0.005;
    s->u_shape = 0.004;
}

/* A rig for one repeat: the plaque's true reflectance, shape scale, the
 * nonlinearity and the placement drawn from what the budget states. */
static inline void syn_rig_init(struct syn_rig *r, uint64_t seed, int noisy)
{
    memset(r, 0, sizeof *r);
    r->noisy = noisy;
    r->rng = seed * 0x2545f4914f6cdd1dull + 1;
    r->gain = 2.0, r->offset = 1000.0, r->dark_e_per_s = 400.0, r->read_sd = 6.0;
    r->full_scale = 65535.0, r->k_stated = 0.03;
    r->k_true = r->k_stated * (1.0 + 0.1 * syn_normal(r));
    r->drift_per_s = 2e-5;
    r->monitor_per_s = 2e6, r->monitor_rel_sd = noisy ? 1e-3 : 0.0;
    r->band_deg = noisy ? 0.05 : 0.0;
    r->responsivity = 1.2e5;
    r->geometry_true = 1.0 + 0.002 * syn_normal(r);
    syn_standard(&r->cert);
    r->truth = r->cert;
    double shape_scale = 1.0 + r->cert.u_shape * syn_normal(r);
    for (int c = 0; c < 3; c++)
        r->truth.rho[c] = (r->cert.rho[c] + r->cert.u_rho[c] * syn_normal(r)) * shape_scale;
}

static inline double syn_lamp(const struct syn_rig *r)
{
    return 1.0 + r->drift_per_s * r->t_now;
}

/* A raw reading of a signal (electrons per second) at integration t. */
static inline double syn_counts(struct syn_rig *r, double e_per_s, double t)
{
    double x = r->gain * (e_per_s + r->dark_e_per_s) * t;
    x += sqrt(r->gain * x) * syn_normal(r) + r->read_sd * syn_normal(r);
    double y = r->offset + x - r->k_true * x * x / r->full_scale;
    return y;
}

static inline double syn_monitor(struct syn_rig *r, double t)
{
    return r->monitor_per_s * syn_lamp(r) * t * (1.0 + r->monitor_rel_sd * syn_normal(r));
}

/* Where the axes came to rest for a nominal geometry. */
static inline void syn_actual(struct syn_rig *r, double ti, double tr, double *ati, double *atr)
{
    double ds = r->noisy ? r->band_deg * (2 * syn_uniform(r) - 1) : 0;
    double da = r->noisy ? r->band_deg * (2 * syn_uniform(r) - 1) : 0;
    *ati = ti + ds;
    *atr = tr + da - ds;
}

/* An underfilled spot: the signal carries cos theta_r beside the BRDF. */
static inline double syn_signal(const struct syn_rig *r, double brdf, double tr)
{
    return r->responsivity * brdf * cos(tr * SYN_PI / 180) * syn_lamp(r);
}

static inline void syn_dark(struct syn_rig *r, double t, int n, struct rad_dark *d)
{
    d->integration_s = t, d->gain_state = 0, d->n = n;
    for (int c = 0; c < 3; c++) {
        double s = 0, s2 = 0;
        for (int k = 0; k < n; k++) {
            double v = syn_counts(r, 0.0, t);
            s += v, s2 += v * v;
        }
        d->mean[c] = s / n;
        /* The spread the detector is known to have (a large set's). */
        double x = r->gain * r->dark_e_per_s * t;
        d->sd[c] = sqrt(r->gain * x + r->read_sd * r->read_sd);
        (void)s2;
    }
    r->t_now += n * t;
}

static inline void syn_reference(struct syn_rig *r, double ti, double tr, double t, int n,
                                 struct rad_ref *ref)
{
    ref->theta_i = ti, ref->theta_r = tr, ref->integration_s = t, ref->gain_state = 0;
    ref->n = n;
    double m = 0, sum[3] = {0};
    for (int k = 0; k < n; k++) {
        double ati, atr, f[3];
        syn_actual(r, ti, tr, &ati, &atr);
        brdf_standard_brdf(&r->truth, ati, atr, f);
        for (int c = 0; c < 3; c++)
            sum[c] += syn_counts(r, syn_signal(r, f[c], atr), t);
        m += syn_monitor(r, t);
        r->t_now += t + 2.0;
    }
    for (int c = 0; c < 3; c++)
        ref->counts[c] = sum[c] / n;
    ref->monitor = m / n;
}

static inline void syn_sample(struct syn_rig *r, double ti, double tr, double t,
                              struct rad_raw *s)
{
    memset(s, 0, sizeof *s); /* no drift, nothing left over */
    double ati, atr;
    syn_actual(r, ti, tr, &ati, &atr);
    s->theta_i = ti, s->theta_r = tr, s->integration_s = t, s->gain_state = 0;
    s->full_scale = r->full_scale, s->nonlinearity = r->k_stated;
    for (int c = 0; c < 3; c++) {
        double f = syn_sample_brdf(ati, atr, c) * r->geometry_true;
        s->counts[c] = syn_counts(r, syn_signal(r, f, atr), t);
        if (s->counts[c] > r->full_scale)
            s->counts[c] = r->full_scale;
    }
    s->monitor = syn_monitor(r, t);
    r->t_now += t + 3.0;
}

/* The setup the budget is told: what the rig above draws from. */
static inline void syn_setup(const struct syn_rig *r, struct rad_setup *su)
{
    memset(su, 0, sizeof *su);
    for (int c = 0; c < 3; c++)
        su->adu_per_electron[c] = r->gain;
    su->monitor_rel_sd = r->monitor_rel_sd;
    su->nonlinearity_rel_u = 0.1;
    su->in_position_deg = r->band_deg;
    su->geometry_rel_u = r->noisy ? 0.002 : 0.0;
    su->spot = RAD_SPOT_UNDERFILLED;
}

#endif
