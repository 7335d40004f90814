/* abc_vlog: compiled alone with -O3 -ffast-math (fit/CMakeLists.txt) so
 * that GCC turns the loop into calls of glibc's vector log (libmvec,
 * declared by <math.h> under __FAST_MATH__): 2 or 4 logs per call, about
 * 2.5x faster than the scalar loop on 2736 values. Fast-math is harmless
 * here: the inputs are finite and positive by contract, and nothing else
 * lives in this file. target_clones builds an AVX2 version beside the
 * baseline one and picks at load time, so the binary stays portable. */
#include "fit/abc_vlog.h"

#include <math.h>

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx2", "default")))
#endif
void abc_vlog(double *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        v[i] = log(v[i]);
}
