#pragma once
/// @file StereoSystemConfig.h
/// Calibration of the stereo pair and its registration to the manipulator
/// (thesis 2.1, 3.1, 4.2.4). Conventions are those of the Bouguet Camera
/// Calibration Toolbox and OpenCV ("plumb bob").

#include <array>
#include <optional>

namespace avatar {

/// Intrinsics of one camera. A point x_n = (x, y) on the normalised image plane
/// with r^2 = x^2 + y^2 is distorted to
///   x_d = (1 + kc1 r^2 + kc2 r^4 + kc5 r^6) x_n + dx,
///   dx  = (2 kc3 x y + kc4 (r^2 + 2 x^2),  kc3 (r^2 + 2 y^2) + 2 kc4 x y)
/// and mapped to pixels by
///   u = fc1 (x_d1 + alpha_c x_d2) + cc1,  v = fc2 x_d2 + cc2.
struct CameraIntrinsics {
    std::array<double, 2> fc{1000.0, 1000.0};  ///< focal length in pixels
    std::array<double, 2> cc{640.0, 480.0};    ///< principal point in pixels
    double alphaC{0.0};                        ///< skew coefficient
    std::array<double, 5> kc{0, 0, 0, 0, 0};   ///< k1, k2, p1, p2, k3
    bool operator==(const CameraIntrinsics& o) const {
        return fc == o.fc && cc == o.cc && alphaC == o.alphaC && kc == o.kc;
    }
};

/// A rigid transform named by its frames: target_T_source maps a point given
/// in the source frame into the target frame, p_target = R p_source + t.
struct RigidTransform {
    /// Row-major rotation matrix.
    std::array<double, 9> rotation{1, 0, 0, 0, 1, 0, 0, 0, 1};
    std::array<double, 3> translationMm{0, 0, 0};
    bool operator==(const RigidTransform& o) const {
        return rotation == o.rotation && translationMm == o.translationMm;
    }
};

struct StereoSystemConfig {
    CameraIntrinsics left;
    CameraIntrinsics right;
    /// right_T_left as Rodrigues vector om (radians) and translation T (mm):
    /// X_right = rodrigues(om) X_left + T.
    std::array<double, 3> om{0, 0, 0};
    std::array<double, 3> translationMm{-100.0, 0, 0};
    /// base_T_vision: the camera-manipulator registration (thesis 3.1.2),
    /// mapping left-camera (vision) coordinates to the manipulator base frame.
    std::optional<RigidTransform> baseTVision;

    bool operator==(const StereoSystemConfig& o) const {
        return left == o.left && right == o.right && om == o.om &&
               translationMm == o.translationMm && baseTVision == o.baseTVision;
    }
};

}  // namespace avatar
