#pragma once
/// @file CameraModel.h
/// Camera geometry, in one home for everything that projects or
/// back-projects: the analysis (triangulation, epipolar matching, sphere
/// silhouettes) and the simulated cameras of the acquisition layer.
///
/// The camera model is the Bouguet Camera Calibration Toolbox's ("plumb bob",
/// thesis 2.1), also OpenCV's: pinhole with focal lengths fc, principal point
/// cc, skew alphaC and five distortion coefficients kc = (k1, k2, p1, p2, k3).
/// A point x_n = (x, y) on the normalised image plane with r^2 = x^2 + y^2 is
/// distorted to
///   x_d = (1 + kc1 r^2 + kc2 r^4 + kc5 r^6) x_n + dx,
///   dx  = (2 kc3 x y + kc4 (r^2 + 2 x^2),  kc3 (r^2 + 2 y^2) + 2 kc4 x y)
/// and mapped to pixels by
///   u = fc1 (x_d1 + alpha_c x_d2) + cc1,  v = fc2 x_d2 + cc2.
///
/// Pixel convention (Bouguet and OpenCV): integer coordinates are pixel
/// centres; the upper-left pixel covers [-0.5, 0.5] x [-0.5, 0.5].
///
/// Frames: a point in a camera frame is in millimetres, x right, y down, z
/// along the optical axis. The vision frame is the left camera's. Functions
/// are pure and thread-safe. The configuration's StereoSystemConfig converts
/// to StereoGeometry with avatar::stereoGeometry() (config/StereoSystemConfig.h).

#include <avatar/common/RigidTransform.h>

#include <opencv2/core/matx.hpp>
#include <opencv2/core/types.hpp>

#include <array>
#include <optional>

namespace avatar {

/// Intrinsics of one camera (see the file comment for the model).
struct CameraIntrinsics {
    std::array<double, 2> fc{1000.0, 1000.0};  ///< focal length in pixels
    std::array<double, 2> cc{640.0, 480.0};    ///< principal point in pixels
    double alphaC{0.0};                        ///< skew coefficient
    std::array<double, 5> kc{0, 0, 0, 0, 0};   ///< k1, k2, p1, p2, k3
    bool operator==(const CameraIntrinsics& o) const {
        return fc == o.fc && cc == o.cc && alphaC == o.alphaC && kc == o.kc;
    }
};

/// A calibrated stereo pair and, when known, its registration to the manipulator.
struct StereoGeometry {
    CameraIntrinsics left;
    CameraIntrinsics right;
    RigidTransform rightTLeft;                 ///< X_right = R X_left + T
    std::optional<RigidTransform> baseTVision; ///< the camera-manipulator registration (thesis 3.1.2)
};

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

/// Camera matrix K of Appendix A in the Bouguet convention:
/// [fc1, fc1 alphaC, cc1; 0, fc2, cc2; 0, 0, 1].
cv::Matx33d cameraMatrix(const CameraIntrinsics& intrinsics);

/// Essential matrix E = [T]x R of right_T_left = (R, T) (Appendix A): for
/// normalised coordinates x = (x/z, y/z, 1) of one point, x_r^T E x_l = 0.
cv::Matx33d essentialMatrix(const RigidTransform& rightTLeft);

/// Fundamental matrix F of Appendix A: l_right = F p_left for homogeneous pixels,
/// F = K_r^-T E K_l^-1 (the thesis prints K_r^T, a typo), so that
/// p_r^T F p_l = 0. It holds for undistorted pixels K x_n; with lens distortion
/// undistort first (normalizePixel(), then normalizedToPixel()).
cv::Matx33d fundamentalMatrix(const StereoGeometry& stereo);

}  // namespace avatar
