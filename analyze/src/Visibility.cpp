#include <avatar/analyze/Visibility.h>

#include "ImageReduce.h"
#include "KernelClones.h"

#include <avatar/common/Error.h>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>

namespace avatar {

namespace {

/// Sums over one row of @p n interleaved BGR pixels: the luma in thousandths
/// (114 B + 587 G + 299 R, an exact integer below 2^31 for 16-bit samples),
/// its square and the smallest channel. The squares are summed in 64 bits,
/// exact for up to kChunk pixels (kChunk * (1000 * 65535)^2 < 2^64).
constexpr int kChunk = 1024;

/// Wide enough for n * sum(l^2) of any image (GCC's and Clang's 128-bit type).
__extension__ typedef unsigned __int128 Wide;

template <typename S>
AVATAR_KERNEL_CLONES void lumaSums(const S* __restrict px, int n, std::uint64_t& luma, std::uint64_t& squares,
                                   std::uint64_t& minimum) {
    std::uint64_t l = 0, q = 0, m = 0;
    for (int i = 0; i < n; ++i) {
        const std::uint32_t b = px[3 * i], g = px[3 * i + 1], r = px[3 * i + 2];
        const std::uint32_t y = 114u * b + 587u * g + 299u * r;
        l += y;
        q += static_cast<std::uint64_t>(y) * y;
        m += std::min(std::min(b, g), r);
    }
    luma += l;
    squares += q;
    minimum += m;
}

/// Contrast and haze of a BGR image from the exact sums of lumaSums(). On
/// the interleaved samples: splitting each row into planes first, so that the
/// sums vectorise, was 6 times slower (the loads of the just-stored planes
/// stall).
template <typename S>
VisibilityMeasures lumaStatistics(const cv::Mat& small, double full) {
    std::uint64_t luma = 0, minimum = 0;
    Wide squares = 0;
    for (int y = 0; y < small.rows; ++y) {
        const S* row = small.ptr<S>(y);
        for (int x = 0; x < small.cols; x += kChunk) {
            std::uint64_t q = 0;
            lumaSums(row + 3 * x, std::min(kChunk, small.cols - x), luma, q, minimum);
            squares += q;
        }
    }
    // n^2 var = n sum(l^2) - sum(l)^2, exactly (>= 0 by Cauchy-Schwarz), so
    // the only rounding is the conversion to double.
    const auto n = static_cast<Wide>(small.total());
    const Wide spread = n * squares - static_cast<Wide>(luma) * luma;
    const auto count = static_cast<double>(small.total());
    VisibilityMeasures m;
    m.contrast = std::sqrt(static_cast<double>(spread)) / count / (1000.0 * full);
    m.haze = static_cast<double>(minimum) / count / full;
    return m;
}

}  // namespace

VisibilityMeasures detail::visibilityFromReduced(const cv::Mat& small, int bitDepth, std::int64_t saturatedPixels,
                                                std::size_t pixels) {
    if (small.empty() || small.channels() != 3 || (small.depth() != CV_8U && small.depth() != CV_16U))
        throw InvalidArgument("visibility: the reduced image must be a non-empty CV_8UC3 or CV_16UC3 image, got " +
                              cv::typeToString(small.type()));
    const double full = static_cast<double>((1 << bitDepth) - 1);
    VisibilityMeasures m = small.depth() == CV_8U ? lumaStatistics<std::uint8_t>(small, full)
                                                  : lumaStatistics<std::uint16_t>(small, full);
    m.saturatedFraction = static_cast<double>(saturatedPixels) / static_cast<double>(pixels);
    return m;
}

VisibilityMeasures measureVisibility(const cv::Mat& bgr, int bitDepth) {
    cv::Mat small;
    detail::downsampleArea4(bgr, small);  // = cv::resize INTER_AREA, bit for bit, serial
    const double full = static_cast<double>((1 << bitDepth) - 1);
    return detail::visibilityFromReduced(small, bitDepth, detail::countPixelsWithAnyAtLeast(bgr, full), bgr.total());
}

VisibilityVerdict judgeVisibility(const VisibilityMeasures& left, const VisibilityMeasures& right,
                                  const VisibilityConfig& limits) {
    std::string reason;
    const auto add = [&](const char* text) { reason += (reason.empty() ? "" : "; ") + std::string(text); };
    for (const auto& [name, m] : {std::pair<const char*, const VisibilityMeasures&>{"left", left}, {"right", right}}) {
        char buf[128];
        if (m.contrast < limits.minContrast) {
            std::snprintf(buf, sizeof buf, "%s: contrast %.4f below %.4f", name, m.contrast, limits.minContrast);
            add(buf);
        }
        if (m.saturatedFraction > limits.maxSaturatedFraction) {
            std::snprintf(buf, sizeof buf, "%s: %.1f%% saturated, above %.1f%%", name, 100.0 * m.saturatedFraction,
                          100.0 * limits.maxSaturatedFraction);
            add(buf);
        }
        if (m.haze > limits.maxHaze) {
            std::snprintf(buf, sizeof buf, "%s: haze %.3f above %.3f", name, m.haze, limits.maxHaze);
            add(buf);
        }
    }
    return {reason.empty() ? Visibility::Good : Visibility::Poor, reason};
}

}  // namespace avatar
