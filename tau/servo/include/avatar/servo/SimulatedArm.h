#pragma once
/// @file SimulatedArm.h
/// A simulated manipulator for the servo's simulation mode: a kinematic tool
/// point that goes where it is told, but not exactly. Like a real arm it has a
/// static accuracy error (the tool ends up staticBiasMm from where its own
/// kinematics, and so its telemetry, say: about 2 cm for the thesis's arm), a
/// repeatability error (each move ends with fresh Gaussian noise) and moves
/// take time. Telemetry reports the commanded pose, as an arm's forward
/// kinematics would; trueBaseTTool() is where the tool really is, which the
/// simulation renders.

#include <avatar/servo/ArmInterface.h>

#include <opencv2/core/matx.hpp>

#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <random>
#include <string>

namespace avatar::servo {

struct SimulatedArmOptions {
    /// The telemetry pose at the start (tool tip and orientation, base frame).
    RigidTransform startBaseTTool;
    /// Where the tool really is minus where telemetry says it is (mm, base frame).
    cv::Vec3d staticBiasMm{0.0, 0.0, 0.0};
    /// Per-axis standard deviation of where each move really ends (mm).
    double repeatabilityMm{0.5};
    /// How long a move takes (the telemetry moves linearly meanwhile).
    std::chrono::milliseconds moveDuration{0};
    /// A move whose target is further than this from the base origin faults
    /// the arm ("out of reach"); 0: no limit.
    double reachMm{0.0};
    std::uint64_t seed{1};  ///< of the repeatability noise
};

class SimulatedArm final : public ArmInterface {
public:
    /// Throws avatar::InvalidArgument for a negative repeatability, reach or duration.
    explicit SimulatedArm(SimulatedArmOptions options);

    ArmTelemetry telemetry() override;
    void moveTo(const cv::Point3d& toolTipBaseMm) override;
    bool motionComplete() override;
    std::optional<std::string> fault() override;
    void halt() noexcept override;

    /// Where the tool really is (telemetry + static bias + the last move's noise).
    RigidTransform trueBaseTTool() const;
    /// Called (on the caller's thread of motionComplete() or halt()) with the
    /// true pose whenever a move ends: the simulation moves the rendered arm.
    void setPoseListener(std::function<void(const RigidTransform& trueBaseTTool)> listener);
    /// Makes the arm report @p why as a fault from now on (and stop).
    void injectFault(std::string why);
    /// Moves commanded so far.
    int moves() const;

private:
    cv::Vec3d commandedNow() const;  // with mutex_ held
    void finish(const cv::Vec3d& endMm);  // with mutex_ held

    mutable std::mutex mutex_;
    SimulatedArmOptions options_;
    std::mt19937_64 rng_;
    cv::Matx33d rotation_;
    cv::Vec3d from_, to_;        ///< commanded tip: start and end of the current move
    cv::Vec3d noise_{0, 0, 0};   ///< of the last move
    bool moving_{false};
    std::chrono::steady_clock::time_point moveStart_;
    std::optional<std::string> fault_;
    int moves_{0};
    std::function<void(const RigidTransform&)> listener_;
};

}  // namespace avatar::servo
