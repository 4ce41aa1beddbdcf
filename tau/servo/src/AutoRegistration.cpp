#include <avatar/servo/AutoRegistration.h>

#include <avatar/common/Error.h>
#include <avatar/common/Logging.h>

#include <log4cpp/Category.hh>
#include <opencv2/core.hpp>

#include <chrono>
#include <thread>

namespace avatar::servo {

namespace {

void waitForMotion(ArmInterface& arm, int timeoutMs, std::size_t index) {
    const auto start = std::chrono::steady_clock::now();
    while (!arm.motionComplete()) {
        if (const auto fault = arm.fault()) {
            throw InvalidState("registration: the arm faulted moving to waypoint " + std::to_string(index + 1) + ": " +
                               *fault);
        }
        if (std::chrono::steady_clock::now() - start > std::chrono::milliseconds(timeoutMs)) {
            arm.halt();
            throw InvalidState("registration: the arm did not reach waypoint " + std::to_string(index + 1) +
                               " within " + std::to_string(timeoutMs) + " ms");
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
}

}  // namespace

MotionRegistration registerByMotion(ArmInterface& arm, VisionSource& vision,
                                    const std::vector<cv::Point3d>& waypointsBaseMm, const ServoConfig& config,
                                    int looks, const RegistrationOptions& options) {
    if (looks < 1) {
        throw InvalidArgument("registerByMotion: looks must be >= 1, got " + std::to_string(looks));
    }
    log4cpp::Category& log = logging::category("servo");
    MotionRegistration out;
    for (std::size_t i = 0; i < waypointsBaseMm.size(); ++i) {
        const std::string where = "waypoint " + std::to_string(i + 1);
        try {
            arm.moveTo(waypointsBaseMm[i]);
        } catch (const Error& e) {
            throw InvalidState("registration: the arm refused " + where + ": " + e.what());
        }
        waitForMotion(arm, config.moveTimeoutMs, i);
        const ArmTelemetry telem = arm.telemetry();
        const cv::Vec3d offset = rotationMatrix(telem.baseTTool) * cv::Vec3d(config.toolOffsetMm.data());
        const cv::Vec3d markerBase = translationVector(telem.baseTTool) - offset;

        cv::Point3d sum(0, 0, 0);
        int seen = 0;
        std::string why;
        for (int k = 0; k < looks; ++k) {
            VisionTargets data;
            try {
                data = vision.acquire(std::chrono::milliseconds(config.visionTimeoutMs));
            } catch (const Error& e) {
                why = std::string("vision: ") + e.what();
                continue;
            }
            int whole = 0;
            int partial = 0;
            cv::Point3d position;
            for (const VisionTarget& t : data.targets) {
                if (t.type != config.armType || !t.positionVisionMm) continue;
                if ((t.flags & kTargetWhole) != 0) {
                    ++whole;
                    position = *t.positionVisionMm;
                } else {
                    ++partial;
                }
            }
            if (whole == 1) {
                sum += position;
                ++seen;
            } else if (whole > 1) {
                why = std::to_string(whole) + " whole '" + config.armType + "' targets";
            } else {
                why = partial > 0 ? "the '" + config.armType + "' target is not whole"
                                  : "no stereo '" + config.armType + "' target";
            }
        }
        if (seen == 0) {
            out.skipped.push_back(where + ": " + why);
            log.warn("registration: %s skipped: %s", where.c_str(), why.c_str());
            continue;
        }
        out.visionMm.push_back(sum * (1.0 / seen));
        out.baseMm.emplace_back(markerBase[0], markerBase[1], markerBase[2]);
        out.waypoints.push_back(static_cast<int>(i));
    }
    out.registration = registerPoints(out.visionMm, out.baseMm, options);
    log.info("registration from %zu of %zu waypoints: rms %.2f mm", out.visionMm.size(), waypointsBaseMm.size(),
             out.registration.rmsMm);
    return out;
}

}  // namespace avatar::servo
