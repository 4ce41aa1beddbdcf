#pragma once
/// @file NinePointTriangulation.h
/// Internal: the nine-point triangulation of thesis 3.4.2, the option
/// TriangulationMode::NinePoints.

#include <avatar/analyze/Feature.h>
#include <avatar/common/StereoCoordinateCalculator.h>

#include <opencv2/core/types.hpp>

#include <optional>

namespace avatar::detail {

/// Triangulates the nine interest points of a matched pair (Figure 3-14: the
/// eight boundary points of Table 3-1, then the centroid, given here as the
/// configured kind of centroid) with @p calculator and averages the points
/// that triangulate (the vision frame, and the base frame when the calculator
/// has a registration; rightMm is left at 0). Boundary points correspond
/// between the images only for near-parallel cameras. std::nullopt when no
/// point triangulates.
std::optional<StereoPoint> triangulateNinePoints(const StereoCoordinateCalculator& calculator,
                                                 const Feature& left, const Feature& right,
                                                 const cv::Point2d& leftCentroid, const cv::Point2d& rightCentroid);

}  // namespace avatar::detail
