/* Internal to fit/: the ABC fit's transcendental functions over arrays,
 * vectorised. Once everything else is shared per sample (docs/fitting.md),
 * a DS1 solve's time is mostly one log per sample and channel and the
 * lobe's log1p and exp per distinct 1 - n.h. */
#ifndef GONIO_FIT_ABC_VMATH_H
#define GONIO_FIT_ABC_VMATH_H

#include <stddef.h>

/* On x86-64 with GCC: an x86-64-v3 (AVX2, FMA) version of the function
 * beside the baseline one, chosen at load time (the binary stays
 * portable): 4-wide vectors and libmvec functions. Also on the residual,
 * normal-equation and grid passes (abc_problem.c, abc_start.c). Not
 * "arch=haswell": for an arch= clone GCC's resolver asks whether the CPU
 * *is* that model, so on every other AVX2 machine the baseline ran. */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define ABC_VCLONES __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define ABC_VCLONES
#endif

/* v[i] = log(v[i]) for i < n. The inputs must be finite and > 0 (callers
 * pass ratios of 1 + f cos theta_i >= 1 terms). Within 4 ulp of log(). */
void abc_vlog(double *v, size_t n);

/* The lobe D = (1 + B x)^-C of brdf_abc_distribution and its derivatives,
 * for x[i] >= 0, i < n, B, C >= 0 finite: out[i] = D, out[n+i] = dD/dB,
 * out[2n+i] = dD/dC (structure of arrays: the residual pass gathers from
 * them). Within a few ulp of brdf_abc_distribution. */
void abc_vlobe(double B, double C, const double *x, size_t n, double *out);

/* The Fresnel term of brdf_abc_fresnel and dF/deta at v.h = vh[i], i < n
 * (eta >= 1 finite): out[i] = F, out[n+i] = dF/deta. */
void abc_vfresnel(double eta, const double *vh, size_t n, double *out);

/* v[i] = exp(-C v[i]) for i < n (v[i], C finite): the lobe from a stored
 * log1p(B x). */
void abc_vexp_neg(double C, double *v, size_t n);

/* out[i] = log1p(B x[i]) for i < n (B x[i] > -1 finite): the grid's lobe
 * exponents per B. */
void abc_vlog1p_mul(double B, const double *x, size_t n, double *out);

#endif
