#pragma once
/// @file ImageFeatureLocator.h
/// Erode and feature-AND restore (thesis 3.3.2) and 8-connected feature
/// location with the geometric filter (thesis 3.3.3).

#include <avatar/analyze/Feature.h>
#include <avatar/config/TargetConfig.h>

#include <opencv2/core/mat.hpp>

#include <vector>

namespace avatar {

/// Erodes @p mask (CV_8UC1, 0/255) with a square kernel of @p kernelSize, then
/// restores every 8-connected component of the original mask that kept at
/// least one pixel to its full original extent (morphological reconstruction,
/// the thesis's "feature-AND"). Components that vanished are removed.
cv::Mat erodeRestore(const cv::Mat& mask, int kernelSize);

/// Finds the 8-connected features of @p mask inside @p window (non-recursive),
/// computes their geometry (centroid, Table 3-1 boundary points with the tie
/// rules of Appendix C, box, aspect ratio, area ratio) and keeps those whose
/// area, aspect ratio and area ratio are within the type's ranges.
/// @param intensity optional CV_8UC3/CV_16UC3 image for the weighted centroid
///        (weights R+G+B); empty: weightedCentroid = centroid.
/// Features are returned in raster order of their first pixel.
std::vector<Feature> locateFeatures(const cv::Mat& mask, const cv::Mat& intensity,
                                    const TargetType& type, cv::Rect window);

/// The search window of a type clipped to an image of @p size (the whole image
/// when the window is unset). Throws avatar::InvalidArgument when the window
/// lies entirely outside the image.
cv::Rect searchWindow(const TargetType& type, cv::Size size);

}  // namespace avatar
