#pragma once
/// @file ImageReduce.h
/// Internal to avatar::analyze: serial whole-image reductions used by the
/// visibility stage, written to give exactly what the OpenCV calls they
/// replace give, at a fraction of the cost (docs/benchmarks.md).

#include <avatar/analyze/Visibility.h>

#include <opencv2/core/mat.hpp>

#include <cstddef>
#include <cstdint>

namespace avatar::detail {

/// The same as cv::resize(image, out, {}, 0.25, 0.25, cv::INTER_AREA) for an
/// 8- or 16-bit image of 1..4 channels, bit for bit: when both sides are
/// multiples of 4 each output sample is the mean of its 4x4 block rounded to
/// nearest, ties to even (OpenCV's fast area path); otherwise cv::resize is
/// called. @p out is reused when it has the right size and type.
void downsampleArea4(const cv::Mat& image, cv::Mat& out);

/// The number of pixels with at least one channel >= @p threshold of an 8-
/// or 16-bit image of 1..4 channels: the count of non-zero pixels of the
/// per-channel comparison reduced by "or", without the temporary masks.
std::int64_t countPixelsWithAnyAtLeast(const cv::Mat& image, double threshold);

/// measureVisibility() from its parts: @p small the BGR image reduced by
/// downsampleArea4(), @p saturatedPixels of @p pixels at full scale. The
/// fused front end gathers both in its pass over the image. Contrast and haze
/// come from exact integer sums over @p small (luma in thousandths, its
/// square, the smallest channel), rounded once at the end, in one pass that
/// allocates nothing.
VisibilityMeasures visibilityFromReduced(const cv::Mat& small, int bitDepth, std::int64_t saturatedPixels,
                                         std::size_t pixels);

}  // namespace avatar::detail
