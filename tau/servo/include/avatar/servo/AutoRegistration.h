#pragma once
/// @file AutoRegistration.h
/// The automated camera-manipulator registration (thesis 5.3.1, 6.2.2): the
/// arm is moved through waypoints, the vision system locates the arm marker at
/// each, and base_T_vision is solved from the marker's vision-frame positions
/// and its base-frame positions from telemetry, with avatar-register's solver
/// (registerPoints(): outliers rejected, the uncertainty checked).

#include <avatar/common/Registration.h>
#include <avatar/config/ServoConfig.h>
#include <avatar/servo/ArmInterface.h>
#include <avatar/servo/VisualServo.h>

#include <opencv2/core/types.hpp>

#include <string>
#include <vector>

namespace avatar::servo {

/// What one registration run measured and solved.
struct MotionRegistration {
    std::vector<cv::Point3d> visionMm;  ///< the marker seen by vision, per waypoint used
    std::vector<cv::Point3d> baseMm;    ///< the marker from telemetry (tip minus the tool offset)
    std::vector<int> waypoints;         ///< index of the waypoint of each pair
    std::vector<std::string> skipped;   ///< "waypoint 3: ...", why a waypoint gave no pair
    PointRegistration registration;
};

/// Moves the tool tip to each of @p waypointsBaseMm (waiting for each move,
/// at most config.moveTimeoutMs), takes @p looks data sets there and uses the
/// mean vision-frame position of the one whole target of config.armType (a
/// waypoint where it is missing, flagged, or not unique is skipped and said
/// why). The marker's base position is the telemetry tip minus the tool
/// offset turned into the base frame. Throws avatar::InvalidArgument (from
/// registerPoints) when the pairs cannot determine the registration, and
/// avatar::InvalidState when the arm faults, refuses a move or does not finish it.
MotionRegistration registerByMotion(ArmInterface& arm, VisionSource& vision,
                                    const std::vector<cv::Point3d>& waypointsBaseMm, const ServoConfig& config,
                                    int looks = 1, const RegistrationOptions& options = {});

}  // namespace avatar::servo
