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

/// Sums over @p n pixels (LumaSums): exact, the squares in 64 bits for up to
/// kChunk pixels (kChunk * (1000 * 65535)^2 < 2^64).
constexpr int kChunk = 1024;

/// Over @p n pixels whose channels lie @p Stride samples apart: 1 for three
/// planes, 3 for interleaved BGR (read where it is: splitting each row into
/// planes first was 6 times slower, the loads of the just-stored planes stall).
template <int Stride, typename S>
AVATAR_KERNEL_CLONES void lumaKernel(const S* __restrict b, const S* __restrict g, const S* __restrict r, int n,
                                     std::uint64_t& luma, std::uint64_t& squares, std::uint64_t& minimum) {
    std::uint64_t l = 0, q = 0, m = 0;
    for (int i = 0; i < n; ++i) {
        const std::uint32_t bi = b[Stride * i], gi = g[Stride * i], ri = r[Stride * i];
        const std::uint32_t y = 114u * bi + 587u * gi + 299u * ri;
        l += y;
        q += static_cast<std::uint64_t>(y) * y;
        m += std::min(std::min(bi, gi), ri);
    }
    luma += l;
    squares += q;
    minimum += m;
}

}  // namespace

template <int Stride, typename S>
void detail::LumaSums::add(const S* b, const S* g, const S* r, int n) {
    for (int x = 0; x < n; x += kChunk) {
        std::uint64_t q = 0;
        const int k = std::min(kChunk, n - x);
        lumaKernel<Stride>(b + Stride * x, g + Stride * x, r + Stride * x, k, luma_, q, minimum_);
        squares_ += q;
    }
    count_ += static_cast<std::uint64_t>(std::max(n, 0));
}

template <typename S>
void detail::LumaSums::addPlanes(const S* b, const S* g, const S* r, int n) {
    add<1>(b, g, r, n);
}

template <typename S>
void detail::LumaSums::addInterleaved(const S* bgr, int n) {
    add<3>(bgr, bgr + 1, bgr + 2, n);
}

template void detail::LumaSums::addPlanes(const std::uint8_t*, const std::uint8_t*, const std::uint8_t*, int);
template void detail::LumaSums::addPlanes(const std::uint16_t*, const std::uint16_t*, const std::uint16_t*, int);
template void detail::LumaSums::addInterleaved(const std::uint8_t*, int);
template void detail::LumaSums::addInterleaved(const std::uint16_t*, int);

VisibilityMeasures detail::LumaSums::measures(int bitDepth, std::int64_t saturatedPixels, std::size_t pixels) const {
    if (count_ == 0 || pixels == 0) throw InvalidArgument("visibility: no pixels were measured");
    const double full = static_cast<double>((1 << bitDepth) - 1);
    // n^2 var = n sum(l^2) - sum(l)^2, exactly (>= 0 by Cauchy-Schwarz), so
    // the only rounding is the conversion to double.
    const Wide spread = static_cast<Wide>(count_) * squares_ - static_cast<Wide>(luma_) * luma_;
    const auto count = static_cast<double>(count_);
    VisibilityMeasures m;
    m.contrast = std::sqrt(static_cast<double>(spread)) / count / (1000.0 * full);
    m.haze = static_cast<double>(minimum_) / count / full;
    m.saturatedFraction = static_cast<double>(saturatedPixels) / static_cast<double>(pixels);
    return m;
}

VisibilityMeasures detail::visibilityFromReduced(const cv::Mat& small, int bitDepth, std::int64_t saturatedPixels,
                                                std::size_t pixels) {
    if (small.empty() || small.channels() != 3 || (small.depth() != CV_8U && small.depth() != CV_16U))
        throw InvalidArgument("visibility: the reduced image must be a non-empty CV_8UC3 or CV_16UC3 image, got " +
                              cv::typeToString(small.type()));
    LumaSums sums;
    for (int y = 0; y < small.rows; ++y) {
        if (small.depth() == CV_8U) sums.addInterleaved(small.ptr<std::uint8_t>(y), small.cols);
        else sums.addInterleaved(small.ptr<std::uint16_t>(y), small.cols);
    }
    return sums.measures(bitDepth, saturatedPixels, pixels);
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
