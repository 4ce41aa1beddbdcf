#pragma once
/// @file AvatarConfig.h
/// The whole configuration of AVATAR: one XML document (see docs/config.md).

#include <avatar/config/AnalysisConfig.h>
#include <avatar/config/CameraHardwareConfig.h>
#include <avatar/config/LightingConfig.h>
#include <avatar/config/MatchConfig.h>
#include <avatar/config/ServoConfig.h>
#include <avatar/config/StereoSystemConfig.h>
#include <avatar/config/TargetConfig.h>

#include <optional>

namespace avatar {

/// Every structure of the design in one value. Passed to the components that
/// need it; there is no global configuration.
struct AvatarConfig {
    CameraHardwareConfig camera;
    TargetConfig targets;
    MatchConfig match;
    StereoSystemConfig stereo;
    LightingConfig lighting;
    AnalysisConfig analysis;
    /// The visual-servo tuning (<servo>), for the manipulator side; absent in
    /// documents that only configure vision.
    std::optional<ServoConfig> servo;

    bool operator==(const AvatarConfig& o) const {
        return camera == o.camera && targets == o.targets && match == o.match &&
               stereo == o.stereo && lighting == o.lighting && analysis == o.analysis && servo == o.servo;
    }
    bool operator!=(const AvatarConfig& o) const { return !(*this == o); }
};

}  // namespace avatar
