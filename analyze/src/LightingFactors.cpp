// The lighting factors' row kernel (LightingFactors.h). Compiled without
// contraction into fused multiply-adds, without errno from sqrt and with
// finite arithmetic assumed (analyze/CMakeLists.txt), so that the same bits
// come out of every SIMD clone and every machine and GCC vectorises it; its
// inputs are validated finite numbers.

#include "LightingFactors.h"

#include "KernelClones.h"

#include <cmath>
#include <cstdint>
#include <cstring>

namespace avatar::detail {
namespace {

/// exp(x) for |x| <= 700 to within two units in the last place, from IEEE
/// additions and multiplications only: x = k ln2 + r (Cody-Waite, k the nearest integer), exp(r) by
/// its Taylor series to degree 13 (below half an ulp for |r| <= ln2/2), 2^k
/// put into the exponent bits. With this file compiled without contraction
/// into fused multiply-adds (-ffp-contract=off), every machine and every SIMD
/// clone computes the same factors bit for bit (a recorded session replays
/// identically anywhere), which libm's exp, whose result may depend on the
/// CPU, does not promise; and GCC vectorises the loop around it.
double expExact(double x) {
    x = std::fmin(std::fmax(x, -700.0), 700.0);
    // k = x / ln2 rounded to the nearest integer: adding and taking away 1.5 * 2^52
    // leaves no fraction (round to nearest, the IEEE default).
    const double k = (x * 1.4426950408889634 + 6755399441055744.0) - 6755399441055744.0;
    const double r = (x - k * 6.93147180369123816490e-01) - k * 1.90821492927058770002e-10;
    double p = 1.0 / 6227020800.0;
    p = p * r + 1.0 / 479001600.0;
    p = p * r + 1.0 / 39916800.0;
    p = p * r + 1.0 / 3628800.0;
    p = p * r + 1.0 / 362880.0;
    p = p * r + 1.0 / 40320.0;
    p = p * r + 1.0 / 5040.0;
    p = p * r + 1.0 / 720.0;
    p = p * r + 1.0 / 120.0;
    p = p * r + 1.0 / 24.0;
    p = p * r + 1.0 / 6.0;
    p = p * r + 0.5;
    p = p * r + 1.0;
    p = p * r + 1.0;
    // 2^k: k sits in the low mantissa bits of k + 1.5 * 2^52; shifted into the exponent field.
    const double shifted = k + 6755399441055744.0;
    std::uint64_t bits;
    std::memcpy(&bits, &shifted, sizeof bits);
    bits = (bits + 1023u) << 52;
    double scale;
    std::memcpy(&scale, &bits, sizeof scale);
    return p * scale;
}

/// One row of factors: element i is pixel xs[i]'s factor of the channel whose
/// exponent and gain * coefficient are e[i] and m[i], times the template's t[i]:
/// m * exp(e * d) * t, d the distance from (ox, oy), clamped to [0, kMaxFactor].
}  // namespace

AVATAR_KERNEL_CLONES void lightingFactorRow(const double* __restrict xs, const double* __restrict e,
                                    const double* __restrict m, const double* __restrict t, double dy2, double ox,
                                    float* __restrict out, int n) {
    for (int i = 0; i < n; ++i) {
        const double dx = xs[i] - ox;
        const double d = std::sqrt(dx * dx + dy2);
        double f = m[i] * expExact(e[i] * d) * t[i];
        f = std::fmin(std::fmax(f, 0.0), static_cast<double>(kMaxFactor));
        out[i] = static_cast<float>(f);
    }
}

}  // namespace avatar::detail
