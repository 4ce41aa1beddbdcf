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

/// Standard errors of one camera's intrinsics, in the units of the parameters.
struct IntrinsicsUncertainty {
    std::array<double, 2> fc{0, 0};
    std::array<double, 2> cc{0, 0};
    double alphaC{0.0};
    std::array<double, 5> kc{0, 0, 0, 0, 0};
    bool operator==(const IntrinsicsUncertainty& o) const {
        return fc == o.fc && cc == o.cc && alphaC == o.alphaC && kc == o.kc;
    }
};

/// Standard errors of a stereo calibration (the +/- of thesis Tables 6-1 and
/// 6-4), as avatar-calibrate estimates them, for later stages to propagate.
struct CalibrationUncertainty {
    IntrinsicsUncertainty left;
    IntrinsicsUncertainty right;
    std::array<double, 3> om{0, 0, 0};             ///< rad
    std::array<double, 3> translationMm{0, 0, 0};  ///< mm
    bool operator==(const CalibrationUncertainty& o) const {
        return left == o.left && right == o.right && om == o.om && translationMm == o.translationMm;
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
    /// The calibration's standard errors, when it was estimated with them.
    std::optional<CalibrationUncertainty> uncertainty;

    bool operator==(const StereoSystemConfig& o) const {
        return left == o.left && right == o.right && om == o.om && translationMm == o.translationMm &&
               baseTVision == o.baseTVision && uncertainty == o.uncertainty;
    }
};

/// right_T_left of a stereo configuration (X_right = R(om) X_left + T).
RigidTransform rightTLeft(const StereoSystemConfig& config);

/// The configuration as camera geometry: both intrinsics, right_T_left and the registration.
StereoGeometry stereoGeometry(const StereoSystemConfig& config);

}  // namespace avatar
