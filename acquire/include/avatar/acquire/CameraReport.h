#pragma once
/// @file CameraReport.h
/// What a backend reports about its cameras, for the camera utilities
/// (avatar-camtest, avatar-featureset; thesis 4.2.4, 4.5.1):
///
/// - the survey of what a backend can reach before anything is opened for
///   acquisition: the cameras it finds (id, model, where) and the checks of
///   what it needs from the machine (driver, device permissions, library),
///   each passed or failed with the reason (surveyBackend() in
///   AcquisitionBackends.h);
/// - each camera's feature set as the camera reports it now
///   (AcquireStereoImagePair::readFeatures()): per feature whether the camera
///   has it at all, whether it can adjust it itself, whether it does so now,
///   and its current value. A camera that lacks a feature is a normal outcome
///   here, reported by name, never an error.

#include <avatar/common/ImageFormat.h>

#include <string>
#include <vector>

namespace avatar {

/// The feature names of the configuration, as the elements of
/// <camera><features> (docs/config.md), in document order: "exposure",
/// "shutter", "gain", "whiteBalance", "brightness", "gamma".
const std::vector<std::string>& cameraFeatureNames();

/// One feature of one camera as the camera reports it now.
struct FeatureReading {
    std::string name;           ///< one of cameraFeatureNames(), e.g. "gain"
    bool present{false};        ///< the camera has the feature: its value can be read and set
    bool autoAvailable{false};  ///< the camera can adjust it itself (an automatic mode)
    bool automatic{false};      ///< the camera adjusts it itself now
    double value{0.0};          ///< in the camera's units; whiteBalance: the blue/U component
    double redV{0.0};           ///< whiteBalance only: the red/V component
    /// What the camera lacks for this feature, in its own terms ("no
    /// ExposureAuto", "no BalanceRatio"); empty when it has the feature and
    /// its automatic mode.
    std::string note;
};

/// What one camera reports for the whole feature set.
struct CameraFeatureReadback {
    Side side{Side::Left};
    std::string cameraId;                  ///< the id the pairs carry (as configured)
    std::vector<FeatureReading> features;  ///< one per cameraFeatureNames(), in that order

    /// The reading of @p name. Throws avatar::InvalidArgument naming @p name
    /// when it is not one of cameraFeatureNames() or not in features.
    const FeatureReading& feature(const std::string& name) const;
};

/// One camera a backend can reach.
struct CameraListing {
    std::string id;        ///< what <leftCameraId>/<rightCameraId> takes ("Aravis-Fake-GV01", "0x00b09d01004a2c1f")
    std::string model;     ///< vendor and model as the camera reports them; "simulated", "recorded" ...
    std::string address;   ///< where it is: IP address, session directory; may be empty
    bool reachable{true};  ///< it could be opened just now
    std::string detail;    ///< protocol, or why it could not be opened
};

/// One thing a backend needs from the machine, and whether it has it.
struct BackendCheck {
    std::string what;    ///< "libdc1394", "/dev/fw1", "Aravis discovery", "session log" ...
    bool ok{true};
    std::string detail;  ///< what was found; when not ok, what is wrong and what to do
};

/// What a backend can reach now (surveyBackend()).
struct BackendSurvey {
    std::string backend;                ///< the backend's name
    std::vector<BackendCheck> checks;   ///< in the order they were made
    std::vector<CameraListing> cameras; ///< in the order the backend finds them
    /// True when every check passed.
    bool ok() const;
};

}  // namespace avatar
