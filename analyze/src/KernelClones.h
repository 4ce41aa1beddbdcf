#pragma once
// Internal to avatar::analyze: the per-pixel kernels are plain loops that GCC
// vectorises. It widens and narrows samples in vector registers only from
// SSE4.1 on, and uses the wider registers only when told, so each kernel is
// compiled for AVX-512F, AVX2, AVX and SSE4.1 as well (by feature, not CPU
// model, so any AVX-512 machine takes the first), and the best clone for the
// CPU is picked when the program loads (target_clones, an ifunc); the default
// clone is the portable loop for any x86-64.

#if defined(__GNUC__) && defined(__x86_64__) && !defined(__clang__)
#define AVATAR_KERNEL_CLONES __attribute__((target_clones("avx512f", "avx2", "avx", "sse4.1", "default")))
#else
#define AVATAR_KERNEL_CLONES
#endif

namespace avatar::detail {

/// Whether the CPU and the OS run AVX-512F code, for the hand-written
/// kernels that are picked at run time (the colour filter's ratio test, the
/// front end's demosaic): asked once, then constant.
inline bool cpuRunsAvx512f() {
#if defined(__GNUC__) && defined(__x86_64__)
    static const bool yes = [] {
        __builtin_cpu_init();  // a kernel may be chosen before the constructor that would call it has run
        return __builtin_cpu_supports("avx512f") != 0;
    }();
    return yes;
#else
    return false;
#endif
}

/// Whether the CPU and the OS run AVX-512BW code (16-bit lanes), likewise.
inline bool cpuRunsAvx512bw() {
#if defined(__GNUC__) && defined(__x86_64__)
    static const bool yes = [] {
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx512bw") != 0;
    }();
    return yes;
#else
    return false;
#endif
}

}  // namespace avatar::detail
