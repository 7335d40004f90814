/* The spectral material kinds: gold (tabulated n, k), printed inks, and a
 * thin-film goniochromatic coating (brdf/spectral.h describes each). */
#include <complex.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "brdf/spectral_private.h"
#include "common/paths.h"

#define SPEC_PI 3.14159265358979323846

double brdf_fresnel_complex(double n, double k, double cos_theta)
{
    double complex eta = n + k * I;
    double c = cos_theta;
    double complex ct = csqrt(1.0 - (1.0 - c * c) / (eta * eta));
    double complex rs = (c - eta * ct) / (c + eta * ct);
    double complex rp = (eta * c - ct) / (eta * c + ct);
    return 0.5 * (creal(rs * conj(rs)) + creal(rp * conj(rp)));
}

double brdf_thin_film_reflectance(double n_film, double d_nm, double n_sub, double k_sub,
                                  double lambda_nm, double cos_theta)
{
    double c0 = cos_theta, s0sq = 1.0 - c0 * c0;
    double n1 = n_film;
    double complex c1 = csqrt(1.0 - s0sq / (n1 * n1));
    double complex eta2 = n_sub + k_sub * I;
    double complex c2 = csqrt(1.0 - s0sq / (eta2 * eta2));
    double complex rs01 = (c0 - n1 * c1) / (c0 + n1 * c1);
    double complex rp01 = (n1 * c0 - c1) / (n1 * c0 + c1);
    double complex rs12 = (n1 * c1 - eta2 * c2) / (n1 * c1 + eta2 * c2);
    double complex rp12 = (eta2 * c1 - n1 * c2) / (eta2 * c1 + n1 * c2);
    /* round trip through the film: phase 2 delta, delta = 2 pi n d cos / lambda */
    double complex ph = cexp(2.0 * I * (2.0 * SPEC_PI * n1 * d_nm * c1 / lambda_nm));
    double complex rs = (rs01 + rs12 * ph) / (1.0 + rs01 * rs12 * ph);
    double complex rp = (rp01 + rp12 * ph) / (1.0 + rp01 * rp12 * ph);
    return 0.5 * (creal(rs * conj(rs)) + creal(rp * conj(rp)));
}

/* The microfacet geometry of a pair: incidence and exit cosines, the half
 * vector's cosine to the normal and to the directions (theta_d). */
struct lobe_geom {
    double ci, co, ch, cd;
};

static int lobe_geom(const struct brdf_pair *p, struct lobe_geom *g)
{
    g->ci = p->wi[2];
    g->co = p->wo[2];
    if (!(g->ci > 0) || !(g->co > 0))
        return 0;
    double h[3] = {p->wi[0] + p->wo[0], p->wi[1] + p->wo[1], p->wi[2] + p->wo[2]};
    double len = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
    g->ch = h[2] / len;
    g->cd = (p->wi[0] * h[0] + p->wi[1] * h[1] + p->wi[2] * h[2]) / len;
    return 1;
}

/* GGX distribution times the separable Smith shadowing, over 4 ci co: the
 * lobe without its Fresnel factor. */
static double ggx_lobe(const struct lobe_geom *g, double alpha)
{
    double a2 = alpha * alpha;
    double t = g->ch * g->ch * (a2 - 1.0) + 1.0;
    double d = a2 / (SPEC_PI * t * t);
    double g1i = 2.0 * g->ci / (g->ci + sqrt(a2 + (1.0 - a2) * g->ci * g->ci));
    double g1o = 2.0 * g->co / (g->co + sqrt(a2 + (1.0 - a2) * g->co * g->co));
    return d * g1i * g1o / (4.0 * g->ci * g->co);
}

/* ---- gold ------------------------------------------------------------------ */

#define NK_MAX 256

struct nk_table {
    int n;
    double lambda[NK_MAX], re[NK_MAX], im[NK_MAX];
    double alpha;
};

static void nk_at(const struct nk_table *t, double lambda, double *n, double *k)
{
    if (lambda <= t->lambda[0]) {
        *n = t->re[0];
        *k = t->im[0];
        return;
    }
    for (int i = 1; i < t->n; i++)
        if (lambda <= t->lambda[i]) {
            double u = (lambda - t->lambda[i - 1]) / (t->lambda[i] - t->lambda[i - 1]);
            *n = t->re[i - 1] + u * (t->re[i] - t->re[i - 1]);
            *k = t->im[i - 1] + u * (t->im[i] - t->im[i - 1]);
            return;
        }
    *n = t->re[t->n - 1];
    *k = t->im[t->n - 1];
}

static void metal_eval(const void *priv, const struct brdf_pair *p, const double *lambda_nm,
                       size_t n, double *out)
{
    const struct nk_table *t = priv;
    struct lobe_geom g;
    if (!lobe_geom(p, &g)) {
        memset(out, 0, n * sizeof *out);
        return;
    }
    double lobe = ggx_lobe(&g, t->alpha);
    for (size_t i = 0; i < n; i++) {
        double re, im;
        nk_at(t, lambda_nm[i], &re, &im);
        out[i] = brdf_fresnel_complex(re, im, g.cd) * lobe;
    }
}

static const struct brdf_spectral_ops metal_ops = {
    .kind = "metal", .eval = metal_eval, .free_priv = free};

/* Read wavelength_nm,n,k rows ('#' comments, one header line). */
static int nk_load(const char *path, struct nk_table *t, struct gonio_err *err)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return gonio_err_set(err, errno == ENOENT ? GONIO_ENOTFOUND : GONIO_EBADDATA,
                             "%s: cannot open (%s)", path, strerror(errno));
    char line[512];
    int lineno = 0, header = 0, rc = 0;
    t->n = 0;
    while (fgets(line, sizeof line, f)) {
        lineno++;
        if (line[0] == '#' || line[0] == '\n' || line[0] == '\r')
            continue;
        if (!header) {
            if (strncmp(line, "wavelength_nm,n,k", 17) != 0) {
                rc = gonio_err_set(err, GONIO_EBADDATA,
                                   "%s:%d: header: expected 'wavelength_nm,n,k'", path, lineno);
                break;
            }
            header = 1;
            continue;
        }
        double l, re, im;
        char extra;
        if (sscanf(line, "%lf,%lf,%lf %c", &l, &re, &im, &extra) != 3 || !isfinite(l) ||
            !(re > 0) || !(im >= 0) || !isfinite(re) || !isfinite(im)) {
            rc = gonio_err_set(err, GONIO_EBADDATA,
                               "%s:%d: expected wavelength_nm,n,k with n > 0 and k >= 0", path,
                               lineno);
            break;
        }
        if (t->n == NK_MAX || (t->n > 0 && !(l > t->lambda[t->n - 1]))) {
            rc = gonio_err_set(err, GONIO_EBADDATA,
                               "%s:%d: wavelength %g nm out of order or too many rows (max %d)",
                               path, lineno, l, NK_MAX);
            break;
        }
        t->lambda[t->n] = l;
        t->re[t->n] = re;
        t->im[t->n] = im;
        t->n++;
    }
    fclose(f);
    if (rc == 0 && t->n < 2)
        rc = gonio_err_set(err, GONIO_EBADDATA, "%s: fewer than 2 rows of n, k", path);
    return rc;
}

static brdf_spectral *open_gold(const char *spec, struct gonio_err *err)
{
    const char *shared = gonio_shared_dir();
    if (!shared) {
        gonio_err_set(err, GONIO_ENOTFOUND, "%s: shared data folder not found (set GONIO_SHARED)",
                      spec);
        return NULL;
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/data/spectral/gold_nk.csv", shared);
    struct nk_table *t = malloc(sizeof *t);
    if (!t) {
        gonio_err_set(err, ENOMEM, "%s: out of memory", spec);
        return NULL;
    }
    if (nk_load(path, t, err) < 0) {
        free(t);
        return NULL;
    }
    t->alpha = 0.12;
    brdf_spectral *m = brdf_spectral_new(&metal_ops, t, spec, t->lambda[0], t->lambda[t->n - 1]);
    if (!m)
        gonio_err_set(err, ENOMEM, "%s: out of memory", spec);
    return m;
}

/* ---- printed inks ------------------------------------------------------------ */

static double logistic(double x)
{
    return 1.0 / (1.0 + exp(-x));
}

/* Model reflectance spectra of process inks on white paper: cyan absorbs
 * the red end (a logistic edge at 580 nm), magenta the green band (a
 * Gaussian absorption at 545 nm). */
static double cyan_reflectance(double l)
{
    return 0.08 + 0.70 * (1.0 - logistic((l - 580.0) / 20.0));
}

static double magenta_reflectance(double l)
{
    double z = (l - 545.0) / 40.0;
    return 0.82 - 0.74 * exp(-0.5 * z * z);
}

/* Dielectric Fresnel (k = 0) of the varnish. */
static double varnish_fresnel(double c)
{
    return brdf_fresnel_complex(1.5, 0.0, c);
}

struct ink {
    double (*reflectance)(double lambda_nm);
};

static void ink_eval(const void *priv, const struct brdf_pair *p, const double *lambda_nm,
                     size_t n, double *out)
{
    const struct ink *ink = priv;
    struct lobe_geom g;
    if (!lobe_geom(p, &g)) {
        memset(out, 0, n * sizeof *out);
        return;
    }
    double gloss = varnish_fresnel(g.cd) * ggx_lobe(&g, 0.25);
    for (size_t i = 0; i < n; i++)
        out[i] = ink->reflectance(lambda_nm[i]) / SPEC_PI + gloss;
}

static const struct ink cyan_ink = {cyan_reflectance}, magenta_ink = {magenta_reflectance};

static const struct brdf_spectral_ops ink_ops = {.kind = "ink", .eval = ink_eval};

/* ---- thin film --------------------------------------------------------------- */

#define FILM_N 1.8
#define FILM_D_NM 380.0
#define FILM_SUB_N 1.5
#define FILM_SUB_K 0.5

static void film_eval(const void *priv, const struct brdf_pair *p, const double *lambda_nm,
                      size_t n, double *out)
{
    (void)priv;
    struct lobe_geom g;
    if (!lobe_geom(p, &g)) {
        memset(out, 0, n * sizeof *out);
        return;
    }
    double lobe = ggx_lobe(&g, 0.2);
    for (size_t i = 0; i < n; i++)
        out[i] = 0.01 / SPEC_PI + lobe * brdf_thin_film_reflectance(FILM_N, FILM_D_NM, FILM_SUB_N,
                                                                     FILM_SUB_K, lambda_nm[i],
                                                                     g.cd);
}

static const struct brdf_spectral_ops film_ops = {.kind = "thin-film", .eval = film_eval};

brdf_spectral *brdf_spectral_open(const char *spec, struct gonio_err *err)
{
    const char *name = strncmp(spec, "spectral:", 9) == 0 ? spec + 9 : spec;
    brdf_spectral *m = NULL;
    if (!strcmp(name, "gold"))
        return open_gold(spec, err);
    if (!strcmp(name, "cyan"))
        m = brdf_spectral_new(&ink_ops, (void *)&cyan_ink, spec, 360, 830);
    else if (!strcmp(name, "magenta"))
        m = brdf_spectral_new(&ink_ops, (void *)&magenta_ink, spec, 360, 830);
    else if (!strcmp(name, "gonio"))
        m = brdf_spectral_new(&film_ops, NULL, spec, 360, 830);
    else {
        gonio_err_set(err, GONIO_ENOTFOUND,
                      "%s: no spectral material '%s' (have: gold, cyan, magenta, gonio)", spec,
                      name);
        return NULL;
    }
    if (!m)
        gonio_err_set(err, ENOMEM, "%s: out of memory", spec);
    return m;
}
