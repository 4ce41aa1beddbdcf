#include "Interleave.h"

#include "KernelClones.h"

#include <array>
#include <cstddef>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#define AVATAR_INTERLEAVE_AVX512 1
#endif

namespace avatar::detail {
namespace {

void interleavePortable(const std::uint16_t* b, const std::uint16_t* g, const std::uint16_t* r, std::uint16_t* out,
                        int n) {
    for (int i = 0; i < n; ++i) {
        out[3 * i] = b[i];
        out[3 * i + 1] = g[i];
        out[3 * i + 2] = r[i];
    }
}

void deinterleavePortable(const std::uint16_t* in, std::uint16_t* b, std::uint16_t* g, std::uint16_t* r, int n) {
    for (int i = 0; i < n; ++i) {
        b[i] = in[3 * i];
        g[i] = in[3 * i + 1];
        r[i] = in[3 * i + 2];
    }
}

#ifdef AVATAR_INTERLEAVE_AVX512
#define AVATAR_AVX512BW __attribute__((target("avx512f,avx512bw")))

using Indices = std::array<std::uint16_t, 32>;

/// Word k of the 48 interleaved words of 16 pixels as an index into the pair
/// (first, second) of _mm512_permutex2var_epi16, where first holds the 16 B
/// samples then the 16 G samples and second the 16 R samples: words
/// @p from .. @p from + 31 (those past 47 are 0, unused).
constexpr Indices interleaveIndices(int from) {
    Indices idx{};
    for (int j = 0; j < 32; ++j) {
        const int k = from + j;
        if (k >= 48) break;
        const int pixel = k / 3, channel = k % 3;
        idx[static_cast<std::size_t>(j)] = static_cast<std::uint16_t>(channel == 0   ? pixel
                                                                      : channel == 1 ? 16 + pixel
                                                                                     : 32 + pixel);
    }
    return idx;
}

/// Channel @p c's 16 samples (words 0-15; the rest 0, unused) as indices
/// into the pair (words 0-31, words 32-47) of 48 interleaved words.
constexpr Indices deinterleaveIndices(int c) {
    Indices idx{};
    for (int p = 0; p < 16; ++p) idx[static_cast<std::size_t>(p)] = static_cast<std::uint16_t>(3 * p + c);
    return idx;
}

constexpr Indices kInterleaveLow = interleaveIndices(0), kInterleaveHigh = interleaveIndices(32);
constexpr Indices kBlue = deinterleaveIndices(0), kGreen = deinterleaveIndices(1), kRed = deinterleaveIndices(2);

AVATAR_AVX512BW __m512i indices(const Indices& idx) { return _mm512_loadu_si512(idx.data()); }

// Half-register loads and stores are masked full-register ones: the 256-bit
// casts and extracts leave lanes undefined, which GCC 12 warns about.

AVATAR_AVX512BW void interleaveAvx512(const std::uint16_t* b, const std::uint16_t* g, const std::uint16_t* r,
                                      std::uint16_t* out, int n) {
    const __m512i low = indices(kInterleaveLow), high = indices(kInterleaveHigh);
    int i = 0;
    for (; i + 16 <= n; i += 16) {
        // B in words 0-15, G in 16-31: the two low halves side by side.
        const __m512i bg = _mm512_maskz_shuffle_i64x2(0xFF, _mm512_maskz_loadu_epi16(0xFFFF, b + i),
                                                      _mm512_maskz_loadu_epi16(0xFFFF, g + i), 0x44);
        const __m512i rr = _mm512_maskz_loadu_epi16(0xFFFF, r + i);
        _mm512_storeu_si512(out + 3 * i, _mm512_permutex2var_epi16(bg, low, rr));
        _mm512_mask_storeu_epi16(out + 3 * i + 32, 0xFFFF, _mm512_permutex2var_epi16(bg, high, rr));
    }
    interleavePortable(b + i, g + i, r + i, out + 3 * i, n - i);
}

AVATAR_AVX512BW void deinterleaveAvx512(const std::uint16_t* in, std::uint16_t* b, std::uint16_t* g,
                                        std::uint16_t* r, int n) {
    const __m512i blue = indices(kBlue), green = indices(kGreen), red = indices(kRed);
    int i = 0;
    for (; i + 16 <= n; i += 16) {
        const __m512i first = _mm512_loadu_si512(in + 3 * i);
        const __m512i second = _mm512_maskz_loadu_epi16(0xFFFF, in + 3 * i + 32);
        _mm512_mask_storeu_epi16(b + i, 0xFFFF, _mm512_permutex2var_epi16(first, blue, second));
        _mm512_mask_storeu_epi16(g + i, 0xFFFF, _mm512_permutex2var_epi16(first, green, second));
        _mm512_mask_storeu_epi16(r + i, 0xFFFF, _mm512_permutex2var_epi16(first, red, second));
    }
    deinterleavePortable(in + 3 * i, b + i, g + i, r + i, n - i);
}

#undef AVATAR_AVX512BW
#endif

}  // namespace

void interleave3(const std::uint16_t* b, const std::uint16_t* g, const std::uint16_t* r, std::uint16_t* out, int n) {
#ifdef AVATAR_INTERLEAVE_AVX512
    if (cpuRunsAvx512bw()) return interleaveAvx512(b, g, r, out, n);
#endif
    interleavePortable(b, g, r, out, n);
}

void deinterleave3(const std::uint16_t* in, std::uint16_t* b, std::uint16_t* g, std::uint16_t* r, int n) {
#ifdef AVATAR_INTERLEAVE_AVX512
    if (cpuRunsAvx512bw()) return deinterleaveAvx512(in, b, g, r, n);
#endif
    deinterleavePortable(in, b, g, r, n);
}

}  // namespace avatar::detail
