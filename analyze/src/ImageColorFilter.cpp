#include <avatar/analyze/ImageColorFilter.h>

#include "ColorFilterKernel.h"
#include "KernelClones.h"

#include <avatar/analyze/ImageFeatureLocator.h>
#include <avatar/common/Error.h>
#include <avatar/config/ConfigXml.h>

#include <opencv2/core.hpp>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>

namespace avatar {
namespace {

// ---------------------------------------------------------------------------
// Exact thresholds.
//
// Every colour test here is "num/den >= x" or "num/den <= x" for integer
// samples num, den in [0, N] (N = 255 or 65535, the container's maximum) and a
// double limit x. Its outcome depends only on which fractions p/q (0 <= p <= N,
// 1 <= q <= N) lie on which side of x. Let lo be the largest fraction that
// fails "p/q >= x" (or passes "p/q <= x") and hi the smallest that passes (or
// fails); lo and hi are neighbours in the Stern-Brocot tree truncated at N, so
// hi - lo >= 1/N^2. Any value m strictly between them gives the same outcome for
// every pixel, and with m at least (hi - lo)/2 away from both, m*den can be
// rounded to float or double without the comparison with num changing sign
// as long as the rounding error stays below den*(hi - lo)/2: always so in
// double, checked per limit for float (limitIsExact). So each limit is replaced
// once by such an m, and the per-pixel test is one multiplication and one
// comparison that is exact, NaN-free and scale-invariant (8-bit and 16-bit
// images that are multiples of each other give identical masks).
// ---------------------------------------------------------------------------

constexpr double kMinLimit = 1.0 / (1 << 20);  // below 1/N for every N <= 2^16
constexpr double kMaxLimit = 1 << 20;          // above N

/// The exact sign of p/q - x for 0 <= p, 1 <= q, p, q <= 2^17 and x in
/// [kMinLimit, kMaxLimit]. x is split into a 26-bit head and a 27-bit tail so
/// that both products with q are exact; p - head*q is exact whenever the two
/// are within a factor 2 (Sterbenz), and otherwise far larger than tail*q.
int compareFraction(double p, double q, double x) {
    int e = 0;
    const double f = std::frexp(x, &e);
    const double head = std::ldexp(std::trunc(std::ldexp(f, 26)), e - 26);
    const double tail = x - head;
    const double d = p - head * q;
    const double t = tail * q;
    return d > t ? 1 : (d < t ? -1 : 0);
}

/// Which fractions pass a limit test.
enum class Bound {
    Lower,  ///< p/q >= x passes
    Upper   ///< p/q <= x passes
};

/// The fractions next to a limit: every fraction p/q (0 <= p <= N, 1 <= q <= N)
/// either passes or fails the limit test, and the ones that fail "p/q >= x"
/// (pass "p/q <= x") are all <= a/b, the others all >= c/d.
struct Neighbours {
    enum Kind { AllAbove, AllBelow, Between } kind{Between};
    double a{0}, b{1}, c{1}, d{0};
};

Neighbours neighbours(double x, Bound bound, std::uint32_t n) {
    Neighbours nb;
    const double nd = n;
    if ((bound == Bound::Lower && !(x > 0.0)) || x < 0.0) {
        nb.kind = Neighbours::AllAbove;  // Lower: everything passes; Upper: nothing does
        return nb;
    }
    if (x > nd || (x == nd && bound == Bound::Upper)) {
        nb.kind = Neighbours::AllBelow;  // Lower: no finite ratio passes; Upper: all do
        return nb;
    }
    const double xc = std::clamp(x, kMinLimit, kMaxLimit);  // same classes for these p, q
    const auto above = [&](double p, double q) {
        const int s = compareFraction(p, q, xc);
        return bound == Bound::Lower ? s >= 0 : s > 0;
    };
    if (!above(nd, 1.0)) {
        nb.kind = Neighbours::AllBelow;
        return nb;
    }
    // Stern-Brocot descent from 0/1 (below, since x > 0 here) and 1/0 (above),
    // moving the bound that the mediant replaces as far as it can go in one
    // step (binary search over the multiple): O(log^2 N) comparisons.
    double a = 0, b = 1, c = 1, d = 0;
    while (a + c <= nd && b + d <= nd) {
        const bool up = above(a + c, b + d);
        // The bound that moves: (c, d) += k (a, b) when the mediant is above,
        // (a, b) += k (c, d) otherwise; k as large as stays on its side and within N.
        double& mp = up ? c : a;
        double& mq = up ? d : b;
        const double sp = up ? a : c;
        const double sq = up ? b : d;
        double kMax = sp > 0 ? std::floor((nd - mp) / sp) : nd;
        kMax = std::min(kMax, sq > 0 ? std::floor((nd - mq) / sq) : nd);
        double lo = 1, hi = kMax;
        while (lo < hi) {
            const double mid = std::floor((lo + hi + 1) / 2);
            if (above(mp + mid * sp, mq + mid * sq) == up) lo = mid; else hi = mid - 1;
        }
        mp += lo * sp;
        mq += lo * sq;
    }
    // d >= 1: N/1 is above, so the upper bound has left 1/0.
    nb.a = a;
    nb.b = b;
    nb.c = c;
    nb.d = d;
    return nb;
}

/// The replacement m of a limit in type T: for Bound::Lower the pixel test is
/// m*den <= num, for Bound::Upper num <= m*den. -1 when every fraction is
/// above the limit, N + 1 when every finite one is below; both products are
/// exact or on the right side of every num for any den <= N.
template <typename T>
T limitValue(const Neighbours& nb, std::uint32_t n) {
    switch (nb.kind) {
        case Neighbours::AllAbove: return T(-1);
        case Neighbours::AllBelow: return static_cast<T>(n + 1.0);
        case Neighbours::Between: break;
    }
    return static_cast<T>((nb.a / nb.b + nb.c / nb.d) / 2);
}

/// True when m = limitValue<T>() is far enough from a/b and c/d that m*den,
/// rounded to T, is on the same side of every num as the exact product:
/// |m*den - num| >= den * dist while the rounding error is <= den * m * eps/2.
template <typename T>
bool limitIsExact(const Neighbours& nb, std::uint32_t n) {
    if (nb.kind != Neighbours::Between) return true;
    const double m = limitValue<T>(nb, n);
    const double dist = std::min(m - nb.a / nb.b, nb.c / nb.d - m);
    // eps (not eps/2) leaves room for the rounding of a/b and c/d themselves.
    return dist > m * static_cast<double>(std::numeric_limits<T>::epsilon());
}

template <typename T>
T exactLimit(double x, Bound bound, std::uint32_t n) {
    return limitValue<T>(neighbours(x, bound, n), n);
}

// ---------------------------------------------------------------------------
// Per-type plans and row kernels (KernelClones.h: each is also compiled for
// AVX2, AVX and SSE4.1, the best picked when the program loads).
// ---------------------------------------------------------------------------

template <typename T>
struct RatioLimits {
    T rgLo, rgHi, rbLo, rbHi, bgLo, bgHi;  // exact replacements, see exactLimit()
    T sumLo, sumHi;                        // integer limits on R+G+B
    bool rgOpen, rbOpen, bgOpen;           // max >= kOpenMax: +infinity (x/0) passes
};

/// A max at least this is no upper bound: it is above every finite ratio of
/// 8- and 16-bit samples, so +infinity (a clipped denominator) passes it too.
constexpr double kOpenMax = 65536.0;

template <typename T>
struct HsvLimits {
    float hueLo, hueHi;    // degrees
    bool hueWraps;         // min > max: passes hue >= lo OR hue <= hi
    T satLo, satHi;        // exact replacements for (max-min)/max
    bool blackSatPasses;   // saturation of a black pixel (defined as 0) is in range
    T valLo, valHi;        // integer limits on max(R, G, B)
};

/// RGB-ratio test (thesis Figure 3-8) on one row span of planar samples (the
/// integer sample values held in floats, exact up to 2^24). Branch-free so
/// that GCC vectorises it at -O3: each of the six ratio limits costs one
/// multiply and one compare in T, and the verdict is a 0/255 byte. The planes
/// are contiguous, so no de-interleaving is needed per type.
template <typename T>
AVATAR_KERNEL_CLONES void ratioRow(const float* __restrict pb, const float* __restrict pg, const float* __restrict pr,
                                   std::uint8_t* __restrict out, int n, const RatioLimits<T>& lim) {
    const T rgLo = lim.rgLo, rgHi = lim.rgHi, rbLo = lim.rbLo, rbHi = lim.rbHi;
    const T bgLo = lim.bgLo, bgHi = lim.bgHi, sumLo = lim.sumLo, sumHi = lim.sumHi;
    const bool rgOpen = lim.rgOpen, rbOpen = lim.rbOpen, bgOpen = lim.bgOpen;
    for (int i = 0; i < n; ++i) {
        const T b = static_cast<T>(pb[i]);
        const T g = static_cast<T>(pg[i]);
        const T r = static_cast<T>(pr[i]);
        const T sum = b + g + r;  // exact: at most 3 * 65535 < 2^24
        // With a zero denominator both products are 0: lo * 0 <= num always
        // holds (+infinity and 0/0 pass every min), num <= hi * 0 only for 0/0,
        // and +infinity passes the max only when it is open (see the header).
        // A black pixel (sum 0) fails.
        const bool ok = (sum > T(0)) & (rgLo * g <= r) & ((r <= rgHi * g) | (rgOpen & (g == T(0)))) &
                        (rbLo * b <= r) & ((r <= rbHi * b) | (rbOpen & (b == T(0)))) & (bgLo * g <= b) &
                        ((b <= bgHi * g) | (bgOpen & (g == T(0)))) & (sum >= sumLo) & (sum <= sumHi);
        out[i] = static_cast<std::uint8_t>(ok ? 255 : 0);
    }
}

#if defined(__GNUC__) && defined(__x86_64__)
#define AVATAR_RATIO_AVX512 1
#define AVATAR_AVX512F __attribute__((target("avx512f")))

// ---------------------------------------------------------------------------
// ratioRow with AVX-512F intrinsics. Even in its avx512f clone GCC compiles
// ratioRow to 256-bit vectors with register spills and turns each compare
// result into bytes through vector blends and packs (191 instructions per 32
// pixels, the largest share of the fused front end). Here the compares of 16
// pixels go into mask registers (a masked compare tests only the lanes still
// passing) and the mask becomes the 16 verdict bytes in two instructions:
// 30 instructions per 16 pixels. The operations are ratioRow's, in its order and type: each
// product limit * sample rounded once, then compared (no product feeds an
// addition, so nothing can be fused into an FMA), the sum added as b + g + r;
// so the verdicts are ratioRow's bit for bit (ColorFilterTest checks it). The
// portable ratioRow stays the kernel for CPUs without AVX-512F (chosen once,
// when the plan is made: see ratioRowFor()).
// ---------------------------------------------------------------------------

/// One zmm register of T (16 floats or 8 doubles) and its compare mask.
template <typename T>
struct Zmm;

template <>
struct Zmm<float> {
    using V = __m512;
    using M = __mmask16;
    static AVATAR_AVX512F V set1(float x) { return _mm512_set1_ps(x); }
    static AVATAR_AVX512F V add(V a, V b) { return _mm512_add_ps(a, b); }
    static AVATAR_AVX512F V mul(V a, V b) { return _mm512_mul_ps(a, b); }
    /// a P b in the lanes of k, 0 elsewhere.
    template <int P>
    static AVATAR_AVX512F M cmp(M k, V a, V b) {
        return _mm512_mask_cmp_ps_mask(k, a, b, P);
    }
};

template <>
struct Zmm<double> {
    using V = __m512d;
    using M = __mmask8;
    static AVATAR_AVX512F V set1(double x) { return _mm512_set1_pd(x); }
    static AVATAR_AVX512F V add(V a, V b) { return _mm512_add_pd(a, b); }
    static AVATAR_AVX512F V mul(V a, V b) { return _mm512_mul_pd(a, b); }
    template <int P>
    static AVATAR_AVX512F M cmp(M k, V a, V b) {
        return _mm512_mask_cmp_pd_mask(k, a, b, P);
    }
};

/// RatioLimits<T> broadcast to registers, the open maxima as all-lane masks.
template <typename T>
struct ZmmRatioLimits {
    using Z = Zmm<T>;
    typename Z::V rgLo, rgHi, rbLo, rbHi, bgLo, bgHi, sumLo, sumHi;
    typename Z::M rgOpen, rbOpen, bgOpen;

    AVATAR_AVX512F explicit ZmmRatioLimits(const RatioLimits<T>& lim)
        : rgLo(Z::set1(lim.rgLo)), rgHi(Z::set1(lim.rgHi)), rbLo(Z::set1(lim.rbLo)), rbHi(Z::set1(lim.rbHi)),
          bgLo(Z::set1(lim.bgLo)), bgHi(Z::set1(lim.bgHi)), sumLo(Z::set1(lim.sumLo)), sumHi(Z::set1(lim.sumHi)),
          rgOpen(lim.rgOpen ? typename Z::M(~0u) : 0), rbOpen(lim.rbOpen ? typename Z::M(~0u) : 0),
          bgOpen(lim.bgOpen ? typename Z::M(~0u) : 0) {}
};

/// The two parts of ratioRow's verdict. The ordered non-signalling
/// predicates (_OQ) are C++'s <=, >=, > and ==, false for NaN.
///
/// ratioMinima(): the lanes of @p valid whose three ratios reach their
/// minima. A target's colour is a small part of an image, so for most pixels
/// this already says no (ratioRowAvx512 skips the rest for them).
template <typename T>
AVATAR_AVX512F inline typename Zmm<T>::M ratioMinima(typename Zmm<T>::M valid, typename Zmm<T>::V b,
                                                     typename Zmm<T>::V g, typename Zmm<T>::V r,
                                                     const ZmmRatioLimits<T>& l) {
    using Z = Zmm<T>;
    typename Z::M k = Z::template cmp<_CMP_LE_OQ>(valid, Z::mul(l.rgLo, g), r);
    k = Z::template cmp<_CMP_LE_OQ>(k, Z::mul(l.rbLo, b), r);
    return Z::template cmp<_CMP_LE_OQ>(k, Z::mul(l.bgLo, g), b);
}

/// ratioMaxima(): the lanes of @p k (ratioMinima()'s) whose ratios stay
/// within their maxima and whose sum is positive and within the band: two
/// chains of compares ANDed at the end rather than one, so that their
/// compares need not wait for each other. @p Open: some maximum is open
/// (RatioLimits); without one the zero-denominator terms are 0 and left out.
template <typename T, bool Open>
AVATAR_AVX512F inline typename Zmm<T>::M ratioMaxima(typename Zmm<T>::M k, typename Zmm<T>::V b,
                                                     typename Zmm<T>::V g, typename Zmm<T>::V r,
                                                     const ZmmRatioLimits<T>& l) {
    using Z = Zmm<T>;
    using M = typename Z::M;
    const typename Z::V zero = Z::set1(T(0));
    const typename Z::V sum = Z::add(Z::add(b, g), r);
    M kSum = Z::template cmp<_CMP_GT_OQ>(k, sum, zero);
    kSum = Z::template cmp<_CMP_GE_OQ>(kSum, sum, l.sumLo);
    kSum = Z::template cmp<_CMP_LE_OQ>(kSum, sum, l.sumHi);
    if constexpr (Open) {
        // A max passes num <= hi * den, or when it is open a zero denominator (+infinity).
        const M gZero = Z::template cmp<_CMP_EQ_OQ>(k, g, zero);
        const M bZero = Z::template cmp<_CMP_EQ_OQ>(k, b, zero);
        const M rgMax = Z::template cmp<_CMP_LE_OQ>(k, r, Z::mul(l.rgHi, g)) | (gZero & l.rgOpen);
        const M rbMax = Z::template cmp<_CMP_LE_OQ>(k, r, Z::mul(l.rbHi, b)) | (bZero & l.rbOpen);
        const M bgMax = Z::template cmp<_CMP_LE_OQ>(k, b, Z::mul(l.bgHi, g)) | (gZero & l.bgOpen);
        return kSum & rgMax & rbMax & bgMax;
    } else {
        M kMax = Z::template cmp<_CMP_LE_OQ>(k, r, Z::mul(l.rgHi, g));
        kMax = Z::template cmp<_CMP_LE_OQ>(kMax, r, Z::mul(l.rbHi, b));
        kMax = Z::template cmp<_CMP_LE_OQ>(kMax, b, Z::mul(l.bgHi, g));
        return kSum & kMax;
    }
}

/// Which part of the verdict ratioMask16() gives.
enum class RatioPart { Minima, Maxima };

// The all-lanes masks below (maskz_ forms of unmasked operations) only keep
// GCC 12 from warning about the undefined source register of the unmasked
// intrinsics (-Wmaybe-uninitialized); the code is the same.

/// The 16 verdict bytes (0 or 255) of a mask, one per lane.
AVATAR_AVX512F inline __m128i verdictBytes(__mmask16 k) {
    return _mm512_maskz_cvtepi32_epi8(0xFFFF, _mm512_maskz_mov_epi32(k, _mm512_set1_epi32(255)));
}

/// One part of the verdict of the 16 pixels at @p i: ratioMinima() of the
/// lanes in @p k, or ratioMaxima() of those of them that reached the minima
/// (@p k, ratioMinima()'s result). Only the lanes of @p k are read.
template <RatioPart Part, bool Open>
AVATAR_AVX512F inline __mmask16 ratioMask16(const float* pb, const float* pg, const float* pr, int i, __mmask16 k,
                                            const ZmmRatioLimits<float>& l) {
    const __m512 b = _mm512_maskz_loadu_ps(k, pb + i), g = _mm512_maskz_loadu_ps(k, pg + i),
                 r = _mm512_maskz_loadu_ps(k, pr + i);
    if constexpr (Part == RatioPart::Minima) return ratioMinima<float>(k, b, g, r, l);
    else return ratioMaxima<float, Open>(k, b, g, r, l);
}

/// Lanes 0-7 (@p Half 0) or 8-15 (1) of 16 floats widened to double (exact).
template <int Half>
AVATAR_AVX512F inline __m512d widenHalf(__m512 v) {
    const __m256d half = _mm512_maskz_extractf64x4_pd(0xF, _mm512_castps_pd(v), Half);
    return _mm512_maskz_cvtps_pd(0xFF, _mm256_castpd_ps(half));
}

/// The same in double (as ratioRow<double>): the 16 samples widened, as two
/// halves of 8.
template <RatioPart Part, bool Open>
AVATAR_AVX512F inline __mmask16 ratioMask16(const float* pb, const float* pg, const float* pr, int i, __mmask16 k,
                                            const ZmmRatioLimits<double>& l) {
    const __m512 b = _mm512_maskz_loadu_ps(k, pb + i);
    const __m512 g = _mm512_maskz_loadu_ps(k, pg + i);
    const __m512 r = _mm512_maskz_loadu_ps(k, pr + i);
    const auto part = [&](__mmask8 lanes, const __m512d& bh, const __m512d& gh, const __m512d& rh) {
        if constexpr (Part == RatioPart::Minima) return ratioMinima<double>(lanes, bh, gh, rh, l);
        else return ratioMaxima<double, Open>(lanes, bh, gh, rh, l);
    };
    const __mmask8 kLow = part(static_cast<__mmask8>(k), widenHalf<0>(b), widenHalf<0>(g), widenHalf<0>(r));
    const __mmask8 kHigh = part(static_cast<__mmask8>(k >> 8), widenHalf<1>(b), widenHalf<1>(g), widenHalf<1>(r));
    return static_cast<__mmask16>(kLow | (kHigh << 8));
}

/// The single limits that can reject a pixel on their own (each one
/// conjunct of the verdict), as prefilters for ratioRowAvx512: 0-2 the
/// minima of R/G, R/B, B/G (when above 0), 3-5 their maxima (when closed).
struct Prefilters {
    std::array<int, 6> tests{};
    int count{0};

    template <typename T>
    explicit Prefilters(const RatioLimits<T>& lim) {
        const bool usable[6] = {lim.rgLo > T(0), lim.rbLo > T(0), lim.bgLo > T(0),
                                !lim.rgOpen,     !lim.rbOpen,     !lim.bgOpen};
        for (int t = 0; t < 6; ++t)
            if (usable[t]) tests[static_cast<std::size_t>(count++)] = t;
    }
};

/// The lanes of the 16 pixels at @p i that pass limit @p test (Prefilters)
/// alone: one multiply and one compare on the two planes it reads.
AVATAR_AVX512F inline __mmask16 limitPasses(int test, const float* pb, const float* pg, const float* pr, int i,
                                            const ZmmRatioLimits<float>& l) {
    switch (test) {
    case 0: return _mm512_cmp_ps_mask(_mm512_mul_ps(l.rgLo, _mm512_loadu_ps(pg + i)), _mm512_loadu_ps(pr + i), _CMP_LE_OQ);
    case 1: return _mm512_cmp_ps_mask(_mm512_mul_ps(l.rbLo, _mm512_loadu_ps(pb + i)), _mm512_loadu_ps(pr + i), _CMP_LE_OQ);
    case 2: return _mm512_cmp_ps_mask(_mm512_mul_ps(l.bgLo, _mm512_loadu_ps(pg + i)), _mm512_loadu_ps(pb + i), _CMP_LE_OQ);
    case 3: return _mm512_cmp_ps_mask(_mm512_loadu_ps(pr + i), _mm512_mul_ps(l.rgHi, _mm512_loadu_ps(pg + i)), _CMP_LE_OQ);
    case 4: return _mm512_cmp_ps_mask(_mm512_loadu_ps(pr + i), _mm512_mul_ps(l.rbHi, _mm512_loadu_ps(pb + i)), _CMP_LE_OQ);
    default: return _mm512_cmp_ps_mask(_mm512_loadu_ps(pb + i), _mm512_mul_ps(l.bgHi, _mm512_loadu_ps(pg + i)), _CMP_LE_OQ);
    }
}

/// ratioRow with AVX-512F: 16 pixels a step, the last n % 16 with masked
/// loads and a masked store (nothing outside the n pixels is read or written).
template <typename T, bool Open>
AVATAR_AVX512F bool ratioRowAvx512(const float* pb, const float* pg, const float* pr, std::uint8_t* out, int n,
                                   const ZmmRatioLimits<T>& l, const Prefilters& pre) {
    int i = 0;
    __mmask16 passed = 0;  // the lanes that passed in some step
    // 64 pixels a step: one limit alone first (in float), then their minima,
    // and the rest only when some lane is left. Most steps of an image are
    // background that fails a limit, and one branch per 64 pixels is one the
    // CPU predicts, also in a tracking frame's regions around the targets (a
    // branch per 16 pixels missed there at every edge of a target). The
    // limit tried alone is the one that rejected the last steps: after a step
    // it let through that the whole test then rejected, the next is tried
    // (the background decides which limit it fails; any one is exact, as
    // each is a conjunct of the verdict).
    int current = 0;
    for (; i + 64 <= n; i += 64) {
        if constexpr (std::is_same_v<T, float>) {
            if (pre.count > 0) {
                const int test = pre.tests[static_cast<std::size_t>(current)];
                if ((limitPasses(test, pb, pg, pr, i, l) | limitPasses(test, pb, pg, pr, i + 16, l) |
                     limitPasses(test, pb, pg, pr, i + 32, l) | limitPasses(test, pb, pg, pr, i + 48, l)) == 0) {
                    _mm512_storeu_si512(out + i, _mm512_setzero_si512());
                    continue;
                }
            }
        }
        __mmask16 k[4];
        for (int j = 0; j < 4; ++j)
            k[j] = ratioMask16<RatioPart::Minima, Open>(pb, pg, pr, i + 16 * j, 0xFFFF, l);
        __mmask16 any = 0;
        if ((k[0] | k[1] | k[2] | k[3]) == 0) {
            _mm512_storeu_si512(out + i, _mm512_setzero_si512());
        } else {
            for (int j = 0; j < 4; ++j) {
                const __mmask16 v = ratioMask16<RatioPart::Maxima, Open>(pb, pg, pr, i + 16 * j, k[j], l);
                any = static_cast<__mmask16>(any | v);
                _mm_storeu_si128(reinterpret_cast<__m128i*>(out + i + 16 * j), verdictBytes(v));
            }
        }
        if (any == 0 && pre.count > 0) current = (current + 1) % pre.count;
        passed = static_cast<__mmask16>(passed | any);
    }
    for (; i < n; i += 16) {
        const auto valid = static_cast<__mmask16>(n - i >= 16 ? 0xFFFFu : (1u << (n - i)) - 1u);
        const __mmask16 k = ratioMask16<RatioPart::Maxima, Open>(
            pb, pg, pr, i, ratioMask16<RatioPart::Minima, Open>(pb, pg, pr, i, valid, l), l);
        _mm512_mask_cvtepi32_storeu_epi8(out + i, valid, _mm512_maskz_mov_epi32(k, _mm512_set1_epi32(255)));
        passed = static_cast<__mmask16>(passed | k);
    }
    return passed != 0;
}

/// Returns whether any pixel passed (exact).
template <typename T>
AVATAR_AVX512F bool ratioRowAvx512(const float* pb, const float* pg, const float* pr, std::uint8_t* out, int n,
                                   const RatioLimits<T>& lim) {
    const ZmmRatioLimits<T> l(lim);
    const Prefilters pre(lim);
    if (lim.rgOpen || lim.rbOpen || lim.bgOpen) return ratioRowAvx512<T, true>(pb, pg, pr, out, n, l, pre);
    return ratioRowAvx512<T, false>(pb, pg, pr, out, n, l, pre);
}

#undef AVATAR_AVX512F
#endif

/// A row kernel of the ratio test: ratioRowPortable<T> or ratioRowAvx512<T>;
/// false when no pixel passed, true when some may have.
template <typename T>
using RatioKernel = bool (*)(const float* pb, const float* pg, const float* pr, std::uint8_t* out, int n,
                             const RatioLimits<T>& lim);

/// ratioRow as a RatioKernel: it does not tell whether a pixel passed.
template <typename T>
bool ratioRowPortable(const float* pb, const float* pg, const float* pr, std::uint8_t* out, int n,
                      const RatioLimits<T>& lim) {
    ratioRow<T>(pb, pg, pr, out, n, lim);
    return true;
}

/// HSV test on one row span of planar samples. Hue is computed in float with
/// one division (correctly rounded, so it depends only on the ratio of the
/// samples); saturation and value use exact limits like the ratio test.
/// Written with integer 0/1 flags and selects between constants only: GCC does
/// not if-convert a select whose arm is a floating-point operation (it might
/// trap), and a loop with control flow is not vectorised.
template <typename T>
AVATAR_KERNEL_CLONES void hsvRow(const float* __restrict pb, const float* __restrict pg, const float* __restrict pr,
                                 std::uint8_t* __restrict out, int n, const HsvLimits<T>& lim) {
    const float hueLo = lim.hueLo, hueHi = lim.hueHi;
    const bool wraps = lim.hueWraps, blackOk = lim.blackSatPasses;
    const T satLo = lim.satLo, satHi = lim.satHi, valLo = lim.valLo, valHi = lim.valHi;
    const std::int32_t wrapsI = wraps, blackI = blackOk;
    for (int i = 0; i < n; ++i) {
        const auto b = static_cast<std::int32_t>(pb[i]);
        const auto g = static_cast<std::int32_t>(pg[i]);
        const auto r = static_cast<std::int32_t>(pr[i]);
        const std::int32_t mx = std::max(std::max(b, g), r);
        const std::int32_t mn = std::min(std::min(b, g), r);
        const std::int32_t c = mx - mn;
        // Hue sector by the largest channel (ties: red, then green). A grey
        // pixel (c = 0) takes the red sector with num = 0: hue 0, as cv::cvtColor.
        const bool isR = mx == r;
        const bool isG = !isR & (mx == g);
        const bool isB = !isR & !isG;
        const std::int32_t num = isR * (g - b) + isG * (b - r) + isB * (r - g);
        const std::int32_t off = 120 * isG + 240 * isB;
        const float den = static_cast<float>(std::max(c, 1));
        const float h = 60.0f * (static_cast<float>(num) / den) + static_cast<float>(off);
        const float hue = h + (h < 0.0f ? 360.0f : 0.0f);
        const std::int32_t aboveLo = hue >= hueLo;
        const std::int32_t belowHi = hue <= hueHi;
        // Without wrap-around both must hold; with it (lo > hi) they cannot
        // both hold and either suffices.
        const std::int32_t hueOk = (aboveLo & belowHi) | (wrapsI & (aboveLo | belowHi));
        const T mxT = static_cast<T>(mx);
        const T cT = static_cast<T>(c);
        const std::int32_t satRatioOk = (satLo * mxT <= cT) & (cT <= satHi * mxT);
        const std::int32_t positive = mx > 0;
        const std::int32_t satOk = (positive & satRatioOk) | ((1 - positive) & blackI);
        const std::int32_t valOk = (mxT >= valLo) & (mxT <= valHi);
        out[i] = static_cast<std::uint8_t>(-(hueOk & satOk & valOk));
    }
}

/// Interleaved BGR samples to three float planes (exact), once per row for
/// every type. GCC vectorises the stride-3 loads with their widening from
/// SSE4.1 on, hence the clones.
template <typename S>
AVATAR_KERNEL_CLONES void splitRowKernel(const S* __restrict px, float* __restrict b, float* __restrict g,
                                         float* __restrict r, int n) {
    for (int i = 0; i < n; ++i) {
        b[i] = static_cast<float>(static_cast<std::int32_t>(px[3 * i]));
        g[i] = static_cast<float>(static_cast<std::int32_t>(px[3 * i + 1]));
        r[i] = static_cast<float>(static_cast<std::int32_t>(px[3 * i + 2]));
    }
}

}  // namespace

/// Everything one type needs for one image size and depth: its clipped window
/// and its row kernel with its limits. An RGB-ratio type is one or more
/// segments: the limits for one interval of R+G+B (a brightness band, or what
/// lies between bands); a pixel passes when it passes the segment of its
/// brightness. Without bands, one segment.
struct detail::ColorTest::Plan {
    /// False when no pixel passed, true when some may have.
    using Row = bool (*)(const float* b, const float* g, const float* r, std::uint8_t* out, int n, const Plan& plan,
                         std::uint8_t* scratch);
    cv::Rect window;
    Row row{nullptr};
    std::vector<RatioLimits<float>> ratioF;
    std::vector<RatioLimits<double>> ratioD;
    /// With a veil: its hull's bounding box as ratio limits (one segment, in
    /// ratioF or ratioD's type, a little wider: it only preselects), and the
    /// hull's edges as a R + b G + c B >= 0 (veilRow), kMaxVeilEdges of them.
    std::vector<RatioLimits<float>> veilBoundsF;
    std::vector<RatioLimits<double>> veilBoundsD;
    std::vector<float> veilEdges;
    HsvLimits<float> hsvF{};
    HsvLimits<double> hsvD{};
};

namespace {

using Plan = detail::ColorTest::Plan;

/// The most edges a veil's hull has: the hull of a convex polygon of at most
/// six vertices (a box cut by two R/B lines) and a copy of it shrunk towards
/// a point has at most two more.
constexpr std::size_t kMaxVeilEdges = 8;

/// Sets out[i] to 255 where box[i] (the hull's bounding box passed), G > 0
/// and every edge e of the hull holds, e[0] R + e[1] G + e[2] B >= 0 (unused
/// edges are 0, which holds); returns how many it set.
AVATAR_KERNEL_CLONES int veilRow(const float* __restrict b, const float* __restrict g, const float* __restrict r,
                                 const std::uint8_t* __restrict box, std::uint8_t* __restrict out, int n,
                                 const float* __restrict edges) {
    int set = 0;
    for (int i = 0; i < n; ++i) {
        float low = g[i] > 0.0f ? 0.0f : -1.0f;
        for (std::size_t k = 0; k < kMaxVeilEdges; ++k)
            low = std::min(low, edges[3 * k] * r[i] + edges[3 * k + 1] * g[i] + edges[3 * k + 2] * b[i]);
        const bool pass = box[i] != 0 && low >= 0.0f && out[i] == 0;
        set += pass;
        out[i] = pass ? std::uint8_t{255} : out[i];
    }
    return set;
}

/// @p Kernel: ratioRow<T> or ratioRowAvx512<T> (ratioRowFor()).
template <typename T, RatioKernel<T> Kernel>
bool ratioRowErased(const float* b, const float* g, const float* r, std::uint8_t* out, int n, const Plan& plan,
                    std::uint8_t* scratch) {
    const auto& segments = [&]() -> const std::vector<RatioLimits<T>>& {
        if constexpr (std::is_same_v<T, float>) return plan.ratioF;
        else return plan.ratioD;
    }();
    if (segments.empty()) {
        std::memset(out, 0, static_cast<std::size_t>(n));
        return false;
    }
    bool any = Kernel(b, g, r, out, n, segments[0]);
    // Segments hold disjoint brightness intervals, but for a water's ranges.
    for (std::size_t k = 1; k < segments.size(); ++k) {
        if (!Kernel(b, g, r, scratch, n, segments[k])) continue;
        any = true;
        for (int i = 0; i < n; ++i) out[i] |= scratch[i];
    }
    const auto& veilBounds = [&]() -> const std::vector<RatioLimits<T>>& {
        if constexpr (std::is_same_v<T, float>) return plan.veilBoundsF;
        else return plan.veilBoundsD;
    }();
    // A veil goes with no brightness bands (validateTargetType), so scratch is free.
    if (veilBounds.empty() || !Kernel(b, g, r, scratch, n, veilBounds[0])) return any;
    // The hull's edges only on the runs of 32 pixels the bounding box passed some of.
    constexpr int kRun = 32;
    int set = 0;
    for (int from = 0; from < n; from += kRun) {
        const int count = std::min(kRun, n - from);
        if (std::find_if(scratch + from, scratch + from + count, [](std::uint8_t v) { return v != 0; }) ==
            scratch + from + count)
            continue;
        set += veilRow(b + from, g + from, r + from, scratch + from, out + from, count, plan.veilEdges.data());
    }
    return set > 0 || any;
}

/// ratioRowErased with ratioRowAvx512 on a CPU that runs it, else with the
/// portable ratioRow (the two give the same verdicts).
template <typename T>
Plan::Row ratioRowFor() {
#ifdef AVATAR_RATIO_AVX512
    if (detail::cpuRunsAvx512f()) return &ratioRowErased<T, &ratioRowAvx512<T>>;
#endif
    return &ratioRowErased<T, &ratioRowPortable<T>>;
}

template <typename T>
bool hsvRowErased(const float* b, const float* g, const float* r, std::uint8_t* out, int n, const Plan& plan,
                  std::uint8_t* /*scratch*/) {
    if constexpr (std::is_same_v<T, float>)
        hsvRow<T>(b, g, r, out, n, plan.hsvF);
    else
        hsvRow<T>(b, g, r, out, n, plan.hsvD);
    return true;  // not known
}

/// Integer limits [lo, hi] on an integer quantity v equivalent to r.min <= v <= r.max.
std::pair<double, double> integerLimits(const Range& r, double vMax) {
    const double lo = std::clamp(std::ceil(r.min), -1.0, vMax + 1.0);
    const double hi = std::clamp(std::floor(r.max), -1.0, vMax + 1.0);
    return {lo, hi};
}

/// Integer limits on max(R,G,B) equivalent to vmin <= max/fullScale <= vmax, exactly.
std::pair<double, double> valueLimits(const Range& v, double fullScale) {
    const auto ge = [&](double k) {  // k/fullScale >= v.min
        if (!(v.min > 0.0)) return true;
        if (k == 0.0) return false;
        return compareFraction(k, fullScale, std::clamp(v.min, kMinLimit, kMaxLimit)) >= 0;
    };
    const auto le = [&](double k) {  // k/fullScale <= v.max
        if (v.max < 0.0) return false;
        if (k == 0.0) return true;
        return compareFraction(k, fullScale, std::clamp(v.max, kMinLimit, kMaxLimit)) <= 0;
    };
    double lo = std::clamp(std::ceil(v.min * fullScale), 0.0, fullScale + 1.0);
    while (lo > 0.0 && ge(lo - 1.0)) lo -= 1.0;
    while (lo <= fullScale && !ge(lo)) lo += 1.0;
    double hi = std::clamp(std::floor(v.max * fullScale), -1.0, fullScale);
    while (hi < fullScale && le(hi + 1.0)) hi += 1.0;
    while (hi >= 0.0 && !le(hi)) hi -= 1.0;
    return {lo, hi};
}

template <typename T>
RatioLimits<T> ratioLimits(const Range& rg, const Range& rb, const Range& bg, double sumLo, double sumHi,
                           std::uint32_t n) {
    RatioLimits<T> lim{};
    lim.rgLo = exactLimit<T>(rg.min, Bound::Lower, n);
    lim.rgHi = exactLimit<T>(rg.max, Bound::Upper, n);
    lim.rbLo = exactLimit<T>(rb.min, Bound::Lower, n);
    lim.rbHi = exactLimit<T>(rb.max, Bound::Upper, n);
    lim.bgLo = exactLimit<T>(bg.min, Bound::Lower, n);
    lim.bgHi = exactLimit<T>(bg.max, Bound::Upper, n);
    lim.rgOpen = rg.max >= kOpenMax;
    lim.rbOpen = rb.max >= kOpenMax;
    lim.bgOpen = bg.max >= kOpenMax;
    lim.sumLo = static_cast<T>(sumLo);
    lim.sumHi = static_cast<T>(sumHi);
    return lim;
}

/// @p x moved outward (down for a minimum, up for a maximum) to a multiple
/// of 1/q, q the power of two with 24 < q x <= 48: a fraction whose nearest
/// neighbours of 16-bit samples lie far enough for the float test to be
/// exact (limitIsExact: q x below 64), at most 4.2 % further; x itself when
/// that multiple would be 0 or x is below every ratio of samples (1/65535).
double roundOutward(double x, Bound bound) {
    if (!(x > 1e-5) || x >= kOpenMax) return x;
    const double q = std::exp2(std::floor(std::log2(48.0 / x)));
    const double p = bound == Bound::Lower ? std::floor(x * q) : std::ceil(x * q);
    return p > 0.0 ? p / q : x;
}

/// The ranges a type's water adds (TargetConfig.h, Water): the water's
/// ranges (the type's by default) with each ratio's far end moved by the
/// water over its longest path (R/G by exp(-(k_R - k_G) L), B/G by
/// exp(-(k_B - k_G) L)) and rounded outward (roundOutward: so that the
/// water does not take a type whose limits float tests exactly to double
/// precision, twice as slow); R/B open.
TargetType waterRanges(const TargetType& type) {
    const Water& w = *type.water;
    const auto through = [&](Range r, double dk) {
        const double f = std::exp(-dk * w.maxPathM);
        if (f < 1.0) r.min = roundOutward(r.min * f, Bound::Lower);
        else if (f > 1.0 && r.max < kOpenMax) r.max = std::min(roundOutward(r.max * f, Bound::Upper), kOpenMax);
        return r;
    };
    TargetType out = type;
    out.water.reset();
    out.veil.reset();
    out.redGreen = through(w.redGreen.value_or(type.redGreen), w.attenuationPerM[0] - w.attenuationPerM[1]);
    out.blueGreen = through(w.blueGreen.value_or(type.blueGreen), w.attenuationPerM[2] - w.attenuationPerM[1]);
    out.redBlue = {0.0, 1e9};
    return out;
}

/// The segments of an RGB-ratio type: each band on its integer brightness
/// interval, and the type's own ranges on the intervals between bands, all
/// within the type's brightness range; with a water, its ranges over the
/// whole brightness range too (a water goes with no bands).
template <typename T>
std::vector<RatioLimits<T>> ratioSegments(const TargetType& type, std::uint32_t n) {
    const double sumMax = 3.0 * n;
    const auto [lo, hi] = type.brightness ? integerLimits(*type.brightness, sumMax)
                                          : std::pair<double, double>{0.0, sumMax};
    std::vector<RatioLimits<T>> out;
    std::vector<std::pair<double, double>> taken;
    for (const BrightnessBand& band : type.brightnessBands) {
        const auto [blo, bhi] = integerLimits(band.brightness, sumMax);
        if (blo > bhi) continue;  // holds no integer sum
        taken.emplace_back(blo, bhi);
        const double a = std::max(lo, blo), b = std::min(hi, bhi);
        if (a <= b) out.push_back(ratioLimits<T>(band.redGreen, band.redBlue, band.blueGreen, a, b, n));
    }
    std::sort(taken.begin(), taken.end());
    double from = lo;
    const auto own = [&](double a, double b) {
        if (a <= b) out.push_back(ratioLimits<T>(type.redGreen, type.redBlue, type.blueGreen, a, b, n));
    };
    for (const auto& [blo, bhi] : taken) {
        own(from, std::min(hi, blo - 1.0));
        from = std::max(from, bhi + 1.0);
    }
    own(from, hi);
    if (type.water && lo <= hi) {
        const TargetType w = waterRanges(type);
        out.push_back(ratioLimits<T>(w.redGreen, w.redBlue, w.blueGreen, lo, hi, n));
    }
    return out;
}

template <typename T>
HsvLimits<T> hsvLimits(const TargetType& type, std::uint32_t n, double fullScale) {
    const HsvRanges& h = type.hsv;
    HsvLimits<T> lim{};
    lim.hueLo = static_cast<float>(h.hue.min);
    lim.hueHi = static_cast<float>(h.hue.max);
    lim.hueWraps = h.hue.min > h.hue.max;
    lim.satLo = exactLimit<T>(h.saturation.min, Bound::Lower, n);
    lim.satHi = exactLimit<T>(h.saturation.max, Bound::Upper, n);
    lim.blackSatPasses = h.saturation.contains(0.0);
    const auto [lo, hi] = valueLimits(h.value, fullScale);
    lim.valLo = static_cast<T>(lo);
    lim.valHi = static_cast<T>(hi);
    return lim;
}

/// The region of (R/G, B/G) a type's veil adds (TargetConfig.h, Veil): the
/// convex hull of the veil's ranges' region (R/G and B/G, the type's by
/// default, cut by the type's R/B range; open maxima at kOpenMax) and that
/// region moved towards the veil's point by maxShare, counter-clockwise;
/// empty when the ranges hold nothing.
std::vector<cv::Point2d> veilHull(const TargetType& type) {
    using P = cv::Point2d;
    const auto top = [](double v) { return std::min(v, kOpenMax); };
    const Veil& veil = *type.veil;
    const Range rg = veil.redGreen.value_or(type.redGreen), bg = veil.blueGreen.value_or(type.blueGreen);
    std::vector<P> region{{rg.min, bg.min}, {top(rg.max), bg.min}, {top(rg.max), top(bg.max)}, {rg.min, top(bg.max)}};
    // R/B = x / y within [min, max]: x - min y >= 0 and max y - x >= 0.
    const auto clip = [&](double a, double c) {  // keeps a x + c y >= 0
        std::vector<P> out;
        for (std::size_t i = 0; i < region.size(); ++i) {
            const P& p = region[i];
            const P& q = region[(i + 1) % region.size()];
            const double fp = a * p.x + c * p.y, fq = a * q.x + c * q.y;
            if (fp >= 0.0) out.push_back(p);
            if ((fp >= 0.0) != (fq >= 0.0)) out.push_back(p + (q - p) * (fp / (fp - fq)));
        }
        region = out;
    };
    if (type.redBlue.min > 0.0) clip(1.0, -type.redBlue.min);
    if (type.redBlue.max < kOpenMax && !region.empty()) clip(-1.0, type.redBlue.max);
    if (region.size() < 3) return {};
    const P v(veil.colourRgb[0] / veil.colourRgb[1], veil.colourRgb[2] / veil.colourRgb[1]);
    std::vector<P> points = region;
    for (const P& p : region) points.push_back(v + (p - v) * (1.0 - veil.maxShare));
    // Andrew's monotone chain.
    std::sort(points.begin(), points.end(), [](const P& a, const P& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
    const auto cross = [](const P& o, const P& a, const P& b) { return (a - o).x * (b - o).y - (a - o).y * (b - o).x; };
    std::vector<P> hull(2 * points.size());
    std::size_t k = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        while (k >= 2 && cross(hull[k - 2], hull[k - 1], points[i]) <= 0.0) --k;
        hull[k++] = points[i];
    }
    for (std::size_t i = points.size() - 1, t = k + 1; i-- > 0;) {
        while (k >= t && cross(hull[k - 2], hull[k - 1], points[i]) <= 0.0) --k;
        hull[k++] = points[i];
    }
    hull.resize(k > 0 ? k - 1 : 0);
    return hull.size() >= 3 ? hull : std::vector<P>{};
}

/// The ratio limits of the hull's bounding box (R/B open), within the type's brightness.
TargetType veilBounds(const TargetType& type, const std::vector<cv::Point2d>& hull) {
    TargetType bounds = type;
    bounds.veil.reset();
    bounds.redGreen = {hull[0].x, hull[0].x};
    bounds.blueGreen = {hull[0].y, hull[0].y};
    for (const cv::Point2d& p : hull) {
        bounds.redGreen = {std::min(bounds.redGreen.min, p.x), std::max(bounds.redGreen.max, p.x)};
        bounds.blueGreen = {std::min(bounds.blueGreen.min, p.y), std::max(bounds.blueGreen.max, p.y)};
    }
    for (Range* r : {&bounds.redGreen, &bounds.blueGreen}) {
        // A little wider, so that a limit's rounding in float never cuts the hull.
        r->min *= 1.0 - 1e-5;
        r->max = r->max >= kOpenMax ? 1e9 : r->max * (1.0 + 1e-5);
    }
    bounds.redBlue = {0.0, 1e9};  // the hull's edges hold the R/B range
    return bounds;
}

/// The hull's edges as a R + b G + c B >= 0 (inside or on the edge, G > 0),
/// each scaled to a largest coefficient of 1, then zeros to kMaxVeilEdges.
std::vector<float> veilEdges(const std::vector<cv::Point2d>& hull) {
    if (hull.size() > kMaxVeilEdges) throw InvalidState("veilEdges: a hull of " + std::to_string(hull.size()) + " edges");
    std::vector<float> edges(3 * kMaxVeilEdges, 0.0f);
    for (std::size_t i = 0; i < hull.size(); ++i) {
        const cv::Point2d& p = hull[i];
        const cv::Point2d d = hull[(i + 1) % hull.size()] - p;
        // Left of p -> p + d: d.x (B/G - p.y) - d.y (R/G - p.x) >= 0, times G.
        const double e[3] = {-d.y, d.y * p.x - d.x * p.y, d.x};
        const double scale = std::max({std::abs(e[0]), std::abs(e[1]), std::abs(e[2])});
        for (int c = 0; c < 3; ++c) edges[3 * i + c] = static_cast<float>(e[c] / scale);
    }
    return edges;
}

/// Float is exact for every limit of the type (always for 8-bit images)?
bool floatIsExact(const TargetType& type, std::uint32_t n) {
    const auto ok = [&](const Range& r) {
        return limitIsExact<float>(neighbours(r.min, Bound::Lower, n), n) &&
               limitIsExact<float>(neighbours(r.max, Bound::Upper, n), n);
    };
    if (type.filter == ColorFilterMethod::Hsv) return ok(type.hsv.saturation);
    for (const BrightnessBand& b : type.brightnessBands)
        if (!ok(b.redGreen) || !ok(b.redBlue) || !ok(b.blueGreen)) return false;
    if (type.water) {
        const TargetType w = waterRanges(type);
        if (!ok(w.redGreen) || !ok(w.blueGreen)) return false;
    }
    return ok(type.redGreen) && ok(type.redBlue) && ok(type.blueGreen);
}

Plan makePlan(const TargetType& type, cv::Size size, std::uint32_t n, int bitDepth) {
    validateTargetType(type);  // the configuration's rules: ranges ordered, limits not NaN
    Plan plan;
    plan.window = searchWindow(type, size);
    // Float (twice the SIMD width) whenever it is exact for this type's
    // limits: always for 8-bit images; for 16-bit ones only when the limit's
    // neighbouring fractions have small denominators (see limitIsExact).
    bool useFloat = floatIsExact(type, n);
    if (type.filter == ColorFilterMethod::Hsv) {
        const double fullScale = std::ldexp(1.0, bitDepth) - 1.0;
        if (useFloat) {
            plan.hsvF = hsvLimits<float>(type, n, fullScale);
            plan.row = &hsvRowErased<float>;
        } else {
            plan.hsvD = hsvLimits<double>(type, n, fullScale);
            plan.row = &hsvRowErased<double>;
        }
    } else {
        const std::vector<cv::Point2d> hull = type.veil ? veilHull(type) : std::vector<cv::Point2d>{};
        const std::optional<TargetType> bounds =
            hull.empty() ? std::nullopt : std::optional<TargetType>(veilBounds(type, hull));
        if (useFloat) {
            plan.ratioF = ratioSegments<float>(type, n);
            if (bounds) plan.veilBoundsF = ratioSegments<float>(*bounds, n);
            plan.row = ratioRowFor<float>();
        } else {
            plan.ratioD = ratioSegments<double>(type, n);
            if (bounds) plan.veilBoundsD = ratioSegments<double>(*bounds, n);
            plan.row = ratioRowFor<double>();
        }
        if (bounds) plan.veilEdges = veilEdges(hull);
    }
    return plan;
}

}  // namespace

void detail::prepareMask(cv::Mat& mask, cv::Size size) {
    const bool reusable = mask.type() == CV_8UC1 && mask.size() == size && !mask.isSubmatrix() &&
                          mask.u != nullptr && mask.u->refcount == 1;
    if (!reusable) mask = cv::Mat(size, CV_8UC1);
}

namespace {

template <typename S>
void filterImage(const cv::Mat& bgr, const std::vector<detail::ColorTest>& tests, std::vector<cv::Mat>& masks) {
    const int cols = bgr.cols;
    std::vector<float> planes(3 * static_cast<std::size_t>(cols));
    std::vector<std::uint8_t> scratch(static_cast<std::size_t>(cols));
    float* b = planes.data();
    float* g = b + cols;
    float* r = g + cols;
    for (int y = 0; y < bgr.rows; ++y) {
        // The columns some type looks at in this row, split once for all types.
        int from = cols, to = 0;
        for (const detail::ColorTest& t : tests) {
            const cv::Rect& w = t.window();
            if (y >= w.y && y < w.y + w.height) {
                from = std::min(from, w.x);
                to = std::max(to, w.x + w.width);
            }
        }
        if (from < to) detail::splitRow(bgr.ptr<S>(y) + 3 * from, b + from, g + from, r + from, to - from);
        for (std::size_t t = 0; t < tests.size(); ++t) {
            std::uint8_t* out = masks[t].ptr<std::uint8_t>(y);
            const cv::Rect& w = tests[t].window();
            if (y < w.y || y >= w.y + w.height) {
                std::memset(out, 0, static_cast<std::size_t>(cols));
                continue;
            }
            std::memset(out, 0, static_cast<std::size_t>(w.x));
            tests[t].row(b + w.x, g + w.x, r + w.x, out + w.x, w.width, scratch.data());
            std::memset(out + w.x + w.width, 0, static_cast<std::size_t>(cols - w.x - w.width));
        }
    }
}

}  // namespace

namespace detail {

ColorTest::ColorTest(const TargetType& type, cv::Size size, int depth, int bitDepth)
    : plan_(std::make_shared<const Plan>(
          makePlan(type, size, depth == CV_8U ? 255u : 65535u, bitDepth))) {}

const cv::Rect& ColorTest::window() const { return plan_->window; }

bool ColorTest::row(const float* b, const float* g, const float* r, std::uint8_t* out, int n,
                    std::uint8_t* scratch) const {
    return plan_->row(b, g, r, out, n, *plan_, scratch);
}

void splitRow(const std::uint8_t* bgr, float* b, float* g, float* r, int n) { splitRowKernel(bgr, b, g, r, n); }
void splitRow(const std::uint16_t* bgr, float* b, float* g, float* r, int n) { splitRowKernel(bgr, b, g, r, n); }

}  // namespace detail

void colorFilterMasks(const cv::Mat& bgr, int bitDepth, const std::vector<TargetType>& types,
                      std::vector<cv::Mat>& masks) {
    const int depth = bgr.depth();
    if (bgr.empty() || bgr.channels() != 3 || (depth != CV_8U && depth != CV_16U))
        throw FormatError("colorFilterMasks: the image must be 8- or 16-bit BGR, got " +
                          cv::typeToString(bgr.type()) + " " + std::to_string(bgr.cols) + "x" +
                          std::to_string(bgr.rows));
    const int maxBits = depth == CV_8U ? 8 : 16;
    if (bitDepth < 1 || bitDepth > maxBits)
        throw InvalidArgument("colorFilterMasks: bit depth " + std::to_string(bitDepth) + " is not in 1.." +
                              std::to_string(maxBits) + " for a " + cv::typeToString(bgr.type()) + " image");

    std::vector<detail::ColorTest> tests;
    tests.reserve(types.size());
    for (const TargetType& type : types) tests.emplace_back(type, bgr.size(), depth, bitDepth);
    masks.resize(types.size());
    for (cv::Mat& mask : masks) detail::prepareMask(mask, bgr.size());

    if (depth == CV_8U)
        filterImage<std::uint8_t>(bgr, tests, masks);
    else
        filterImage<std::uint16_t>(bgr, tests, masks);
}

cv::Mat applyMask(const cv::Mat& bgr, const cv::Mat& mask) {
    if (mask.type() != CV_8UC1)
        throw FormatError("applyMask: the mask must be CV_8UC1, got " + cv::typeToString(mask.type()));
    if (bgr.size() != mask.size())
        throw InvalidArgument("applyMask: the image is " + std::to_string(bgr.cols) + "x" +
                              std::to_string(bgr.rows) + " but the mask " + std::to_string(mask.cols) + "x" +
                              std::to_string(mask.rows));
    cv::Mat out = cv::Mat::zeros(bgr.size(), bgr.type());
    bgr.copyTo(out, mask);
    return out;
}

}  // namespace avatar
