#pragma once
/// @file Tracking.h
/// Target identification and tracking for the visual servo (thesis 3.5.2):
/// which of the reported targets of a type is the one followed, whether it
/// can be trusted this iteration, and the Kalman filter that smooths the
/// estimates over iterations (the thesis's future work). Positions are in the
/// manipulator base frame, mm.

#include <avatar/common/VisionTargets.h>

#include <opencv2/core/matx.hpp>
#include <opencv2/core/types.hpp>

#include <optional>
#include <string>

namespace avatar::servo {

/// What one data set said about the target followed.
enum class Sighting {
    Found,      ///< one whole target, where it was expected
    Missing,    ///< no stereo target of the type (near the expected position)
    Flagged,    ///< the target is there but not whole (cut, occluded, merged, ambiguous)
    Jumped,     ///< the nearest target moved further than the motion check allows
    Ambiguous   ///< several whole candidates and nothing to tell them apart
};

/// "found", "missing", "flagged", "jumped", "ambiguous".
const char* toString(Sighting sighting);

struct TargetSighting {
    Sighting status{Sighting::Missing};
    /// The target chosen (set for Found, Flagged and Jumped).
    std::optional<VisionTarget> target;
    double distanceMm{0.0};  ///< from the expected position (0 without one)
    std::string why;         ///< for every status but Found, a sentence for the log
};

/// How selectTarget() chooses.
struct SelectionRule {
    /// Where the target is expected (its last position, or a prediction);
    /// without it the type must have exactly one whole target.
    std::optional<cv::Point3d> expectedBaseMm;
    /// Candidates further than this from the expected position are other objects.
    double trackingRadiusMm{60.0};
    /// The chosen target may be at most this far from the expected position.
    double maxJumpMm{20.0};
};

/// Chooses the target of @p type in @p data (thesis 3.5.2): the stereo target
/// with a base-frame position nearest the expected one within the tracking
/// radius, then checks it is whole and has not jumped.
TargetSighting selectTarget(const VisionTargets& data, const std::string& type, const SelectionRule& rule);

/// A position and its covariance (mm, mm^2).
struct Estimate {
    cv::Point3d positionMm;
    cv::Matx33d covarianceMm2{cv::Matx33d::eye()};
};

/// A Kalman filter for one 3-D position that follows a random walk: each
/// predict() adds isotropic process noise, each update() weighs a measurement
/// by its covariance. Used for the sample (it may drift) and for the arm's
/// vision-minus-telemetry offset (it changes slowly as the arm moves).
class PositionFilter {
public:
    bool initialised() const { return initialised_; }
    void reset() { initialised_ = false; }
    /// Adds @p sigmaMm^2 to every axis of the covariance (no-op before the first update).
    void predict(double sigmaMm);
    /// Fuses a measurement; the first one initialises the filter. Throws
    /// avatar::InvalidArgument for a covariance that is not positive definite.
    const Estimate& update(const cv::Point3d& measuredMm, const cv::Matx33d& covarianceMm2);
    /// The current estimate; only meaningful once initialised().
    const Estimate& estimate() const { return estimate_; }

private:
    bool initialised_{false};
    Estimate estimate_;
};

}  // namespace avatar::servo
