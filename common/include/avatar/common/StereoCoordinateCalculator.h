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
    /// Distance between the two rays at their closest approach, |X1 - X2|.
    double rayGapMm{0.0};
    /// RMS distance of XL's projections from the two measured points, in
    /// undistorted pixels of each camera (normalised distance x fc).
    double reprojectionPx{0.0};
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

    /// First-order covariance of leftMm (mm^2) for measured points with the
    /// 2x2 covariances @p covLeft and @p covRight: in normalised coordinates
    /// for covarianceNormalized(), in pixels for covariancePixels() (the
    /// normalisation's Jacobian included). Numeric Jacobian of the midpoint
    /// triangulation by central differences. std::nullopt where the rays are
    /// (nearly) parallel.
    std::optional<cv::Matx33d> covarianceNormalized(const cv::Point2d& leftNormalized,
                                                    const cv::Point2d& rightNormalized,
                                                    const cv::Matx22d& covLeft,
                                                    const cv::Matx22d& covRight) const;
    std::optional<cv::Matx33d> covariancePixels(const cv::Point2d& leftPx, const cv::Point2d& rightPx,
                                                const cv::Matx22d& covLeftPx,
                                                const cv::Matx22d& covRightPx) const;

    /// The covariance of base_T_vision X for a vision-frame covariance:
    /// R Cov R^T. Throws avatar::InvalidArgument without a registration.
    cv::Matx33d covarianceToBase(const cv::Matx33d& visionCovariance) const;

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
