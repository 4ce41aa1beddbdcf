#pragma once
/// @file VisualServo.h
/// The visual-servo controller (thesis 3.5, 4.4, Figures 3-19 and 4-7): it
/// drives the tool tip onto the sample by looking at both the sample and the
/// arm marker, so the errors of the calibration, the registration and the
/// arm's own kinematics cancel as the two come together. User guide and
/// measurements: docs/servo.md.
///
/// One iteration: read telemetry, take a vision data set, choose and check the
/// sample and the arm marker (Tracking.h), compute the tool tip from the
/// marker, the registration and the tool offset,
///   ^0 p_tool = ^0 p_arm + ^0_T R ^T p_tool      (^0 p_arm = base_T_vision ^V p_arm)
/// check it against telemetry, and move by the error
///   ^0 e = ^0 p_sample - ^0 p_tool,  scaled down to at most d_max (K_s);
/// within d_last the move onto the sample is the last one. Errant data
/// (the arm estimate far from telemetry or drifting, the sample jumped, a
/// target flagged partial or ambiguous) asks for new data instead of moving;
/// a target that stays lost ends the run after lostTimeoutMs.

#include <avatar/common/VisionTargets.h>
#include <avatar/config/ServoConfig.h>
#include <avatar/servo/ArmInterface.h>
#include <avatar/servo/ServoStateMachine.h>

#include <opencv2/core/types.hpp>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace avatar::tau {
class TauUnit;
}

namespace avatar::servo {

/// Where the controller gets its vision data from.
class VisionSource {
public:
    virtual ~VisionSource() = default;
    /// A data set of a stereo pair acquired after the call began. Throws an
    /// avatar::Error when none could be had within @p timeout.
    virtual VisionTargets acquire(std::chrono::milliseconds timeout) = 0;
};

/// Vision data through TAUNet: a TAKE_SNAPSHOT per data set. Borrows @p unit.
class TauUnitVision final : public VisionSource {
public:
    explicit TauUnitVision(tau::TauUnit& unit) : unit_(unit) {}
    VisionTargets acquire(std::chrono::milliseconds timeout) override;

private:
    tau::TauUnit& unit_;
};

/// What one run is asked to do.
struct ServoTask {
    /// Which sample to go for when several are seen (e.g. picked by an
    /// operator in the first image); without it there must be exactly one.
    std::optional<cv::Point3d> sampleHintBaseMm;
};

/// One record of a run: a data set looked at, and the move made from it.
struct ServoStep {
    int move{0};                    ///< moves commanded before this step
    double timeS{0.0};              ///< since the run began
    ServoState state{ServoState::Initialize};  ///< the state the data set was taken in
    std::uint64_t visionIteration{0};
    cv::Point3d telemetryToolMm;    ///< ^0 p_tool,telem
    std::optional<cv::Point3d> visionToolMm;    ///< ^0 p_tool from the arm marker
    std::optional<cv::Point3d> visionSampleMm;  ///< ^0 p_sample measured
    std::optional<cv::Point3d> toolEstimateMm;  ///< the tool position the move used
    std::optional<cv::Point3d> sampleEstimateMm;///< the sample position the move used
    std::optional<cv::Vec3d> commandedMoveMm;   ///< ^0 e_motion
    double distanceMm{-1.0};        ///< |^0 e_sample| as estimated; -1 when not computed
    bool finalMove{false};
    std::string note;               ///< why the data set was not used, or how it was used
};

/// How a run ended.
struct ServoResult {
    ServoState finalState{ServoState::Initialize};
    int moves{0};                   ///< moves commanded (the final one included)
    int visionRequests{0};          ///< data sets asked for
    std::string reason;             ///< for Fault, TimedOut and Aborted: why
    std::vector<ServoStep> steps;
    std::vector<std::pair<ServoState, ServoEvent>> transitions;
    bool converged() const { return finalState == ServoState::Done; }
};

/// Run-time settings that are not tuning (the tuning is ServoConfig).
struct ServoOptions {
    /// How often motion complete, faults and abort are polled while the arm moves.
    std::chrono::milliseconds pollPeriod{5};
};

class VisualServo {
public:
    /// Borrows @p arm and @p vision. Throws ConfigError (avatar/config/ConfigXml.h)
    /// when @p config is invalid.
    VisualServo(ArmInterface& arm, VisionSource& vision, ServoConfig config, ServoOptions options = {});

    /// Runs one sampling task to a final state (Done, Fault, TimedOut or
    /// Aborted) and returns its record. Never throws for what the arm or the
    /// vision system do: their failures end the run with a reason.
    ServoResult run(const ServoTask& task = {});

    /// Asks a run under way (in another thread) to stop: the arm is halted and
    /// the run ends Aborted. Thread-safe; also stops the next run at once.
    void abort() { abort_ = true; }

    const ServoConfig& config() const { return config_; }

private:
    ArmInterface& arm_;
    VisionSource& vision_;
    ServoConfig config_;
    ServoOptions options_;
    std::atomic<bool> abort_{false};
};

}  // namespace avatar::servo
