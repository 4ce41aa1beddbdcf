#pragma once
/// @file ServoConfig.h
/// Tuning of the visual-servo controller (thesis 3.5, 4.4; docs/servo.md):
/// the optional <servo> section of the AVATAR configuration. The controller
/// (avatar::servo::VisualServo) runs in the manipulator controller's process
/// and reads it from the same document the vision system uses, so the target
/// type names it follows are checked against the document's <targets>.

#include <array>
#include <string>

namespace avatar {

/// How the controller uses vision (docs/servo.md).
enum class ServoMode {
    Servo,          ///< iterate: look, move at most maxMoveMm, look again (Figure 3-19)
    DeadReckoning,  ///< one snapshot, one move straight to the sample (no feedback)
    Hybrid          ///< servo; while the sample is hidden (the arm in front of it), move on its last position
};

/// How target and arm estimates are combined over iterations.
enum class ServoFilter {
    None,   ///< each iteration uses its own measurements
    Kalman  ///< a Kalman filter per estimate, weighted by the reported covariances (docs/servo.md)
};

struct ServoConfig {
    std::string sampleType{"sample"};     ///< the target type the tool is driven onto
    std::string armType{"arm_marker"};    ///< the target type on the end effector
    ServoMode mode{ServoMode::Servo};
    ServoFilter filter{ServoFilter::None};
    /// d_max: the longest move commanded in one iteration (K_s scales longer ones down).
    double maxMoveMm{50.0};
    /// d_last: when the tool is this close to the sample, the move onto it is the last one.
    double finalDistanceMm{15.0};
    /// ^T p_tool: from the arm marker's centre to the tool tip, in the tool frame.
    std::array<double, 3> toolOffsetMm{0.0, 0.0, 0.0};
    /// The tool position seen by vision may differ from telemetry by at most this
    /// (the registration error and the arm's static error together); beyond it the
    /// arm estimate is errant and vision data is requested again.
    double armToleranceMm{150.0};
    /// Between two iterations the vision-minus-telemetry offset of the tool may
    /// change by at most armDriftMm + armDriftPerMm * (distance the arm moved).
    double armDriftMm{10.0};
    double armDriftPerMm{0.2};
    /// The sample may move between two iterations by at most this much; a larger
    /// jump (a wrong target, a bad match) is errant data.
    double maxTargetJumpMm{20.0};
    /// Within this distance of the previous sample position a candidate is the
    /// same target (tracking, thesis 3.5.2); the nearest one is taken.
    double trackingRadiusMm{60.0};
    int visionTimeoutMs{10000};   ///< one snapshot
    int moveTimeoutMs{30000};     ///< one arm motion
    int lostTimeoutMs{20000};     ///< a target not seen (or only errant data) for this long ends the run
    int maxIterations{50};        ///< moves commanded before the run is given up
    /// Refine the registration's rotation during the run from the arm marker's
    /// vision positions and telemetry (docs/servo.md): without it a rotation
    /// error a leaves up to 2 sin(a/2) |toolOffsetMm| at the sample, which
    /// no amount of servoing removes.
    bool refineRegistration{true};
    /// With refineRegistration, the first two moves leave the straight line to
    /// the sample by this angle (one each way), so the marker's positions span
    /// three dimensions and determine the rotation; 0: never leave it.
    double probeAngleDeg{30.0};
    /// How far off the registration's rotation may be (one standard deviation,
    /// per axis; avatar-register reports it): the refinement moves the rotation
    /// away from the registration's in proportion, rotationStd^2 / (rotationStd^2
    /// + the run's own standard error^2), so a poorly determined estimate
    /// changes little.
    double registrationStdDeg{3.0};
    /// Kalman filter: random-walk process noise of the sample position per
    /// iteration, and of the arm's vision-minus-telemetry offset per mm moved.
    double kalmanSampleNoiseMm{1.0};
    double kalmanArmNoisePerMm{0.05};
    /// Measurement sigma assumed when a target carries no covariance.
    double kalmanDefaultSigmaMm{2.0};

    bool operator==(const ServoConfig& o) const {
        return sampleType == o.sampleType && armType == o.armType && mode == o.mode && filter == o.filter &&
               maxMoveMm == o.maxMoveMm && finalDistanceMm == o.finalDistanceMm &&
               toolOffsetMm == o.toolOffsetMm && armToleranceMm == o.armToleranceMm &&
               armDriftMm == o.armDriftMm && armDriftPerMm == o.armDriftPerMm &&
               maxTargetJumpMm == o.maxTargetJumpMm && trackingRadiusMm == o.trackingRadiusMm &&
               visionTimeoutMs == o.visionTimeoutMs && moveTimeoutMs == o.moveTimeoutMs &&
               lostTimeoutMs == o.lostTimeoutMs && maxIterations == o.maxIterations &&
               refineRegistration == o.refineRegistration && probeAngleDeg == o.probeAngleDeg &&
               registrationStdDeg == o.registrationStdDeg &&
               kalmanSampleNoiseMm == o.kalmanSampleNoiseMm && kalmanArmNoisePerMm == o.kalmanArmNoisePerMm &&
               kalmanDefaultSigmaMm == o.kalmanDefaultSigmaMm;
    }
};

}  // namespace avatar
