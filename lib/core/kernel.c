/* Which SIMD kernels this CPU runs. The sweep and encode each have a
 * portable path and vector paths: on x86-64, AVX2 and AVX-512 compiled with
 * target attributes, so one binary runs everywhere and uses what the CPU
 * has; on aarch64, NEON (Advanced SIMD, which every AArch64 CPU has: no run
 * time check). LOCD_KERNEL=scalar|avx2|avx512|neon in the environment caps
 * the choice (LOCD_SCALAR=1 is the old spelling of scalar); a name this CPU
 * has no kernel for leaves the best it has (avx512 on an AVX2 CPU: AVX2;
 * avx2 on ARM: NEON). The tests run every kernel and compare. An engine
 * chooses once, when it is created; a change of the variable applies to
 * engines created after it. */
#include "core/core.h"

#include <stdlib.h>

int lc_kernel_choose(void)
{
    const char *cap = getenv("LOCD_KERNEL"), *scalar = getenv("LOCD_SCALAR");
    int k = LC_KERNEL_SCALAR;
    if (scalar && scalar[0] == '1')
        return LC_KERNEL_SCALAR;
#if defined(__GNUC__) && defined(__x86_64__)
    if (__builtin_cpu_supports("avx2"))
        k = LC_KERNEL_AVX2;
    if (k == LC_KERNEL_AVX2 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
        __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512cd") &&
        __builtin_cpu_supports("bmi2"))
        k = LC_KERNEL_AVX512;
#elif defined(__GNUC__) && defined(__aarch64__) && defined(__ARM_NEON)
    k = LC_KERNEL_NEON;
#endif
    if (cap && strcmp(cap, "scalar") == 0)
        k = LC_KERNEL_SCALAR;
    else if (cap && strcmp(cap, "avx2") == 0 && k == LC_KERNEL_AVX512)
        k = LC_KERNEL_AVX2;
    return k;
}
