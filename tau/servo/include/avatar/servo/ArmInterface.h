#pragma once
/// @file ArmInterface.h
/// What the visual-servo controller needs from a manipulator (thesis 3.5,
/// 4.4): telemetry, a Cartesian move, motion complete and faults. The
/// manipulator controller implements it over its own arm; SimulatedArm
/// implements it for the simulation. Frames: ^0 is the manipulator base,
/// ^T the tool; lengths are millimetres.

#include <avatar/common/RigidTransform.h>

#include <opencv2/core/types.hpp>

#include <optional>
#include <string>

namespace avatar::servo {

/// What the arm reports about itself.
struct ArmTelemetry {
    /// 0_T_R: the tool pose in the base frame (its translation is the tool tip,
    /// ^0 p_tool,telem), as the arm's own kinematics compute it.
    RigidTransform baseTTool;
    bool moving{false};
};

/// The manipulator as the controller sees it. Calls come from one thread (the
/// controller's); none may block for long.
class ArmInterface {
public:
    virtual ~ArmInterface() = default;
    /// The current telemetry.
    virtual ArmTelemetry telemetry() = 0;
    /// Starts a Cartesian move of the tool tip to @p toolTipBaseMm (orientation
    /// kept) and returns at once. Throws avatar::InvalidState when the arm cannot
    /// accept a move (faulted, or still moving).
    virtual void moveTo(const cv::Point3d& toolTipBaseMm) = 0;
    /// True once the last commanded move has ended (true before the first).
    virtual bool motionComplete() = 0;
    /// Why the arm stopped working; std::nullopt while it is healthy.
    virtual std::optional<std::string> fault() = 0;
    /// Stops any motion where it is (abort). Never throws.
    virtual void halt() noexcept = 0;
};

}  // namespace avatar::servo
