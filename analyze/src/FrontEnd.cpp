#include "FrontEnd.h"

#include "ImageReduce.h"
#include "Interleave.h"
#include "KernelClones.h"

#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>

#include <opencv2/core.hpp>
#include <opencv2/core/hal/hal.hpp>

#include <algorithm>
#include <cstdint>
#include <cstring>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#endif

namespace avatar::detail {
namespace {

// ---------------------------------------------------------------------------
// Row kernels. Every sample is carried as a float holding its integer value
// (exact: no sum here exceeds 2^24), so each stage of the chain is one plain
// loop over contiguous rows that GCC vectorises, and the colour filter gets
// the planes it wants without de-interleaving.
// ---------------------------------------------------------------------------

template <typename S>
AVATAR_KERNEL_CLONES void loadRow(const S* __restrict in, float* __restrict out, int n) {
    for (int i = 0; i < n; ++i) out[i] = static_cast<float>(static_cast<std::int32_t>(in[i]));
}

AVATAR_KERNEL_CLONES void swapRow(const std::uint16_t* __restrict in, float* __restrict out, int n) {
    for (int i = 0; i < n; ++i) {
        const std::uint32_t v = in[i];
        out[i] = static_cast<float>(static_cast<std::int32_t>(((v >> 8) | (v << 8)) & 0xFFFFu));
    }
}

/// LightingCorrector::apply's formula on one row of mosaic sites, in place:
/// min(sample * factor, full scale) rounded half up, in single precision.
AVATAR_KERNEL_CLONES void lightRow(float* __restrict row, const float* __restrict factor, int n, float full) {
    for (int i = 0; i < n; ++i) {
        const float v = std::min(row[i] * factor[i], full);
        row[i] = static_cast<float>(static_cast<std::int32_t>(v + 0.5f));
    }
}

/// loadRow then lightRow in one loop (the same operations): the samples and
/// their factors are read once, the row written once.
template <typename S>
AVATAR_KERNEL_CLONES void loadLitRow(const S* __restrict in, const float* __restrict factor, float* __restrict out,
                                     int n, float full) {
    for (int i = 0; i < n; ++i) {
        const float v = std::min(static_cast<float>(static_cast<std::int32_t>(in[i])) * factor[i], full);
        out[i] = static_cast<float>(static_cast<std::int32_t>(v + 0.5f));
    }
}

/// Asks for the cache lines of [p, p + bytes) ahead of their use: a
/// camera's fresh frame comes from memory, and the hardware prefetcher
/// stops at every 4 KiB page (a 1280-pixel 16-bit row is 2.5 KiB), so each
/// page would start with a wait for memory.
inline void prefetchBytes(const void* p, std::size_t bytes, bool forWriting) {
    const char* c = static_cast<const char*>(p);
    for (std::size_t i = 0; i < bytes; i += 64) {
        if (forWriting) __builtin_prefetch(c + i, 1, 3);
        else __builtin_prefetch(c + i, 0, 3);
    }
}

/// Mosaic row @p y of @p in, columns [x, x + n), as floats into @p dst:
/// byte-swapped when asked, corrected by its sites' factors when there are any.
/// Row @p y's lighting factors: its own, or its parity's when there are two rows.
const float* factorRow(const FrontEndInput& in, int y) {
    return in.factors->ptr<float>(in.factors->rows == in.mosaic.rows ? y : y & 1);
}

template <typename S>
void loadSites(const FrontEndInput& in, int y, int x, float* dst, int n, float full) {
    const float* factor = in.factors != nullptr ? factorRow(in, y) + x : nullptr;
    if constexpr (sizeof(S) == 2) {
        if (in.endianSwap) {
            swapRow(in.mosaic.ptr<std::uint16_t>(y) + x, dst, n);
            if (factor != nullptr) lightRow(dst, factor, n, full);
            return;
        }
    }
    if (factor != nullptr) loadLitRow(in.mosaic.ptr<S>(y) + x, factor, dst, n, full);
    else loadRow(in.mosaic.ptr<S>(y) + x, dst, n);
}

/// Bilinear demosaic of one row (interior columns 1..n-2), as cv::cvtColor's
/// integer formulas: a sample keeps its own colour; at a green site the
/// horizontal neighbours give the row's other colour ((a+b+1)>>1) and the
/// vertical ones the third; at a red or blue site the four neighbours give
/// green ((a+b+c+d+2)>>2) and the four diagonals the third. @p own is 1 at the
/// columns holding the row's own non-green colour (cr), 0 at green ones, and
/// @p notOwn its complement: the choice is made by multiplying, exactly (one
/// term is 0), because GCC vectorises no select between computed values. The
/// values are non-negative, so truncation is the floor of the shifts.
AVATAR_KERNEL_CLONES void demosaicRow(const float* __restrict m0, const float* __restrict m1,
                                      const float* __restrict m2, const float* __restrict own,
                                      const float* __restrict notOwn, float* __restrict cr,
                                      float* __restrict green, float* __restrict other, int n) {
    for (int x = 1; x < n - 1; ++x) {
        const float s = m1[x];
        const float h = m1[x - 1] + m1[x + 1];
        const float v = m0[x] + m2[x];
        const float d = (m0[x - 1] + m0[x + 1]) + (m2[x - 1] + m2[x + 1]);
        const float h2 = static_cast<float>(static_cast<std::int32_t>((h + 1.0f) * 0.5f));
        const float v2 = static_cast<float>(static_cast<std::int32_t>((v + 1.0f) * 0.5f));
        const float x4 = static_cast<float>(static_cast<std::int32_t>((h + v + 2.0f) * 0.25f));
        const float d4 = static_cast<float>(static_cast<std::int32_t>((d + 2.0f) * 0.25f));
        const float a = own[x], b = notOwn[x];
        cr[x] = s * a + h2 * b;
        green[x] = x4 * a + s * b;
        other[x] = d4 * a + v2 * b;
    }
}

#if defined(__GNUC__) && defined(__x86_64__)
#define AVATAR_DEMOSAIC_AVX512 1
#define AVATAR_AVX512F __attribute__((target("avx512f")))

/// demosaicRow() with AVX-512F, 16 pixels a step: the choice between a
/// site's two formulas made by blending with the lanes' constant pattern
/// (@p ownEven: the row's own colour is at its even columns), so each pixel
/// computes the two rounded values it keeps rather than all four, and a
/// truncation is one roundscale (the values are non-negative integers below
/// 2^24, exact in float). The last steps with masked loads and stores:
/// nothing outside columns 0..n-1 is read, nothing outside 1..n-2 written.
AVATAR_AVX512F void demosaicRowAvx512(const float* m0, const float* m1, const float* m2, bool ownEven, float* cr,
                                      float* green, float* other, int n) {
    const __m512 one = _mm512_set1_ps(1.0f), two = _mm512_set1_ps(2.0f);
    const __m512 half = _mm512_set1_ps(0.5f), quarter = _mm512_set1_ps(0.25f);
    constexpr int kTruncate = _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC;
    for (int x = 1; x < n - 1; x += 16) {
        const int left = n - 1 - x;
        const auto valid = static_cast<__mmask16>(left >= 16 ? 0xFFFFu : (1u << left) - 1u);
        const auto own = static_cast<__mmask16>(((x & 1) == 0) == ownEven ? 0x5555u : 0xAAAAu);
        const __m512 s = _mm512_maskz_loadu_ps(valid, m1 + x);
        const __m512 h = _mm512_add_ps(_mm512_maskz_loadu_ps(valid, m1 + x - 1), _mm512_maskz_loadu_ps(valid, m1 + x + 1));
        const __m512 v = _mm512_add_ps(_mm512_maskz_loadu_ps(valid, m0 + x), _mm512_maskz_loadu_ps(valid, m2 + x));
        const __m512 d = _mm512_add_ps(
            _mm512_add_ps(_mm512_maskz_loadu_ps(valid, m0 + x - 1), _mm512_maskz_loadu_ps(valid, m0 + x + 1)),
            _mm512_add_ps(_mm512_maskz_loadu_ps(valid, m2 + x - 1), _mm512_maskz_loadu_ps(valid, m2 + x + 1)));
        const __m512 scale = _mm512_mask_blend_ps(own, half, quarter);
        // Own sites: green (h + v + 2) >> 2 and the third (d + 2) >> 2; green
        // sites: the row's colour (h + 1) >> 1 and the third (v + 1) >> 1.
        const __m512 near = _mm512_maskz_roundscale_ps(
            0xFFFF, _mm512_mul_ps(_mm512_mask_blend_ps(own, _mm512_add_ps(h, one), _mm512_add_ps(_mm512_add_ps(h, v), two)), scale),
            kTruncate);
        const __m512 far = _mm512_maskz_roundscale_ps(
            0xFFFF, _mm512_mul_ps(_mm512_mask_blend_ps(own, _mm512_add_ps(v, one), _mm512_add_ps(d, two)), scale),
            kTruncate);
        _mm512_mask_storeu_ps(cr + x, valid, _mm512_mask_blend_ps(own, near, s));
        _mm512_mask_storeu_ps(green + x, valid, _mm512_mask_blend_ps(own, s, near));
        _mm512_mask_storeu_ps(other + x, valid, far);
    }
}

/// demosaicRowAvx512() and, on the values it keeps in its registers, the
/// visibility's column sums (started when @p first, else added to) and the
/// count of pixels with a channel at or above @p full: sumAndCount() over
/// columns 1..n-2, without reading the planes back. The sums of the row's own
/// colour, green and the third colour are @p sumCr, @p sumGreen, @p sumOther.
AVATAR_AVX512F std::int32_t demosaicSumRowAvx512(const float* m0, const float* m1, const float* m2, bool ownEven,
                                                 float* cr, float* green, float* other, float* sumCr,
                                                 float* sumGreen, float* sumOther, bool first, float full, int n) {
    const __m512 one = _mm512_set1_ps(1.0f), two = _mm512_set1_ps(2.0f);
    const __m512 half = _mm512_set1_ps(0.5f), quarter = _mm512_set1_ps(0.25f);
    const __m512 top = _mm512_set1_ps(full);
    constexpr int kTruncate = _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC;
    std::int32_t saturated = 0;
    for (int x = 1; x < n - 1; x += 16) {
        const int left = n - 1 - x;
        const auto valid = static_cast<__mmask16>(left >= 16 ? 0xFFFFu : (1u << left) - 1u);
        const auto own = static_cast<__mmask16>(((x & 1) == 0) == ownEven ? 0x5555u : 0xAAAAu);
        const __m512 s = _mm512_maskz_loadu_ps(valid, m1 + x);
        const __m512 h = _mm512_add_ps(_mm512_maskz_loadu_ps(valid, m1 + x - 1), _mm512_maskz_loadu_ps(valid, m1 + x + 1));
        const __m512 v = _mm512_add_ps(_mm512_maskz_loadu_ps(valid, m0 + x), _mm512_maskz_loadu_ps(valid, m2 + x));
        const __m512 d = _mm512_add_ps(
            _mm512_add_ps(_mm512_maskz_loadu_ps(valid, m0 + x - 1), _mm512_maskz_loadu_ps(valid, m0 + x + 1)),
            _mm512_add_ps(_mm512_maskz_loadu_ps(valid, m2 + x - 1), _mm512_maskz_loadu_ps(valid, m2 + x + 1)));
        const __m512 scale = _mm512_mask_blend_ps(own, half, quarter);
        const __m512 near = _mm512_maskz_roundscale_ps(
            0xFFFF, _mm512_mul_ps(_mm512_mask_blend_ps(own, _mm512_add_ps(h, one), _mm512_add_ps(_mm512_add_ps(h, v), two)), scale),
            kTruncate);
        const __m512 far = _mm512_maskz_roundscale_ps(
            0xFFFF, _mm512_mul_ps(_mm512_mask_blend_ps(own, _mm512_add_ps(v, one), _mm512_add_ps(d, two)), scale),
            kTruncate);
        const __m512 c = _mm512_mask_blend_ps(own, near, s), g = _mm512_mask_blend_ps(own, s, near);
        _mm512_mask_storeu_ps(cr + x, valid, c);
        _mm512_mask_storeu_ps(green + x, valid, g);
        _mm512_mask_storeu_ps(other + x, valid, far);
        if (first) {
            _mm512_mask_storeu_ps(sumCr + x, valid, c);
            _mm512_mask_storeu_ps(sumGreen + x, valid, g);
            _mm512_mask_storeu_ps(sumOther + x, valid, far);
        } else {
            _mm512_mask_storeu_ps(sumCr + x, valid, _mm512_add_ps(_mm512_maskz_loadu_ps(valid, sumCr + x), c));
            _mm512_mask_storeu_ps(sumGreen + x, valid, _mm512_add_ps(_mm512_maskz_loadu_ps(valid, sumGreen + x), g));
            _mm512_mask_storeu_ps(sumOther + x, valid, _mm512_add_ps(_mm512_maskz_loadu_ps(valid, sumOther + x), far));
        }
        const __mmask16 atFull = _mm512_mask_cmp_ps_mask(valid, c, top, _CMP_GE_OQ) |
                                 _mm512_mask_cmp_ps_mask(valid, g, top, _CMP_GE_OQ) |
                                 _mm512_mask_cmp_ps_mask(valid, far, top, _CMP_GE_OQ);
        saturated += __builtin_popcount(static_cast<unsigned>(atFull));
    }
    return saturated;
}

#undef AVATAR_AVX512F
#endif


/// Float planes to sample planes (the values are exact integers in range).
template <typename S>
AVATAR_KERNEL_CLONES void narrowRow(const float* __restrict in, S* __restrict out, int n) {
    for (int i = 0; i < n; ++i) out[i] = static_cast<S>(static_cast<std::int32_t>(in[i]));
}

/// One row of the BGR image from its planes: narrowed here, then
/// interleaved (Interleave.h: 16-bit rows stay in the cache, unlike
/// cv::hal::merge16u's aligned stores; a plain stride-3 store loop costs
/// twice as much).
template <typename S>
void storeRow(const float* b, const float* g, const float* r, S* planes, S* out, int n) {
    S* p[3] = {planes, planes + n, planes + 2 * n};
    narrowRow(b, p[0], n);
    narrowRow(g, p[1], n);
    narrowRow(r, p[2], n);
    if constexpr (sizeof(S) == 1) {
        const S* src[3] = {p[0], p[1], p[2]};
        cv::hal::merge8u(src, out, n, 3);
    } else {
        interleave3(p[0], p[1], p[2], out, n);  // kept in the cache for the stages that read it next
    }
}

/// Pixels with any channel at or above full scale (measureVisibility's count).
AVATAR_KERNEL_CLONES std::int32_t countSaturated(const float* __restrict b, const float* __restrict g,
                                                 const float* __restrict r, int n, float full) {
    std::int32_t count = 0;
    for (int i = 0; i < n; ++i) count += static_cast<std::int32_t>((b[i] >= full) | (g[i] >= full) | (r[i] >= full));
    return count;
}

/// countSaturated() and the column sums of the three planes in one loop: the
/// sums are started (@p first, a block's first row) or added to. The whole
/// pass's 4x4 reduction and the coarse pass's 2x2 one both gather them here.
AVATAR_KERNEL_CLONES std::int32_t sumAndCount(const float* __restrict b, const float* __restrict g,
                                              const float* __restrict r, float* __restrict sb,
                                              float* __restrict sg, float* __restrict sr, int n, float full,
                                              bool first) {
    std::int32_t count = 0;
    if (first)
        for (int i = 0; i < n; ++i) {
            sb[i] = b[i];
            sg[i] = g[i];
            sr[i] = r[i];
            count += static_cast<std::int32_t>((b[i] >= full) | (g[i] >= full) | (r[i] >= full));
        }
    else
        for (int i = 0; i < n; ++i) {
            sb[i] += b[i];
            sg[i] += g[i];
            sr[i] += r[i];
            count += static_cast<std::int32_t>((b[i] >= full) | (g[i] >= full) | (r[i] >= full));
        }
    return count;
}

/// One channel of a row of 4x4-block sums from four rows' column sums (exact:
/// integers below 2^24, so the order of the additions does not matter).
AVATAR_KERNEL_CLONES void blockSums(const float* __restrict sums, float* __restrict out, int blocks) {
    for (int x = 0; x < blocks; ++x) out[x] = (sums[4 * x] + sums[4 * x + 1]) + (sums[4 * x + 2] + sums[4 * x + 3]);
}

/// The 4x4-block means from their sums, rounded to nearest with ties to
/// even, as downsampleArea4() (cv::resize INTER_AREA), as samples.
template <typename S>
AVATAR_KERNEL_CLONES void blockMeans(const float* __restrict sums, S* __restrict out, int blocks) {
    // sum = 16 q + r: adding 7 and q's parity carries into q exactly when r > 8,
    // or r = 8 and q is odd (integer operations only, which GCC vectorises).
    for (int x = 0; x < blocks; ++x) {
        const auto sum = static_cast<std::uint32_t>(static_cast<std::int32_t>(sums[x]));
        out[x] = static_cast<S>((sum + 7u + ((sum >> 4) & 1u)) >> 4);
    }
}

/// One row of the 4x4-block means of the three channels' column sums, as
/// planes into the visibility's sums (the reduced image is never stored).
template <typename S>
void addBlockMeans(float* const* sums, float* blockRow, S* planes, int blocks, LumaSums& luma) {
    S* p[3] = {planes, planes + blocks, planes + 2 * blocks};
    for (int c = 0; c < 3; ++c) {
        blockSums(sums[c], blockRow, blocks);
        blockMeans(blockRow, p[c], blocks);
    }
    luma.addPlanes(p[0], p[1], p[2], blocks);
}

/// @p image itself when it has @p size and @p type (true), else a new buffer (false).
bool prepareImage(cv::Mat& image, cv::Size size, int type) {
    if (image.type() == type && image.size() == size && image.isContinuous()) return true;
    image = cv::Mat(size, type);
    return false;
}

/// One image's pass, its rows computed in steps (advance()), so that two
/// images of a pair can take turns over the same rows (runFrontEndPair) and
/// each row of lighting factors is read from memory once for both.
/// How many rows ahead a pass asks for its inputs and masks (prefetchBytes).
constexpr int kPrefetchRows = 4;

template <typename S>
class Pass {
public:
    Pass(const FrontEndInput& input, FrontEndResult& output)
        : in(input),
          out(output),
          mosaic(input.mosaic),
          w(mosaic.cols),
          h(mosaic.rows),
          depth(mosaic.depth()),
          n(static_cast<std::size_t>(w)),
          regional(input.regions != nullptr && !input.regions->empty()),
          writeImage(input.writeImage || regional),
          types(input.tests != nullptr ? input.tests->size() : 0),
          rows(9 * n, 0.0f),
          ownColumn(2 * n),
          greenColumn(2 * n),
          scratch(n),
          verdicts(n),
          samplePlanes(3 * n),
          blockRow(n / 4 + 1),
          full(static_cast<float>((1 << input.bitDepth) - 1)),
          avx512(!input.portableKernels && cpuRunsAvx512f()),
          measure(input.visibility && !regional),
          reduce(measure && w % 4 == 0 && h % 4 == 0) {
        if (measure && !reduce && !writeImage)
            throw InvalidArgument("front end: the visibility of a " + std::to_string(w) + "x" + std::to_string(h) +
                                  " image (sides not multiples of 4) is measured on the image, which was not asked for");
        bgrClear = writeImage && prepareImage(out.bgr, mosaic.size(), CV_MAKETYPE(depth, 3)) &&
                   out.bgrZeroOutsideRegions;
        out.masks.resize(types);
        masksClear = out.masksZeroOutsideRegions;
        dirtyRows.assign(types, std::vector<std::uint8_t>(static_cast<std::size_t>(h), 1));
        for (std::size_t t = 0; t < types; ++t) {
            const bool kept = prepareImage(out.masks[t], mosaic.size(), CV_8UC1);
            masksClear = kept && masksClear;
            if (!kept || regional || t >= out.masksDirty.size()) continue;
            // The rows the buffer's last user may have left non-zero; the rest are 0.
            std::vector<std::uint8_t>& dirty = dirtyRows[t];
            std::fill(dirty.begin(), dirty.end(), std::uint8_t{0});
            for (const cv::Rect& r : out.masksDirty[t])
                for (int row = std::max(r.y, 0); row < std::min(r.y + r.height, h); ++row)
                    dirty[static_cast<std::size_t>(row)] = 1;
        }
        out.maskRows.resize(regional ? 0 : types);
        for (std::size_t t = 0; t < out.maskRows.size(); ++t) {
            MaskRows& spans = out.maskRows[t];
            spans.data = out.masks[t].data;
            spans.begin.assign(static_cast<std::size_t>(h), 0);
            spans.end.assign(static_cast<std::size_t>(h), 0);
        }
        // Rows: three of the (corrected) mosaic (a ring), the demosaiced planes, the
        // visibility's column sums; the per-column role of each row parity.
        for (int k = 0; k < 3; ++k) {
            mosaicRow[k] = rows.data() + static_cast<std::size_t>(k) * n;
            demosaiced[k] = rows.data() + static_cast<std::size_t>(3 + k) * n;
            sums[k] = rows.data() + static_cast<std::size_t>(6 + k) * n;
        }
        for (int parity = 0; parity < 2; ++parity) {
            const int even = bayerSiteColour(in.pattern, 0, parity), odd = bayerSiteColour(in.pattern, 1, parity);
            ownColour[parity] = even == 1 ? odd : even;
            otherColour[parity] = 2 - ownColour[parity];
            for (int x = 0; x < w; ++x) {
                const bool isOwn = bayerSiteColour(in.pattern, x, parity) != 1;
                ownColumn[parity * n + static_cast<std::size_t>(x)] = isOwn ? 1.0f : 0.0f;
                greenColumn[parity * n + static_cast<std::size_t>(x)] = isOwn ? 0.0f : 1.0f;
            }
        }
    }

    /// Whether the pass covers the whole image (no search regions).
    bool whole() const { return !regional; }

    /// The whole pass: every region, or the whole image and its visibility.
    void run() {
        if (regional) {
            // The callers' buffers are 0 outside the regions (BufferPool::getZeroedOutside);
            // one that is not is cleared here.
            if (!bgrClear) out.bgr.setTo(0);
            if (!masksClear)
                for (cv::Mat& mask : out.masks) mask.setTo(0);
            const cv::Rect image(0, 0, w, h);
            for (const cv::Rect& r : *in.regions) {
                if ((r & image) != r || r.empty())
                    throw InvalidArgument("front end: search region [" + std::to_string(r.x) + ", " +
                                          std::to_string(r.y) + ", " + std::to_string(r.width) + "x" +
                                          std::to_string(r.height) + "] is empty or not inside the " +
                                          std::to_string(w) + "x" + std::to_string(h) + " image");
                start(r);
                advance(r.y + r.height);
            }
            out.visibility.reset();
            return;
        }
        start(cv::Rect(0, 0, w, h));
        advance(h);
        finish();
    }

    /// Begins @p a: every output pixel of it, as the whole image gives them.
    /// The demosaic of its edge pixels reads one more column and row of the
    /// mosaic each side (where the image has them), and the image's first and
    /// last rows and columns copy their neighbour's, as OpenCV's.
    void start(const cv::Rect& a) {
        area = a;
        // The columns demosaiced: the area widened by one each side inside the
        // image, and at least three, so that a first or last column always has
        // the neighbour it copies computed.
        c0 = std::max(std::min(area.x - 1, w - 3), 0);
        c1 = std::min(std::max(area.x + area.width + 1, 3), w);
        m = c1 - c0;
        o = static_cast<std::size_t>(c0);
        loaded = std::clamp(area.y, 1, h - 2) - 2;  // the last mosaic row loaded
        lastSource = -1;
        y = area.y;
    }

    /// The area's rows up to (not including) @p yEnd.
    void advance(int yEnd) {
        yEnd = std::min(yEnd, area.y + area.height);
        for (; y < yEnd; ++y) {
            // The first and last rows copy their neighbour's demosaic, as OpenCV's.
            const int source = std::clamp(y, 1, h - 2);
            bool summed = false;  // this row's visibility sums gathered by the demosaic
            if (source != lastSource) {
                while (loaded < source + 1) {
                    ++loaded;
                    if (loaded + kPrefetchRows < h) {
                        const int ahead = loaded + kPrefetchRows;
                        prefetchBytes(in.mosaic.ptr<S>(ahead) + c0, static_cast<std::size_t>(m) * sizeof(S), false);
                        if (in.factors != nullptr && in.factors->rows == h)  // two rows stay in the cache
                            prefetchBytes(in.factors->ptr<float>(ahead) + c0, static_cast<std::size_t>(m) * sizeof(float), false);
                        for (std::size_t t = 0; t < out.masks.size(); ++t)  // not rows known to be 0
                            if (dirtyRows[t][static_cast<std::size_t>(ahead)] != 0)
                                prefetchBytes(out.masks[t].ptr(ahead) + c0, static_cast<std::size_t>(m), true);
                    }
                    loadSites<S>(in, loaded, c0, mosaicRow[loaded % 3] + o, m, full);
                }
                const int parity = source & 1;
                float* own = demosaiced[ownColour[parity]];
                float* third = demosaiced[otherColour[parity]];
                const std::size_t roles = static_cast<std::size_t>(parity) * n + o;
#ifdef AVATAR_DEMOSAIC_AVX512
                if (avx512 && reduce) {  // a whole-image pass (c0 = 0, c1 = w): the sums on the way
                    saturated += demosaicSumRowAvx512(
                        mosaicRow[(source - 1) % 3], mosaicRow[source % 3], mosaicRow[(source + 1) % 3],
                        ownColumn[roles] != 0.0f, own, demosaiced[1], third, sums[ownColour[parity]], sums[1],
                        sums[otherColour[parity]], y % 4 == 0, full, w);
                    summed = true;
                } else if (avx512)
                    demosaicRowAvx512(mosaicRow[(source - 1) % 3] + o, mosaicRow[source % 3] + o,
                                      mosaicRow[(source + 1) % 3] + o, ownColumn[roles] != 0.0f, own + o,
                                      demosaiced[1] + o, third + o, m);
                else
#endif
                    demosaicRow(mosaicRow[(source - 1) % 3] + o, mosaicRow[source % 3] + o,
                                mosaicRow[(source + 1) % 3] + o, ownColumn.data() + roles,
                                greenColumn.data() + roles, own + o, demosaiced[1] + o, third + o, m);
                for (float* plane : demosaiced) {  // the first and last columns copy their neighbour's
                    if (c0 == 0) plane[0] = plane[1];
                    if (c1 == w) plane[w - 1] = plane[w - 2];
                }
                if (summed) {  // and are summed here, as sumAndCount() would
                    for (const int x : {0, w - 1}) {
                        for (int c = 0; c < 3; ++c)
                            sums[c][x] = y % 4 == 0 ? demosaiced[c][x] : sums[c][x] + demosaiced[c][x];
                        saturated += (demosaiced[0][x] >= full) | (demosaiced[1][x] >= full) | (demosaiced[2][x] >= full);
                    }
                }
                lastSource = source;
            }
            const float* const* planes = demosaiced;
            const float* b = planes[0];
            const float* g = planes[1];
            const float* r = planes[2];
            const int x0 = area.x, x1 = area.x + area.width;
            if (writeImage)
                storeRow(b + x0, g + x0, r + x0, samplePlanes.data(), out.bgr.ptr<S>(y) + 3 * x0, area.width);

            for (std::size_t t = 0; t < types; ++t) {
                const ColorTest& test = (*in.tests)[t];
                std::uint8_t* mask = out.masks[t].ptr<std::uint8_t>(y);
                const cv::Rect& win = test.window();
                const bool inRows = y >= win.y && y < win.y + win.height;
                if (regional) {  // the rest of the mask is 0 already
                    const int a = std::max(x0, win.x), e = std::min(x1, win.x + win.width);
                    if (inRows && a < e) test.row(b + a, g + a, r + a, mask + a, e - a, scratch.data());
                    continue;
                }
                // A row known to be 0 (masksDirty) is written only where its
                // verdicts are not: they go to a row in the cache first.
                const bool zero = dirtyRows[t][static_cast<std::size_t>(y)] == 0;
                if (!inRows) {
                    if (!zero) std::memset(mask, 0, n);
                    continue;
                }
                std::uint8_t* verdict = zero ? verdicts.data() : mask;
                if (!zero) std::memset(mask, 0, static_cast<std::size_t>(win.x));
                const bool some = test.row(b + win.x, g + win.x, r + win.x, verdict + win.x, win.width, scratch.data());
                if (!zero) std::memset(mask + win.x + win.width, 0, static_cast<std::size_t>(w - win.x - win.width));
                int& first = out.maskRows[t].begin[static_cast<std::size_t>(y)];
                int& last = out.maskRows[t].end[static_cast<std::size_t>(y)];
                if (some) nonZeroSpan(verdict + win.x, win.width, first, last);
                if (last > first) {
                    first += win.x;
                    last += win.x;
                    if (zero) std::memcpy(mask + first, verdict + first, static_cast<std::size_t>(last - first));
                }
            }

            if (measure) {
                if (reduce) {
                    if (!summed) saturated += sumAndCount(b, g, r, sums[0], sums[1], sums[2], w, full, y % 4 == 0);
                    if (y % 4 == 3)
                        addBlockMeans(sums, blockRow.data(), samplePlanes.data(), w / 4, luma);
                } else {
                    saturated += countSaturated(b, g, r, w, full);
                }
            }
        }
    }

    /// After a whole image's rows: its visibility.
    void finish() {
        if (in.visibility)
            out.visibility = reduce ? luma.measures(in.bitDepth, saturated, mosaic.total())
                                    : measureVisibility(out.bgr, in.bitDepth);
        else
            out.visibility.reset();
    }

private:
    const FrontEndInput& in;
    FrontEndResult& out;
    const cv::Mat& mosaic;
    const int w, h, depth;
    const std::size_t n;
    const bool regional, writeImage;
    const std::size_t types;
    bool bgrClear{false}, masksClear{false};
    std::vector<float> rows;
    float* mosaicRow[3];
    float* demosaiced[3];
    float* sums[3];
    std::vector<float> ownColumn, greenColumn;
    int ownColour[2], otherColour[2];
    std::vector<std::uint8_t> scratch;
    std::vector<std::uint8_t> verdicts;  ///< a mask row's verdicts, for a row known to be 0
    std::vector<std::vector<std::uint8_t>> dirtyRows;  ///< per mask and row: may hold non-zero values
    std::vector<S> samplePlanes;
    std::vector<float> blockRow;
    const float full;
    [[maybe_unused]] const bool avx512;
    const bool measure, reduce;
    LumaSums luma;  ///< of the 4x4-block means (reduce)
    std::int64_t saturated{0};
    // The area being computed and where its rows stand.
    cv::Rect area;
    int c0{0}, c1{0}, m{0};
    std::size_t o{0};
    int loaded{0}, lastSource{-1}, y{0};
};

template <typename S>
void run(const FrontEndInput& in, FrontEndResult& out) {
    Pass<S>(in, out).run();
}

/// Both images of a pair, taking turns every kPairStripRows rows: the two
/// read the same lighting factors, which are then still in cache for the
/// second (the factor image, 4 bytes a site, is the largest input).
constexpr int kPairStripRows = 8;

template <typename S>
void runPair(const FrontEndInput& left, FrontEndResult& outLeft, const FrontEndInput& right,
             FrontEndResult& outRight) {
    Pass<S> a(left, outLeft), b(right, outRight);
    if (!a.whole() || !b.whole()) {
        a.run();
        b.run();
        return;
    }
    const int h = left.mosaic.rows;
    a.start(cv::Rect(0, 0, left.mosaic.cols, h));
    b.start(cv::Rect(0, 0, right.mosaic.cols, h));
    for (int y = 0; y < h; y += kPairStripRows) {
        a.advance(y + kPairStripRows);
        b.advance(y + kPairStripRows);
    }
    a.finish();
    b.finish();
}

/// Every second sample of @p in (the sites of one colour in a mosaic row).
AVATAR_KERNEL_CLONES void pickRow(const float* __restrict in, float* __restrict out, int n) {
    for (int i = 0; i < n; ++i) out[i] = in[2 * i];
}

/// The mean of two green sites of each block, rounded half up.
AVATAR_KERNEL_CLONES void greenRow(const float* __restrict a, const float* __restrict b, float* __restrict out,
                                   int n) {
    for (int i = 0; i < n; ++i) out[i] = static_cast<float>(static_cast<std::int32_t>((a[2 * i] + b[2 * i] + 1.0f) * 0.5f));
}

template <typename S>
void coarse(const FrontEndInput& in, const std::vector<ColorTest>& tests, CoarseResult& out) {
    const cv::Mat& mosaic = in.mosaic;
    const int w = mosaic.cols, cw = w / 2, ch = mosaic.rows / 2;
    const std::size_t n = static_cast<std::size_t>(w), half = static_cast<std::size_t>(cw);
    // The superpixel image itself only where the visibility is measured on it
    // (a half size that the 2x2 reduction does not divide).
    const bool keepImage = in.visibility && !(cw % 2 == 0 && ch % 2 == 0 && cw >= 2 && ch >= 2);
    if (keepImage) prepareImage(out.bgr, {cw, ch}, CV_MAKETYPE(mosaic.depth(), 3));
    else out.bgr.release();
    out.masks.resize(tests.size());
    for (cv::Mat& mask : out.masks) prepareImage(mask, {cw, ch}, CV_8UC1);
    std::vector<float> rows(2 * n + 6 * half, 0.0f);
    float* site[2] = {rows.data(), rows.data() + n};
    float* planes[3] = {rows.data() + 2 * n, rows.data() + 2 * n + half, rows.data() + 2 * n + 2 * half};
    float* sums[3] = {planes[2] + half, planes[2] + 2 * half, planes[2] + 3 * half};
    // The visibility from the superpixels, as the whole pass measures it from
    // its pixels: saturated ones counted, 2x2 superpixel means as its 4x4 ones.
    const bool measure = in.visibility && cw % 2 == 0 && ch % 2 == 0 && cw >= 2 && ch >= 2;
    std::int64_t saturated = 0;
    LumaSums luma;  ///< of the 2x2-superpixel means (measure)
    // Where in a block each colour lies: (column, row) of red and blue, the two greens.
    cv::Point red, blue, greens[2];
    int g = 0;
    for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 2; ++i) {
            const int c = bayerSiteColour(in.pattern, i, j);
            if (c == 2) red = {i, j};
            else if (c == 0) blue = {i, j};
            else greens[g++] = {i, j};
        }
    std::vector<std::uint8_t> scratch(half);
    std::vector<S> samplePlanes(3 * half);
    const float full = static_cast<float>((1 << in.bitDepth) - 1);
    for (int y = 0; y < ch; ++y) {
        for (int j = 0; j < 2; ++j) loadSites<S>(in, 2 * y + j, 0, site[j], w, full);
        pickRow(site[red.y] + red.x, planes[2], cw);
        pickRow(site[blue.y] + blue.x, planes[0], cw);
        greenRow(site[greens[0].y] + greens[0].x, site[greens[1].y] + greens[1].x, planes[1], cw);
        if (keepImage) storeRow(planes[0], planes[1], planes[2], samplePlanes.data(), out.bgr.ptr<S>(y), cw);
        if (measure) {
            saturated += sumAndCount(planes[0], planes[1], planes[2], sums[0], sums[1], sums[2], cw, full, y % 2 == 0);
            if (y % 2 == 1) {  // 2x2 superpixels: the 4x4 blocks of the whole pass's reduction
                const int blocks = cw / 2;
                S* p[3] = {samplePlanes.data(), samplePlanes.data() + blocks, samplePlanes.data() + 2 * blocks};
                for (int c = 0; c < 3; ++c) {
                    const float* sum = sums[c];
                    for (int x = 0; x < blocks; ++x) {
                        const auto v = static_cast<std::uint32_t>(static_cast<std::int32_t>(sum[2 * x] + sum[2 * x + 1]));
                        p[c][x] = static_cast<S>((v + 2u) >> 2);
                    }
                }
                luma.addPlanes(p[0], p[1], p[2], blocks);
            }
        }
        for (std::size_t t = 0; t < tests.size(); ++t) {
            std::uint8_t* mask = out.masks[t].ptr<std::uint8_t>(y);
            const cv::Rect& win = tests[t].window();
            std::memset(mask, 0, half);
            if (y < win.y || y >= win.y + win.height) continue;
            tests[t].row(planes[0] + win.x, planes[1] + win.x, planes[2] + win.x, mask + win.x, win.width,
                         scratch.data());
        }
    }
    if (measure)
        out.visibility = luma.measures(in.bitDepth, saturated, static_cast<std::size_t>(cw) * static_cast<std::size_t>(ch));
    else if (in.visibility)
        out.visibility = measureVisibility(out.bgr, in.bitDepth);
    else
        out.visibility.reset();
}

}  // namespace

void runCoarse(const FrontEndInput& in, const std::vector<ColorTest>& tests, CoarseResult& out) {
    if (!frontEndHandles(in.mosaic))
        throw InvalidArgument("coarse pass: needs an 8- or 16-bit one-channel mosaic of at least 4x4");
    if (in.mosaic.depth() == CV_8U)
        coarse<std::uint8_t>(in, tests, out);
    else
        coarse<std::uint16_t>(in, tests, out);
}

bool frontEndHandles(const cv::Mat& mosaic) {
    return mosaic.channels() == 1 && (mosaic.depth() == CV_8U || mosaic.depth() == CV_16U) && mosaic.cols >= 4 &&
           mosaic.rows >= 4;
}

FrontEndInput imageInput(const AnalysisFrame& frame, Side side) {
    FrontEndInput in;
    in.mosaic = frame.original.image(side);
    in.pattern = frame.layout.bayerPattern;
    in.bitDepth = frame.layout.bitDepth;
    in.endianSwap = frame.samplesByteSwapped;
    in.factors = frame.mosaicLightingFactors.empty() ? nullptr : &frame.mosaicLightingFactors;
    return in;
}

namespace {

void checkInput(const FrontEndInput& in) {
    if (!frontEndHandles(in.mosaic))
        throw InvalidArgument("front end: needs an 8- or 16-bit one-channel mosaic of at least 4x4, got " +
                              cv::typeToString(in.mosaic.type()) + " " + std::to_string(in.mosaic.cols) + "x" +
                              std::to_string(in.mosaic.rows));
    const int maxBits = in.mosaic.depth() == CV_8U ? 8 : 16;
    if (in.bitDepth < 1 || in.bitDepth > maxBits)
        throw InvalidArgument("front end: bit depth " + std::to_string(in.bitDepth) + " does not fit " +
                              std::to_string(maxBits) + "-bit samples");
    if (in.factors != nullptr &&
        (in.factors->type() != CV_32FC1 || in.factors->cols != in.mosaic.cols ||
         (in.factors->rows != in.mosaic.rows && in.factors->rows != 2)))
        throw InvalidArgument("front end: the lighting factors must be a CV_32FC1 image of the mosaic's size, or "
                              "its width and two rows");
}

}  // namespace

void runFrontEnd(const FrontEndInput& in, FrontEndResult& out) {
    checkInput(in);
    if (in.mosaic.depth() == CV_8U)
        run<std::uint8_t>(in, out);
    else
        run<std::uint16_t>(in, out);
}

void runFrontEndPair(const FrontEndInput& left, FrontEndResult& outLeft, const FrontEndInput& right,
                     FrontEndResult& outRight) {
    checkInput(left);
    checkInput(right);
    if (left.mosaic.size() != right.mosaic.size() || left.mosaic.depth() != right.mosaic.depth()) {
        runFrontEnd(left, outLeft);
        runFrontEnd(right, outRight);
    } else if (left.mosaic.depth() == CV_8U) {
        runPair<std::uint8_t>(left, outLeft, right, outRight);
    } else {
        runPair<std::uint16_t>(left, outLeft, right, outRight);
    }
}

}  // namespace avatar::detail
