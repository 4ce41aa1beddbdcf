#pragma once
/// @file SphereSilhouette.h
/// Removing the silhouette bias of spherical targets.
///
/// A sphere's silhouette is the image of a circular cone whose apex is the
/// camera centre and whose axis passes through the sphere's centre. Off the
/// optical axis the silhouette is an ellipse whose centroid is not the
/// projection of the sphere's centre: triangulating centroids pulls large,
/// near, off-axis spheres towards the camera (about 1% of range at the
/// edges of the Scorpion's view). The axis of the cone is recovered from the
/// silhouette's conic: in normalised coordinates the conic matrix of the cone
/// is Q = c c^T - cos^2(theta) I, whose one eigenvalue of distinct sign has the
/// centre direction c as eigenvector. No radius is needed.

#include <avatar/analyze/Feature.h>
#include <avatar/config/StereoSystemConfig.h>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include <optional>
#include <vector>

namespace avatar {

/// The outline of one feature of @p mask (CV_8UC1, non-zero = set): the
/// midpoints of the pixel edges between the feature's pixels and pixels
/// outside it (4-neighbours), in pixel coordinates. Unbiased samples of the
/// silhouette edge, unlike the centres of boundary pixels.
std::vector<cv::Point2d> featureOutline(const cv::Mat& mask, const Feature& feature);

/// Undistorted normalised direction (x/z, y/z) of the centre of a sphere from
/// outline points given in distorted pixels of a camera. std::nullopt when
/// fewer than 6 points are given or the fitted conic is not an ellipse.
std::optional<cv::Point2d> sphereCentreDirection(const CameraIntrinsics& camera,
                                                 const std::vector<cv::Point2d>& outlinePx);

}  // namespace avatar
