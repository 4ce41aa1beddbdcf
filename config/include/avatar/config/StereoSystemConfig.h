#pragma once
/// @file StereoSystemConfig.h
/// Calibration of the stereo pair and its registration to the manipulator
/// (thesis 2.1, 3.1, 4.2.4), as the XML configuration stores them.
/// Conventions are those of the Bouguet Camera Calibration Toolbox and OpenCV
/// ("plumb bob", see avatar/common/CameraModel.h); stereoGeometry() turns
/// this into the plain geometry the camera model and the triangulation use.

#include <avatar/common/CameraModel.h>
#include <avatar/common/RigidTransform.h>

#include <array>
#include <optional>

namespace avatar {

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

/// right_T_left of a stereo configuration (X_right = R(om) X_left + T).
RigidTransform rightTLeft(const StereoSystemConfig& config);

/// The configuration as camera geometry: both intrinsics, right_T_left and the registration.
StereoGeometry stereoGeometry(const StereoSystemConfig& config);

}  // namespace avatar
