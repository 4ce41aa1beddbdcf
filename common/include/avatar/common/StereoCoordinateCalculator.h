#pragma once
/// @file StereoCoordinateCalculator.h
/// 3-D reconstruction of a matched pixel pair (thesis 3.4.2, Figure 3-18):
/// the midpoint triangulation of the Bouguet toolbox's `stereo_triangulation`.
/// The only triangulation of the system: the matcher's depth test, the
/// centroid, sphere and nine-point positions all come from here.

#include <avatar/common/CameraModel.h>

#include <opencv2/core/matx.hpp>
#include <opencv2/core/types.hpp>

#include <optional>

namespace avatar {

/// One triangulated point, in millimetres.
struct StereoPoint {
    cv::Point3d leftMm;   ///< XL: left camera (vision) frame
    cv::Point3d rightMm;  ///< XR = R XL + T: right camera frame
    /// base_T_vision XL; set when the geometry has a registration.
    std::optional<cv::Point3d> baseMm;
};

/// Triangulates matched pixels with one stereo calibration. Immutable after
/// construction; safe to share between threads.
class StereoCoordinateCalculator {
public:
    explicit StereoCoordinateCalculator(const StereoGeometry& geometry);

    /// Figure 3-18: normalize both pixels (Bouguet `normalize`), then
    ///   u = R Xl, DD = |Xl|^2 |Xr|^2 - (Xr.u)^2,
    ///   NN1 = (Xr.u)(Xr.T) - |Xr|^2 (u.T),  NN2 = |Xl|^2 (Xr.T) - (u.T)(Xr.u),
    ///   Zl = NN1/DD, Zr = NN2/DD, X1 = Xl Zl, X2 = R^T (Xr Zr - T),
    ///   XL = (X1 + X2) / 2, XR = R XL + T.
    /// std::nullopt when the two rays are parallel (DD == 0 to rounding).
    std::optional<StereoPoint> triangulate(const cv::Point2d& leftPx,
                                           const cv::Point2d& rightPx) const;

    /// The same on undistorted normalised coordinates (x/z, y/z) of each camera,
    /// for points that are not pixels (e.g. a sphere's silhouette-cone axis).
    std::optional<StereoPoint> triangulateNormalized(const cv::Point2d& leftNormalized,
                                                     const cv::Point2d& rightNormalized) const;

    /// True when the geometry carries base_T_vision.
    bool hasRegistration() const { return geometry_.baseTVision.has_value(); }
    /// Maps a vision-frame point to the manipulator base frame; throws
    /// avatar::InvalidArgument when there is no registration.
    cv::Point3d visionToBase(const cv::Point3d& visionMm) const;

    const StereoGeometry& geometry() const { return geometry_; }

private:
    StereoGeometry geometry_;
    cv::Matx33d rightRLeft_;
    cv::Vec3d rightTLeftMm_;
};

}  // namespace avatar
