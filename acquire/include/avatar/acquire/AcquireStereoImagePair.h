#pragma once
/// @file AcquireStereoImagePair.h
/// The base of every acquisition backend (thesis 4.2.2, Figure 4-4): it
/// numbers each acquired pair and is the one interface the layers above use
/// to get pairs, whatever their source (FireWire, GenICam, raw replay, files,
/// simulation).
///
/// Numbering: the first pair is group 1, member 0. The member number increments
/// every cycle; when the configuration changes, or when the member number would
/// reach the group size (default 99,999, the five digits of the raw file
/// names), the group number increments and the member number resets to 0.
///
/// Error policy: a pair that cannot be acquired is an AcquisitionError naming
/// the camera (or file) and what went wrong; the backend's status() then says
/// whether it is recovering or has failed. A backend never returns a pair whose
/// two images do not belong together.

#include <avatar/acquire/CameraReport.h>
#include <avatar/common/Error.h>
#include <avatar/common/StereoImagePair.h>
#include <avatar/common/VisionTargets.h>
#include <avatar/config/AvatarConfig.h>

#include <array>
#include <cstdint>
#include <optional>
#include <string>

namespace avatar {

/// A pair could not be acquired. what() names the camera or file.
class AcquisitionError : public Error {
public:
    using Error::Error;
};

/// Health of a backend, for the daemon's STATUS reply.
struct AcquisitionStatus {
    enum class State {
        Ok,          ///< delivering pairs
        Recovering,  ///< lost a camera or frame, trying to get it back
        Failed,      ///< gave up; needs attention (message says why)
        Finished     ///< a finite source (replay, file list) has no more pairs
    };
    State state{State::Ok};
    std::string message;  ///< empty when Ok, else what happened, naming the camera or file
};

/// What one acquisition cycle yields.
struct AcquiredPair {
    StereoImagePair pair;  ///< numbered: pair.id() carries group, member, camera ids, timestamps
    /// Replay only: the iteration the recording gave this pair.
    std::optional<std::uint64_t> recordedIteration;
    /// Replay only: the configuration XML the recording applied at this pair
    /// (set where the recorded configuration changed, and on the first pair).
    std::optional<std::string> recordedConfigXml;
    /// Replay only: where recordedConfigXml comes from, as errors name it:
    /// "<session>/session.log (configuration 2)".
    std::string recordedConfigSource;
    /// Replay only: the analysis result the recording stored for this pair.
    std::optional<VisionTargets> recordedResult;

    /// recordedConfigXml read and validated: std::nullopt when the pair carries
    /// no configuration; ConfigError naming recordedConfigSource when it does
    /// not validate (with this build's rules).
    std::optional<AvatarConfig> recordedConfig() const;
};

class AcquireStereoImagePair {
public:
    /// Throws avatar::InvalidArgument unless 1 <= groupSize <= 99999.
    explicit AcquireStereoImagePair(std::uint32_t groupSize = 99999);
    virtual ~AcquireStereoImagePair() = default;
    AcquireStereoImagePair(const AcquireStereoImagePair&) = delete;
    AcquireStereoImagePair& operator=(const AcquireStereoImagePair&) = delete;

    /// The backend's name as used on command lines: "firewire", "genicam", "replay", "files", "simulation".
    virtual std::string name() const = 0;

    /// Acquires the next pair and numbers it (a replayed pair keeps the numbers
    /// it was recorded with). Throws AcquisitionError when no pair can be had;
    /// status() then tells whether to retry.
    AcquiredPair acquire();

    /// Applies the camera part of a new configuration (exposure, gain, ROI...)
    /// and starts a new group. Throws (AcquisitionError, InvalidArgument) and
    /// keeps the previous settings and numbering when the backend cannot apply it.
    void applyConfig(const AvatarConfig& config);

    virtual AcquisitionStatus status() const { return {}; }

    /// The feature set as each camera reports it now, left then right
    /// (CameraReport.h): per feature whether the camera has it, whether it can
    /// and does adjust it itself, and its current value. A feature a camera
    /// lacks is reported here by name, not an error: applyConfig() skips what
    /// a camera lacks (on every backend) and this is how a caller finds out.
    /// Throws AcquisitionError when a camera does not answer or is not open.
    /// The default throws avatar::NotAvailable: the backend has no cameras
    /// whose features could be read (files). Implemented by firewire,
    /// genicam, replay (the recorded settings) and simulation (which has no
    /// adjustable feature: all reported missing).
    virtual std::array<CameraFeatureReadback, 2> readFeatures() const;

    std::uint32_t groupSize() const { return groupSize_; }
    /// The numbers the next acquired pair will get (live backends).
    std::uint32_t nextGroup() const { return group_; }
    std::uint32_t nextMember() const { return member_; }

protected:
    /// Fills AcquiredPair::pair with both images, their camera ids and
    /// timestamps; the base sets group and member. A replay backend that sets
    /// recordedIteration keeps the group and member it put in the pair.
    virtual AcquiredPair grab() = 0;
    /// Applies the camera settings of @p config. Default: nothing to apply.
    virtual void configure(const AvatarConfig& /*config*/) {}

private:
    std::uint32_t groupSize_;
    std::uint32_t group_{1};
    std::uint32_t member_{0};
};

}  // namespace avatar
