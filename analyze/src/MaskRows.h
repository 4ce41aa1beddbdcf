#pragma once
// Internal to avatar::analyze: where a mask's "on" pixels lie, row by row,
// handed from the stage that wrote the mask to the ones that label it, so
// that they read only those parts of it.
//
// A filtered 1280x960 mask is 1.2 MB of which a few thousand bytes are on;
// scanning it whole for runs, once in erode_restore and again in
// locate_features, for two masks of two images, was a tenth of a whole
// analysis, bound by the memory it streamed (docs/benchmarks.md). The front
// end knows each row's span while the row is still in the first-level
// cache.

#include <avatar/analyze/Feature.h>
#include <avatar/config/TargetConfig.h>

#include <opencv2/core/mat.hpp>

#include <cstdint>
#include <vector>

namespace avatar::detail {

/// Every "on" pixel of row y of the mask whose buffer starts at @ref data
/// lies in [begin[y], end[y]) (begin == end: the row is empty). A promise of
/// the writer: a wider span only costs time, a narrower one loses pixels.
struct MaskRows {
    const std::uint8_t* data{nullptr};  ///< the mask's buffer these rows describe
    std::vector<int> begin, end;

    /// Whether these rows describe @p mask (its buffer and height).
    bool describes(const cv::Mat& mask) const {
        return data != nullptr && data == mask.data && begin.size() == static_cast<std::size_t>(mask.rows) &&
               end.size() == begin.size();
    }
};

/// The bands of consecutive rows of @p rows that are not empty, each as wide
/// as the mask (@p width): where the mask may be non-zero, in a few rectangles.
std::vector<cv::Rect> nonZeroBands(const MaskRows& rows, int width);

/// The span of the non-zero bytes of @p row (@p n of them) as [begin, end),
/// begin == end == 0 when there is none. Reads the row once when it is empty.
void nonZeroSpan(const std::uint8_t* row, int n, int& begin, int& end);

/// erodeRestore() (ImageFeatureLocator.h) written into @p mask itself: the
/// components that do not survive the erosion are cleared, the others left
/// as they are (the result is the same 0/255 mask when @p mask is 0/255).
/// The caller owns @p mask alone. @p rows: where its on pixels lie (described
/// rows of this mask; may be null); on return, where the kept ones lie.
/// Returns the number of components kept.
int erodeRestoreInPlace(cv::Mat& mask, int kernelSize, const MaskRows* rows, MaskRows& kept);

/// locateFeatures() (ImageFeatureLocator.h), reading of @p mask only the
/// spans @p rows gives (rows that describe @p mask, or null: all of it).
std::vector<Feature> locateFeatures(const cv::Mat& mask, const cv::Mat& intensity, const TargetType& type,
                                    cv::Rect window, const MaskRows* rows);

}  // namespace avatar::detail
