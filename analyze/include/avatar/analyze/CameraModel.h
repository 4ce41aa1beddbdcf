#pragma once
/// @file CameraModel.h
/// The camera model of the Bouguet Camera Calibration Toolbox ("plumb bob",
/// thesis 2.1), exactly as CameraIntrinsics documents it: pinhole with focal
/// lengths fc, principal point cc, skew alphaC and five distortion
/// coefficients kc = (k1, k2, p1, p2, k3).
///
/// Pixel convention (Bouguet and OpenCV): integer coordinates are pixel
/// centres; the upper-left pixel covers [-0.5, 0.5] x [-0.5, 0.5].
///
/// Frames: a point in a camera frame is in millimetres, x right, y down, z
/// along the optical axis. Functions are pure and thread-safe.

#include <avatar/config/StereoSystemConfig.h>

#include <opencv2/core/matx.hpp>
#include <opencv2/core/types.hpp>

#include <array>
#include <optional>

namespace avatar {

/// Plumb-bob distortion of a point on the normalised image plane (x/z, y/z).
cv::Point2d distortNormalized(const CameraIntrinsics& intrinsics, const cv::Point2d& undistorted);

/// Distorted normalised coordinates to pixels: u = fc1 (xd + alphaC yd) + cc1, v = fc2 yd + cc2.
cv::Point2d normalizedToPixel(const CameraIntrinsics& intrinsics, const cv::Point2d& distorted);

/// Inverse of normalizedToPixel(): removes cc, fc and the skew (still distorted).
cv::Point2d pixelToNormalized(const CameraIntrinsics& intrinsics, const cv::Point2d& pixel);

/// Projects a point given in this camera's frame (mm) to a distorted pixel.
/// std::nullopt when the point is not in front of the camera (z <= 0).
std::optional<cv::Point2d> projectPoint(const CameraIntrinsics& intrinsics,
                                        const cv::Point3d& pointCameraMm);

/// Pixel to undistorted normalised coordinates exactly as the Bouguet toolbox
/// `normalize` + `comp_distortion_oulu`: remove cc, fc and skew, then 20
/// fixed-point iterations x <- (xd - dx(x)) / radial(x) (skipped when kc is zero).
/// This is what the analysis pipeline uses, so results match the toolbox.
cv::Point2d normalizePixel(const CameraIntrinsics& intrinsics, const cv::Point2d& pixel);

/// Exact inverse of distortNormalized() by Newton's method: iterates until the
/// step is below @p tolerance (default 1e-12) or 50 iterations. std::nullopt
/// when it does not converge (outside the region where the distortion is
/// invertible, e.g. far corners under strong barrel distortion).
std::optional<cv::Point2d> undistortNormalizedExact(const CameraIntrinsics& intrinsics,
                                                    const cv::Point2d& distorted,
                                                    double tolerance = 1e-12);

/// Pixel to undistorted normalised coordinates by undistortNormalizedExact().
std::optional<cv::Point2d> normalizePixelExact(const CameraIntrinsics& intrinsics,
                                               const cv::Point2d& pixel);

/// Rotation matrix of a Rodrigues vector (radians), as the toolbox's `rodrigues`.
cv::Matx33d rodrigues(const std::array<double, 3>& om);
/// Rodrigues vector of a rotation matrix (inverse of rodrigues()).
std::array<double, 3> rodriguesVector(const cv::Matx33d& rotation);

/// The rotation of a RigidTransform as a matrix.
cv::Matx33d rotationMatrix(const RigidTransform& transform);
/// target_T_source applied to a point in the source frame.
cv::Point3d transformPoint(const RigidTransform& targetTSource, const cv::Point3d& pointSource);
/// source_T_target from target_T_source.
RigidTransform inverse(const RigidTransform& targetTSource);
/// Builds a RigidTransform from a rotation matrix and a translation (mm).
RigidTransform makeRigidTransform(const cv::Matx33d& rotation, const cv::Vec3d& translationMm);

/// right_T_left of a stereo configuration (X_right = R(om) X_left + T).
RigidTransform rightTLeft(const StereoSystemConfig& config);

}  // namespace avatar
