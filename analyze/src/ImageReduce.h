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

/// The exact sums measureVisibility() takes from a BGR image reduced by
/// downsampleArea4(), gathered row by row: the luma in thousandths (114 B +
/// 587 G + 299 R, an integer below 2^32 for 16-bit samples), its square and
/// the smallest channel. The fused front end adds each row of 4x4-block means
/// as it computes them, as planes, so that the reduced image is never stored
/// nor read again. Integer sums: any order of rows gives the same measures.
class LumaSums {
public:
    /// Adds @p n pixels given as three planes.
    template <typename S>
    void addPlanes(const S* b, const S* g, const S* r, int n);
    /// Adds @p n interleaved BGR pixels.
    template <typename S>
    void addInterleaved(const S* bgr, int n);
    /// Contrast and haze of the pixels added (rounded once, here), with
    /// @p saturatedPixels of the full image's @p pixels at full scale.
    /// Throws avatar::InvalidArgument when nothing was added.
    VisibilityMeasures measures(int bitDepth, std::int64_t saturatedPixels, std::size_t pixels) const;

private:
    /// @p n pixels whose channels lie @p Stride samples apart.
    template <int Stride, typename S>
    void add(const S* b, const S* g, const S* r, int n);
    __extension__ typedef unsigned __int128 Wide;  ///< GCC's and Clang's 128-bit type: n * sum(l^2) of any image
    std::uint64_t count_{0}, luma_{0}, minimum_{0};
    Wide squares_{0};
};

/// measureVisibility() from its parts: @p small the BGR image reduced by
/// downsampleArea4(), @p saturatedPixels of @p pixels at full scale
/// (LumaSums over @p small's rows).
VisibilityMeasures visibilityFromReduced(const cv::Mat& small, int bitDepth, std::int64_t saturatedPixels,
                                         std::size_t pixels);

}  // namespace avatar::detail
