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

#include <map>
#include <memory>
#include <optional>
#include <string>

namespace avatar {

/// Where a configuration was read from, so that a rule checked after reading
/// (an analysis stage list the pipeline cannot build) can still name the
/// element's line: configErrorAt() in ConfigXml.h. Not part of the value:
/// ignored by ==, never written.
struct ConfigOrigin {
    /// The file path, the name given with a document held in memory, or "<memory>".
    std::string source{"<memory>"};
    /// The line of each element path read (null for a configuration built in code).
    std::shared_ptr<const std::map<std::string, int>> lines;
};

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
    /// Set by readConfigString()/readConfigFile().
    ConfigOrigin origin;

    bool operator==(const AvatarConfig& o) const {
        return camera == o.camera && targets == o.targets && match == o.match &&
               stereo == o.stereo && lighting == o.lighting && analysis == o.analysis && servo == o.servo;
    }
    bool operator!=(const AvatarConfig& o) const { return !(*this == o); }
};

}  // namespace avatar
