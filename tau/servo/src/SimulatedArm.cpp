#include <avatar/servo/SimulatedArm.h>

#include <avatar/common/Error.h>

#include <opencv2/core.hpp>

#include <cmath>
#include <utility>

namespace avatar::servo {

SimulatedArm::SimulatedArm(SimulatedArmOptions options)
    : options_(std::move(options)), rng_(options_.seed), rotation_(rotationMatrix(options_.startBaseTTool)),
      from_(translationVector(options_.startBaseTTool)), to_(from_) {
    if (!(options_.repeatabilityMm >= 0.0) || !std::isfinite(options_.repeatabilityMm)) {
        throw InvalidArgument("SimulatedArm: repeatabilityMm must be a finite number >= 0");
    }
    if (!(options_.reachMm >= 0.0) || !std::isfinite(options_.reachMm)) {
        throw InvalidArgument("SimulatedArm: reachMm must be a finite number >= 0");
    }
    if (options_.moveDuration.count() < 0) {
        throw InvalidArgument("SimulatedArm: moveDuration must not be negative");
    }
    for (int i = 0; i < 3; ++i) {
        if (!std::isfinite(options_.staticBiasMm[i])) {
            throw InvalidArgument("SimulatedArm: staticBiasMm must be finite");
        }
    }
}

cv::Vec3d SimulatedArm::commandedNow() const {
    if (!moving_ || options_.moveDuration.count() == 0) {
        return moving_ ? from_ : to_;
    }
    const double f = std::chrono::duration<double>(std::chrono::steady_clock::now() - moveStart_).count() /
                     std::chrono::duration<double>(options_.moveDuration).count();
    const double t = std::min(1.0, std::max(0.0, f));
    return from_ + (to_ - from_) * t;
}

ArmTelemetry SimulatedArm::telemetry() {
    std::lock_guard<std::mutex> lock(mutex_);
    ArmTelemetry t;
    t.baseTTool = makeRigidTransform(rotation_, commandedNow());
    t.moving = moving_;
    return t;
}

void SimulatedArm::moveTo(const cv::Point3d& toolTipBaseMm) {
    std::lock_guard<std::mutex> lock(mutex_);
    const cv::Vec3d target(toolTipBaseMm.x, toolTipBaseMm.y, toolTipBaseMm.z);
    if (fault_) {
        throw InvalidState("the simulated arm is faulted: " + *fault_);
    }
    if (moving_) {
        throw InvalidState("the simulated arm is still moving");
    }
    if (!std::isfinite(target[0]) || !std::isfinite(target[1]) || !std::isfinite(target[2])) {
        throw InvalidArgument("SimulatedArm::moveTo: the target is not finite");
    }
    if (options_.reachMm > 0.0 && cv::norm(target) > options_.reachMm) {
        fault_ = "move target out of reach (" + std::to_string(cv::norm(target)) + " mm from the base, reach " +
                 std::to_string(options_.reachMm) + " mm)";
        throw InvalidState("the simulated arm refused the move: " + *fault_);
    }
    from_ = to_;
    to_ = target;
    moving_ = true;
    moveStart_ = std::chrono::steady_clock::now();
    ++moves_;
}

void SimulatedArm::finish(const cv::Vec3d& endMm) {
    std::normal_distribution<double> normal(0.0, options_.repeatabilityMm);
    to_ = endMm;
    from_ = endMm;
    noise_ = options_.repeatabilityMm > 0.0 ? cv::Vec3d(normal(rng_), normal(rng_), normal(rng_)) : cv::Vec3d();
    moving_ = false;
}

bool SimulatedArm::motionComplete() {
    std::function<void(const RigidTransform&)> listener;
    RigidTransform pose;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!moving_) {
            return true;
        }
        if (std::chrono::steady_clock::now() - moveStart_ < options_.moveDuration) {
            return false;
        }
        finish(to_);
        listener = listener_;
        pose = makeRigidTransform(rotation_, to_ + options_.staticBiasMm + noise_);
    }
    if (listener) {
        listener(pose);
    }
    return true;
}

std::optional<std::string> SimulatedArm::fault() {
    std::lock_guard<std::mutex> lock(mutex_);
    return fault_;
}

void SimulatedArm::halt() noexcept {
    std::function<void(const RigidTransform&)> listener;
    RigidTransform pose;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (!moving_) {
            return;
        }
        finish(commandedNow());
        listener = listener_;
        pose = makeRigidTransform(rotation_, to_ + options_.staticBiasMm + noise_);
    }
    if (listener) {
        try {
            listener(pose);
        } catch (...) {
            // halt() must not throw; the simulation re-renders on the next move
        }
    }
}

RigidTransform SimulatedArm::trueBaseTTool() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return makeRigidTransform(rotation_, commandedNow() + options_.staticBiasMm + noise_);
}

void SimulatedArm::setPoseListener(std::function<void(const RigidTransform&)> listener) {
    std::lock_guard<std::mutex> lock(mutex_);
    listener_ = std::move(listener);
}

void SimulatedArm::injectFault(std::string why) {
    std::lock_guard<std::mutex> lock(mutex_);
    fault_ = std::move(why);
    if (moving_) {
        finish(commandedNow());
    }
}

int SimulatedArm::moves() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return moves_;
}

}  // namespace avatar::servo
