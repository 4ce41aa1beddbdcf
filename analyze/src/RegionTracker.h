#pragma once
// Internal to avatar::analyze: the region-of-interest tracking mode
// (config.analysis.tracking, docs/config.md). The thesis let an operator set
// a search window per target type; here the windows follow the targets: after
// a whole-image search, the next frames are searched only in regions around
// the whole stereo targets found, each region the target's feature box in
// that image widened by the margin. A frame is searched whole again
//  - every fullFrameEvery frames (a new target can only be found there);
//  - after a tracking frame that found fewer whole stereo targets than it
//    followed, or found any target flagged partial or seen in one image only
//    (lost, leaving its region, hidden, cut by the region's edge);
//  - while a whole-image search finds no whole stereo target.
// A tracking frame keeps the visibility measures of the last whole image.

#include <avatar/analyze/ProcessStereoImagePair.h>
#include <avatar/config/AnalysisConfig.h>

#include <opencv2/core/types.hpp>

#include <array>
#include <cstddef>
#include <vector>

namespace avatar::detail {

class RegionTracker {
public:
    /// @param coarseToFine whether whole-image frames are searched coarse-to-fine (AnalysisFrame::coarse)
    RegionTracker(const TrackingConfig& config, bool coarseToFine) : config_(config), coarse_(coarseToFine) {}

    /// Sets up @p frame (acquired pair and layout already set) for this
    /// iteration: its regions (none: the whole image) and, for a tracking
    /// frame, the last whole image's visibility measures; a whole-image frame
    /// is marked coarse when coarse-to-fine is on.
    void begin(AnalysisFrame& frame) const;

    /// Learns from the analysed @p frame where the next one is searched.
    void end(const AnalysisFrame& frame);

    /// Frames since the last whole-image search (0 before the first).
    int framesSinceFull() const { return sinceFull_; }

private:
    TrackingConfig config_;
    bool coarse_;
    std::array<std::vector<cv::Rect>, 2> next_;  ///< empty: the whole image
    std::array<VisibilityMeasures, 2> visibility_;
    std::size_t followed_{0};  ///< whole stereo targets the regions were made for
    int sinceFull_{0};
};

/// The regions around @p boxes in an image of @p size: each box widened by
/// @p margin and clipped to the image, then every two that overlap or lie
/// within one pixel of each other merged into their bounding box until all are
/// apart (so no 8-connected feature spans two), in raster order of their corners.
std::vector<cv::Rect> regionsAround(const std::vector<cv::Rect>& boxes, int margin, cv::Size size);

}  // namespace avatar::detail
