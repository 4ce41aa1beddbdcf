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
///
/// Any non-zero mask value counts as "on"; the result is 0/255. Pixels beyond
/// the image edge count as "on" during the erosion, so a feature cut by the
/// edge is eroded only from its inside (a target partly out of view is not
/// penalised twice). A kernel size of 1 returns the mask unchanged (as 0/255).
/// Throws avatar::FormatError when @p mask is not CV_8UC1 and
/// avatar::InvalidArgument when @p kernelSize is not odd and positive.
cv::Mat erodeRestore(const cv::Mat& mask, int kernelSize);
/// The same into @p out, written in place when it is a CV_8UC1 of the mask's
/// size (the caller decides it may be overwritten; a view into a larger image
/// is written there), else (re)allocated; it must not share the mask's buffer
/// (avatar::InvalidArgument).
void erodeRestore(const cv::Mat& mask, int kernelSize, cv::Mat& out);

/// Finds the 8-connected features of @p mask (CV_8UC1, non-zero = "on")
/// inside @p window (non-recursive), computes their geometry (centroid,
/// Table 3-1 boundary points with the tie rules of Appendix C, box, aspect
/// ratio, area ratio) and keeps those whose area, aspect ratio and area ratio
/// are within the type's ranges (inclusive).
///
/// Only the pixels inside @p window are considered: a feature crossing the
/// window edge is cut there (and has touchesBorder set). All coordinates of
/// the returned features are full-image pixel coordinates.
/// @param intensity optional CV_8UC3/CV_16UC3 image of the mask's size for the
///        weighted centroid (weights R+G+B); empty, or a feature whose pixels
///        are all black: weightedCentroid = centroid.
/// @param window must be non-empty and inside the mask, e.g. from searchWindow().
/// Features are returned in raster order of their first pixel (their
/// kTopLeft point). Throws avatar::FormatError for a mask or intensity image
/// of the wrong type and avatar::InvalidArgument for a window outside the
/// mask or an intensity image of another size.
std::vector<Feature> locateFeatures(const cv::Mat& mask, const cv::Mat& intensity,
                                    const TargetType& type, cv::Rect window);

/// The search window of a type clipped to an image of @p size (the whole image
/// when the window is unset, i.e. width or height 0). Throws
/// avatar::InvalidArgument naming the window and the image size when the
/// window lies entirely outside the image or the image size is empty.
cv::Rect searchWindow(const TargetType& type, cv::Size size);

}  // namespace avatar
