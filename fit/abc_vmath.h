/* Internal to fit/: the ABC fit's transcendental functions over arrays,
 * vectorised. Once everything else is shared per sample (docs/fitting.md),
 * a DS1 solve's time is mostly one log per sample and channel and the
 * lobe's log1p and exp per distinct 1 - n.h. */
#ifndef GONIO_FIT_ABC_VMATH_H
#define GONIO_FIT_ABC_VMATH_H

#include <stddef.h>

/* On x86-64 with GCC: an AVX2+FMA version of the function beside the
 * baseline one, chosen at load time (the binary stays portable): the
 * 4-wide libmvec functions. (Tried on the residual, normal-equation and
 * grid passes too: no measurable gain, so not there.) */
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define ABC_VCLONES __attribute__((target_clones("arch=haswell", "default")))
#else
#define ABC_VCLONES
#endif

/* v[i] = log(v[i]) for i < n. The inputs must be finite and > 0 (callers
 * pass ratios of 1 + f cos theta_i >= 1 terms). Within 4 ulp of log(). */
void abc_vlog(double *v, size_t n);

/* The lobe D = (1 + B x)^-C of brdf_abc_distribution and its derivatives,
 * for x[i] >= 0, i < n, B, C >= 0 finite: out[3i] = D, out[3i+1] = dD/dB,
 * out[3i+2] = dD/dC. Within a few ulp of brdf_abc_distribution. */
void abc_vlobe(double B, double C, const double *x, size_t n, double *out);

/* The Fresnel term of brdf_abc_fresnel and dF/deta at v.h = vh[i], i < n
 * (eta >= 1 finite): out[2i] = F, out[2i+1] = dF/deta. */
void abc_vfresnel(double eta, const double *vh, size_t n, double *out);

/* v[i] = exp(-C v[i]) for i < n (v[i], C finite): the lobe from a stored
 * log1p(B x). */
void abc_vexp_neg(double C, double *v, size_t n);

#endif
