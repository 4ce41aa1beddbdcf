#include <avatar/servo/VisualServo.h>

#include <avatar/common/Error.h>
#include <avatar/common/Registration.h>
#include <avatar/common/Logging.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/servo/Tracking.h>
#include <avatar/tau/TauUnit.h>

#include <log4cpp/Category.hh>
#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <thread>

namespace avatar::servo {

VisionTargets TauUnitVision::acquire(std::chrono::milliseconds timeout) {
    return unit_.takeSnapshot(timeout);
}

namespace {

using Clock = std::chrono::steady_clock;

constexpr double kPi = 3.14159265358979323846;


std::string mm(double value) {
    char text[32];
    std::snprintf(text, sizeof text, "%.1f mm", value);
    return text;
}

cv::Vec3d vec(const cv::Point3d& p) {
    return {p.x, p.y, p.z};
}
cv::Point3d point(const cv::Vec3d& v) {
    return {v[0], v[1], v[2]};
}

/// The covariance a target reports in the base frame, or the default.
cv::Matx33d measurementCovariance(const VisionTarget& t, double defaultSigmaMm) {
    if (t.covarianceBaseMm2) {
        return *t.covarianceBaseMm2;
    }
    return cv::Matx33d::eye() * (defaultSigmaMm * defaultSigmaMm);
}

/// One run's working state.
class Run {
public:
    Run(ArmInterface& arm, VisionSource& vision, const ServoConfig& config, const ServoOptions& options,
        const std::atomic<bool>& abort, const ServoTask& task)
        : arm_(arm), vision_(vision), c_(config), options_(options), abort_(abort), task_(task),
          log_(logging::category("servo")) {}

    ServoResult execute() {
        start_ = Clock::now();
        lastValid_ = start_;
        while (!isFinal(sm_.state())) {
            if (abort_) {
                arm_.halt();
                end(ServoEvent::Abort, "aborted by the operator");
                break;
            }
            if (const std::optional<std::string> fault = arm_.fault()) {
                arm_.halt();
                end(ServoEvent::ArmFault, "arm fault: " + *fault);
                break;
            }
            switch (sm_.state()) {
                case ServoState::RequestVision:
                    ++result_.visionRequests;
                    sm_.fire(ServoEvent::VisionRequested);
                    break;
                case ServoState::Initialize:
                    ++result_.visionRequests;
                    look();
                    break;
                case ServoState::WaitVision: look(); break;
                case ServoState::ComputeMove: computeMove(); break;
                case ServoState::ArmMoving:
                case ServoState::ArmSampling: waitForMotion(); break;
                default: break;
            }
        }
        result_.finalState = sm_.state();
        result_.transitions = sm_.history();
        log_.info("servo run ended %s after %d moves and %d vision requests%s%s",
                  std::string(toString(result_.finalState)).c_str(), result_.moves, result_.visionRequests,
                  result_.reason.empty() ? "" : ": ", result_.reason.c_str());
        return result_;
    }

private:
    double secondsSinceStart() const {
        return std::chrono::duration<double>(Clock::now() - start_).count();
    }

    void end(ServoEvent event, const std::string& reason) {
        result_.reason = reason;
        sm_.fire(event);
    }

    /// No valid data for too long ends the run; otherwise ask again.
    void notUsable(ServoEvent event, ServoStep& step, const std::string& why) {
        step.note = why;
        result_.steps.push_back(step);
        log_.info("vision data not used: %s", why.c_str());
        const auto lost = std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - lastValid_);
        if (lost.count() > c_.lostTimeoutMs) {
            end(ServoEvent::Timeout, "no usable vision data for " + std::to_string(lost.count()) +
                                         " ms (lostTimeoutMs " + std::to_string(c_.lostTimeoutMs) + "): " + why);
            return;
        }
        sm_.fire(event);
    }

    /// The marker's position as telemetry predicts it, with the offset seen last.
    cv::Point3d expectedMarker(const ArmTelemetry& telem) const {
        const cv::Vec3d tip = translationVector(telem.baseTTool);
        const cv::Vec3d offset = rotationMatrix(telem.baseTTool) * cv::Vec3d(c_.toolOffsetMm.data());
        cv::Vec3d marker = tip - offset;
        if (armOffset_) {
            marker += vec(*armOffset_);
        }
        return point(marker);
    }

    /// Initialize and WaitVision: take a data set and judge it.
    void look() {
        ServoStep step;
        step.move = result_.moves;
        step.state = sm_.state();
        const ArmTelemetry telem = arm_.telemetry();
        step.telemetryToolMm = point(translationVector(telem.baseTTool));
        VisionTargets data;
        try {
            data = vision_.acquire(std::chrono::milliseconds(c_.visionTimeoutMs));
        } catch (const Error& e) {
            step.timeS = secondsSinceStart();
            notUsable(ServoEvent::TargetsMissing, step, std::string("vision: ") + e.what());
            return;
        }
        step.timeS = secondsSinceStart();
        step.visionIteration = data.iteration;

        SelectionRule sampleRule;
        sampleRule.trackingRadiusMm = c_.trackingRadiusMm;
        sampleRule.maxJumpMm = c_.maxTargetJumpMm;
        if (sampleTrack_) {
            sampleRule.expectedBaseMm = *sampleTrack_;
        } else if (task_.sampleHintBaseMm) {
            sampleRule.expectedBaseMm = task_.sampleHintBaseMm;
            sampleRule.maxJumpMm = c_.trackingRadiusMm;  // a hint is no position to jump from
        }
        TargetSighting sample = selectTarget(data, c_.sampleType, sampleRule);
        bool sampleAssumed = false;
        if (sample.status == Sighting::Found) {
            step.visionSampleMm = *sample.target->positionBaseMm;
        } else if (c_.mode == ServoMode::Hybrid && sampleTrack_ &&
                   (sample.status == Sighting::Missing || sample.status == Sighting::Flagged)) {
            sampleAssumed = true;  // hidden behind the arm: dead reckoning on its last position
        } else {
            notUsable(sample.status == Sighting::Missing ? ServoEvent::TargetsMissing : ServoEvent::DataErrant, step,
                      sample.why);
            return;
        }

        std::optional<VisionTarget> marker;
        std::string armWhy;
        if (c_.mode != ServoMode::DeadReckoning) {
            SelectionRule armRule;
            armRule.expectedBaseMm = expectedMarker(telem);
            if (armOffset_) {
                const double moved = cv::norm(step.telemetryToolMm - offsetTelemetry_);
                armRule.trackingRadiusMm = c_.trackingRadiusMm + c_.armDriftPerMm * moved;
                armRule.maxJumpMm = c_.armDriftMm + c_.armDriftPerMm * moved;
            } else {
                armRule.trackingRadiusMm = c_.armToleranceMm;
                armRule.maxJumpMm = c_.armToleranceMm;
            }
            const TargetSighting arm = selectTarget(data, c_.armType, armRule);
            if (arm.status == Sighting::Found) {
                marker = arm.target;
                const cv::Vec3d offset = rotationMatrix(telem.baseTTool) * cv::Vec3d(c_.toolOffsetMm.data());
                step.visionToolMm = point(vec(*marker->positionBaseMm) + offset);
            } else if (c_.mode == ServoMode::Hybrid && armOffset_ &&
                       (arm.status == Sighting::Missing || arm.status == Sighting::Flagged)) {
                armWhy = arm.why;  // hidden (by the sample, say): telemetry and the offset seen last
            } else {
                notUsable(arm.status == Sighting::Missing ? ServoEvent::TargetsMissing : ServoEvent::DataErrant, step,
                          arm.why);
                return;
            }
        }
        pending_ = Pending{telem, step, sample.target, marker, sampleAssumed};
        std::string note;
        if (sampleAssumed) {
            note = "sample not seen (" + sample.why + "): moving on its last position";
        }
        if (!armWhy.empty()) {
            note += (note.empty() ? "" : "; ") + std::string("arm marker not seen (") + armWhy +
                    "): telemetry and the last vision offset";
        }
        pending_->step.note = note;
        lastValid_ = Clock::now();
        sm_.fire(ServoEvent::DataValid);
    }

    void computeMove() {
        Pending p = std::move(*pending_);
        pending_.reset();
        ServoStep& step = p.step;
        const cv::Point3d telemTip = step.telemetryToolMm;

        const cv::Vec3d toolOffset = rotationMatrix(p.telemetry.baseTTool) * cv::Vec3d(c_.toolOffsetMm.data());
        const cv::Point3d telemMarker = telemTip - point(toolOffset);

        // The arm: the marker seen by vision minus where telemetry puts it
        // (the registration's and the arm's errors together), checked, filtered;
        // in hybrid mode the last one while the marker is hidden.
        std::optional<cv::Point3d> markerSeen;
        if (step.visionToolMm) {
            const cv::Point3d offset = *step.visionToolMm - telemTip;
            if (cv::norm(offset) > c_.armToleranceMm) {
                notUsable(ServoEvent::DataErrant, step,
                          "the arm seen by vision is " + mm(cv::norm(offset)) + " from telemetry (armToleranceMm " +
                              mm(c_.armToleranceMm) + ")");
                return;
            }
            markerSeen = *p.marker->positionBaseMm;
            cv::Point3d used = offset;
            if (c_.filter == ServoFilter::Kalman) {
                const double moved = armOffset_ ? cv::norm(telemTip - offsetTelemetry_) : 0.0;
                armFilter_.predict(c_.kalmanArmNoisePerMm * moved);
                used = armFilter_.update(offset, measurementCovariance(*p.marker, c_.kalmanDefaultSigmaMm)).positionMm;
            }
            armOffset_ = used;
            offsetTelemetry_ = telemTip;
            seenTelemetryMarker_ = telemMarker;
            refine(*markerSeen, telemMarker);
        }
        // The sample: measured, filtered, or (hybrid, hidden) its last position.
        cv::Point3d sampleRaw;
        if (p.sampleAssumed) {
            sampleRaw = *sampleTrack_;
        } else {
            sampleRaw = *p.sample->positionBaseMm;
            if (c_.filter == ServoFilter::Kalman) {
                sampleFilter_.predict(c_.kalmanSampleNoiseMm);
                sampleRaw =
                    sampleFilter_.update(sampleRaw, measurementCovariance(*p.sample, c_.kalmanDefaultSigmaMm)).positionMm;
            }
            sampleTrack_ = sampleRaw;
        }
        // Both in the working frame: the registration's, or refined onto telemetry's.
        cv::Point3d tool = telemTip;
        if (c_.mode != ServoMode::DeadReckoning && armOffset_) {
            // The marker where it was last seen, in the working frame, moved on by
            // telemetry since: a hidden marker is carried by the arm's own
            // (accurate) relative motion, not by the registration's frame.
            const cv::Point3d seen = working(seenTelemetryMarker_ + *armOffset_);
            tool = seen + (telemMarker - seenTelemetryMarker_) + point(toolOffset);
        }
        const cv::Point3d sample = c_.mode == ServoMode::DeadReckoning ? sampleRaw : working(sampleRaw);
        step.toolEstimateMm = tool;
        step.sampleEstimateMm = sample;

        cv::Vec3d error = vec(sample - tool);
        const double distance = cv::norm(error);
        step.distanceMm = distance;
        const bool final = c_.mode == ServoMode::DeadReckoning || distance <= c_.finalDistanceMm;
        if (!final) {
            // K_s = |e| / d_max, and the approach stops half of d_last short of
            // the sample: the last look is then taken with both targets apart
            // (at the sample the marker may touch or hide it) and the blind
            // final move is short.
            const double length = std::min(c_.maxMoveMm, distance - 0.5 * c_.finalDistanceMm);
            error *= length / distance;
            probe(error, distance);
        }
        if (result_.moves >= c_.maxIterations) {
            step.note = "iteration limit reached";
            result_.steps.push_back(step);
            end(ServoEvent::Timeout, std::to_string(result_.moves) + " moves without reaching the sample (maxIterations " +
                                         std::to_string(c_.maxIterations) + ")");
            return;
        }
        step.commandedMoveMm = error;
        step.finalMove = final;
        try {
            arm_.moveTo(telemTip + point(error));
        } catch (const Error& e) {
            step.note = std::string("move refused: ") + e.what();
            result_.steps.push_back(step);
            arm_.halt();
            end(ServoEvent::ArmFault, step.note);
            return;
        }
        ++result_.moves;
        motionStart_ = Clock::now();
        log_.info("move %d: %.1f mm towards the sample (%.1f mm away)%s", result_.moves, cv::norm(error), distance,
                  final ? ", the last" : "");
        result_.steps.push_back(step);
        sm_.fire(final ? ServoEvent::FinalMoveCommanded : ServoEvent::MoveCommanded);
    }

    /// A point of the registration's base frame in the working frame.
    cv::Point3d working(const cv::Point3d& p) const {
        return correction_ ? transformPoint(*correction_, p) : p;
    }

    /// Registration refinement: the marker's positions through the registration
    /// and through telemetry, fitted by a rigid transform that maps the
    /// registration's frame onto the arm's own (its bias included), so the tool
    /// offset, known in the arm's frame, is added in the frame the vision
    /// positions are in. Each axis of the fitted rotation is shrunk towards the
    /// registration's by the weight of the two uncertainties: a run whose looks
    /// lie on one line leaves the rotation about that line as it was.
    void refine(const cv::Point3d& markerVisionBase, const cv::Point3d& markerTelemetry) {
        if (!c_.refineRegistration) {
            return;
        }
        refineVision_.push_back(markerVisionBase);
        refineTelemetry_.push_back(markerTelemetry);
        if (refineVision_.size() < 3) {
            return;
        }
        RigidTransform fit;
        RegistrationUncertainty u;
        try {
            fit = registerClosedForm(refineVision_, refineTelemetry_);
            u = registrationUncertainty(fit, refineVision_, refineTelemetry_);
        } catch (const InvalidArgument&) {
            return;  // all on one line so far: the registration as it is
        }
        const double prior = c_.registrationStdDeg * kPi / 180.0;
        std::array<double, 3> om = rodriguesVector(rotationMatrix(fit));
        for (std::size_t i = 0; i < 3; ++i) {
            const double s = u.rotationStdRad[i];
            om[i] *= std::isfinite(s) ? prior * prior / (prior * prior + s * s) : 0.0;
        }
        const cv::Matx33d rotation = rodrigues(om);
        cv::Vec3d meanVision(0, 0, 0), meanTelemetry(0, 0, 0);
        for (std::size_t i = 0; i < refineVision_.size(); ++i) {
            meanVision += vec(refineVision_[i]);
            meanTelemetry += vec(refineTelemetry_[i]);
        }
        const double n = static_cast<double>(refineVision_.size());
        correction_ = makeRigidTransform(rotation, meanTelemetry / n - rotation * (meanVision / n));
        log_.debug("registration refined from %zu looks: fitted %.2f deg, std %.2f %.2f %.2f deg, used %.2f deg",
                   refineVision_.size(), rotationAngleBetween(cv::Matx33d::eye(), rotationMatrix(fit)) * 180.0 / kPi,
                   u.rotationStdRad[0] * 180.0 / kPi, u.rotationStdRad[1] * 180.0 / kPi,
                   u.rotationStdRad[2] * 180.0 / kPi, rotationAngleBetween(cv::Matx33d::eye(), rotation) * 180.0 / kPi);
    }

    /// With refinement, the first two long moves leave the line to the sample
    /// by probeAngleDeg, one about each perpendicular axis.
    void probe(cv::Vec3d& move, double distance) const {
        if (!c_.refineRegistration || c_.probeAngleDeg <= 0.0 || result_.moves >= 2 ||
            distance < c_.maxMoveMm + c_.finalDistanceMm || c_.mode == ServoMode::DeadReckoning) {
            return;
        }
        const double length = cv::norm(move);
        const cv::Vec3d along = move / length;
        const cv::Vec3d axis = std::abs(along[0]) < 0.6 ? cv::Vec3d(1, 0, 0) : cv::Vec3d(0, 1, 0);
        cv::Vec3d across = along.cross(axis);
        across /= cv::norm(across);
        if (result_.moves == 1) {
            across = along.cross(across);
        }
        const double angle = c_.probeAngleDeg * kPi / 180.0;
        move = (along * std::cos(angle) + across * std::sin(angle)) * length;
    }

    void waitForMotion() {
        if (arm_.motionComplete()) {
            sm_.fire(ServoEvent::MotionComplete);
            return;
        }
        const auto elapsed = std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - motionStart_);
        if (elapsed.count() > c_.moveTimeoutMs) {
            arm_.halt();
            end(ServoEvent::Timeout, "the arm did not complete move " + std::to_string(result_.moves) + " within " +
                                         std::to_string(c_.moveTimeoutMs) + " ms (moveTimeoutMs)");
            return;
        }
        std::this_thread::sleep_for(options_.pollPeriod);
    }

    struct Pending {
        ArmTelemetry telemetry;
        ServoStep step;
        std::optional<VisionTarget> sample;
        std::optional<VisionTarget> marker;
        bool sampleAssumed{false};
    };

    ArmInterface& arm_;
    VisionSource& vision_;
    const ServoConfig& c_;
    const ServoOptions& options_;
    const std::atomic<bool>& abort_;
    const ServoTask& task_;
    log4cpp::Category& log_;

    ServoStateMachine sm_;
    ServoResult result_;
    Clock::time_point start_;
    Clock::time_point lastValid_;
    Clock::time_point motionStart_;
    std::optional<Pending> pending_;
    std::optional<cv::Point3d> sampleTrack_;   ///< the sample's last position (filtered when Kalman)
    std::optional<cv::Point3d> armOffset_;     ///< marker (or tool) by vision minus by telemetry, last seen
    cv::Point3d offsetTelemetry_;              ///< the telemetry tip it was seen at
    cv::Point3d seenTelemetryMarker_;          ///< the marker by telemetry when last seen
    std::vector<cv::Point3d> refineVision_;    ///< the marker through the registration, per look
    std::vector<cv::Point3d> refineTelemetry_; ///< the marker from telemetry, per look
    std::optional<RigidTransform> correction_; ///< registration frame -> arm frame, once determined
    PositionFilter sampleFilter_;
    PositionFilter armFilter_;
};

}  // namespace

VisualServo::VisualServo(ArmInterface& arm, VisionSource& vision, ServoConfig config, ServoOptions options)
    : arm_(arm), vision_(vision), config_(std::move(config)), options_(options) {
    validateServoConfig(config_);
}

ServoResult VisualServo::run(const ServoTask& task) {
    Run run(arm_, vision_, config_, options_, abort_, task);
    return run.execute();
}

}  // namespace avatar::servo
