#pragma once
/// @file Visibility.h
/// Visibility measures and verdict (thesis 3.6.1): whether an image pair is
/// fit to look for targets in (turbid water, a lamp that failed, a camera
/// facing the sun), judged from global statistics of each image.

#include <avatar/common/VisionTargets.h>
#include <avatar/config/AnalysisConfig.h>

#include <opencv2/core/mat.hpp>

#include <string>

namespace avatar {

/// The global statistics of one BGR image, each relative to full scale.
struct VisibilityMeasures {
    double contrast{0.0};           ///< RMS contrast: std(luma) / full scale
    double saturatedFraction{0.0};  ///< pixels with any channel at full scale / pixels, in [0, 1]
    double haze{0.0};               ///< mean of the per-pixel minimum channel / full scale
};

/// Measures an 8- or 16-bit BGR image with @p bitDepth significant bits.
/// Contrast and haze are measured on a 4x area-downsampled image (they are
/// global, so this costs little accuracy and three quarters of the time);
/// saturation on the full image, where downsampling would average it away.
VisibilityMeasures measureVisibility(const cv::Mat& bgr, int bitDepth);

/// The verdict of a pair.
struct VisibilityVerdict {
    Visibility visibility{Visibility::Unknown};
    /// Empty when good; otherwise every limit each image breaks, e.g.
    /// "left: contrast 0.0100 below 0.0200; right: haze 0.700 above 0.600".
    std::string reason;
};

/// Good when both images are within every limit of @p limits, otherwise Poor.
VisibilityVerdict judgeVisibility(const VisibilityMeasures& left, const VisibilityMeasures& right,
                                  const VisibilityConfig& limits);

}  // namespace avatar
