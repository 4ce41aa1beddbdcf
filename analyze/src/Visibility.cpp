#include <avatar/analyze/Visibility.h>

#include "ImageReduce.h"

#include <opencv2/core.hpp>

#include <cstdio>

namespace avatar {

VisibilityMeasures detail::visibilityFromReduced(const cv::Mat& small, int bitDepth, std::int64_t saturatedPixels,
                                                std::size_t pixels, VisibilityScratch* reuse) {
    const double full = static_cast<double>((1 << bitDepth) - 1);
    VisibilityScratch local;
    VisibilityScratch& s = reuse != nullptr ? *reuse : local;
    cv::Mat* channels = s.channels.data();
    small.convertTo(s.scaled, CV_32F, 1.0 / full);
    cv::split(s.scaled, channels);
    // 0.114 B + 0.587 G + 0.299 R and the minimum channel, written as the
    // calls OpenCV's expressions make, into buffers kept from frame to frame.
    cv::addWeighted(channels[0], 0.114f, channels[1], 0.587f, 0.0, s.luma);
    cv::addWeighted(s.luma, 1.0, channels[2], 0.299f, 0.0, s.luma);
    cv::Scalar mean, stddev;
    cv::meanStdDev(s.luma, mean, stddev);
    VisibilityMeasures m;
    m.contrast = stddev[0];
    cv::min(channels[0], channels[1], s.minChannel);
    cv::min(s.minChannel, channels[2], s.minChannel);
    m.haze = cv::mean(s.minChannel)[0];
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
