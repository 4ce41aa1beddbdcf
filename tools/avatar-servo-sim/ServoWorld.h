#pragma once
/// @file ServoWorld.h
/// The simulated world of avatar-servo-sim (docs/servo.md): a Scorpion-like
/// stereo pair, the seabed, a sample ball, a gold ball on the end effector of a
/// SimulatedArm, and the whole vision chain (AcquireSIPSimulation ->
/// VisionInterface -> TAUNet on a local port -> TAUUnit). Before every look
/// the scene is rebuilt from the arm's true pose and the sample's true
/// position, so the controller sees the world only through rendered images.
///
/// The vision system is given a registration that is wrong by a chosen angle
/// and offset; the arm misses its telemetry by a fixed bias plus its
/// repeatability noise. Everything is drawn from one seed.

#include <avatar/acquire/AcquireSIPSimulation.h>
#include <avatar/config/AvatarConfig.h>
#include <avatar/servo/SimulatedArm.h>
#include <avatar/servo/VisualServo.h>
#include <avatar/tau/TauNetServer.h>
#include <avatar/tau/TauUnit.h>
#include <avatar/tau/VisionInterface.h>

#include <opencv2/core/types.hpp>

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace avatar::servosim {

/// What happens to the sample during a run.
enum class Scenario {
    Static,      ///< it stays where it is
    Moving,      ///< it drifts by sampleSpeedMmPerLook per look, in a random horizontal direction
    Lost,        ///< it disappears for lostLooks looks from look lostFrom (0-based)
    Distractor   ///< a second ball of the same colour 90-140 mm from it
};
/// "static", "moving", "lost", "distractor".
const char* toString(Scenario scenario);
/// Throws avatar::InvalidArgument naming the word otherwise.
Scenario parseScenario(const std::string& word);

struct WorldSpec {
    /// The truth: calibration, registration (<baseTVision> required), targets, <servo>.
    AvatarConfig config;
    std::uint64_t seed{1};
    /// Seeds the sensor and arm noise; 0: derived from seed. The same seed with
    /// other noise seeds is the same world measured again (repeatability).
    std::uint64_t noiseSeed{0};
    double registrationErrorDeg{5.0};  ///< of the registration the vision system is given
    double registrationErrorMm{20.0};
    double armBiasMm{20.0};            ///< static accuracy error of the arm
    double repeatabilityMm{0.5};       ///< per axis
    std::chrono::milliseconds moveDuration{0};
    Scenario scenario{Scenario::Static};
    double sampleSpeedMmPerLook{1.0};
    int lostFrom{2};
    int lostLooks{3};
    int supersampling{2};
};

/// Where things really are at one moment (base frame, mm).
struct WorldTruth {
    cv::Point3d toolTipBaseMm;
    cv::Point3d sampleBaseMm;
    double errorMm{0.0};  ///< |tool tip - sample centre|
};

class ServoWorld {
public:
    /// Draws the layout from spec.seed and starts the vision chain. Throws
    /// avatar::InvalidArgument when the configuration has no registration or
    /// no <servo>, and what the vision chain throws when it cannot start.
    explicit ServoWorld(const WorldSpec& spec);
    ~ServoWorld();
    ServoWorld(const ServoWorld&) = delete;
    ServoWorld& operator=(const ServoWorld&) = delete;

    servo::SimulatedArm& arm() { return *arm_; }
    /// Vision data through TAUNet; the scene is brought up to date before each look.
    servo::VisionSource& vision();
    /// The servo tuning of the configuration.
    const ServoConfig& servoConfig() const { return *spec_.config.servo; }
    /// The configuration the vision system runs with (the perturbed registration).
    const AvatarConfig& visionConfig() const { return visionConfig_; }
    /// base_T_vision, true and as given to the vision system.
    const RigidTransform& trueRegistration() const { return trueRegistration_; }
    /// Where an operator picking the sample in the first image would put it:
    /// its true position through the registration the vision system has.
    cv::Point3d sampleHintBaseMm() const;
    /// The truth now, and at every look so far (in order).
    WorldTruth truth() const;
    const std::vector<WorldTruth>& truthAtLooks() const { return looks_; }
    /// A fresh arm at the start pose (same bias, new noise): for a second run.
    void resetArm();
    /// The arm's start telemetry (tool tip, base frame).
    cv::Point3d startTelemetryMm() const;
    /// Gives the vision system a new registration (SEND_CONFIG over TAUNet, as
    /// a controller would after the automated registration).
    void applyRegistration(const RigidTransform& baseTVision);
    /// Registration waypoints: a 3 x 2 x 2 grid of tool tip positions (base
    /// frame, through the registration the vision system has) that keeps the
    /// marker in view.
    std::vector<cv::Point3d> registrationWaypoints() const;
    /// The sample's true vision-frame position at look @p look.
    cv::Point3d sampleVisionMm(int look) const;

private:
    class Vision;
    void prepareLook();
    render::Scene sceneNow() const;

    WorldSpec spec_;
    AvatarConfig visionConfig_;
    RigidTransform trueRegistration_;
    render::Scene background_;
    cv::Point3d sampleVision0_;
    cv::Vec3d sampleDrift_{0, 0, 0};
    std::optional<cv::Point3d> distractorVision_;
    servo::SimulatedArmOptions armOptions_;
    std::unique_ptr<servo::SimulatedArm> arm_;
    AcquireSIPSimulation* backend_{nullptr};  ///< owned by vision_
    std::unique_ptr<VisionInterface> visionInterface_;
    std::unique_ptr<tau::TauNetServer> server_;
    std::unique_ptr<tau::TauUnit> unit_;
    std::unique_ptr<Vision> vision_;
    int look_{0};
    std::vector<WorldTruth> looks_;
};

/// One seeded sampling task: the servo from the start pose, then dead
/// reckoning (one snapshot, one move) from the same start with a fresh arm.
struct TaskOutcome {
    servo::ServoResult servo;
    std::vector<WorldTruth> servoLooks;  ///< the truth at each of the servo's looks
    WorldTruth servoFinal;               ///< after the servo's last move
    servo::ServoResult deadReckoning;
    WorldTruth deadReckoningFinal;
};

/// Runs the task of @p spec (its <servo> tuning; the dead-reckoning run with
/// mode dead_reckoning). Throws what ServoWorld throws.
TaskOutcome runSamplingTask(const WorldSpec& spec, servo::ServoOptions options = {});

}  // namespace avatar::servosim
