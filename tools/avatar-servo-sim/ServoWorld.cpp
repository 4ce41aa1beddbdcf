#include "ServoWorld.h"

#include <avatar/common/CameraModel.h>
#include <avatar/common/Error.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/render/Renderer.h>

#include <opencv2/core.hpp>

#include <cmath>
#include <random>
#include <utility>

namespace avatar::servosim {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kSampleRadiusMm = 20.0;
constexpr double kMarkerRadiusMm = 10.0;
const render::Rgb kSampleAlbedo{0.92, 0.72, 0.04};  // the duck's yellow: fits the "sample" filter
const render::Rgb kMarkerAlbedo{0.85, 0.46, 0.28};  // gold: fits the "arm_marker" filter
constexpr double kMarginPx = 60.0;                   // everything stays this far inside both images

cv::Vec3d vec(const cv::Point3d& p) {
    return {p.x, p.y, p.z};
}
cv::Point3d point(const cv::Vec3d& v) {
    return {v[0], v[1], v[2]};
}

cv::Vec3d randomDirection(std::mt19937_64& rng) {
    std::normal_distribution<double> normal;
    cv::Vec3d d(normal(rng), normal(rng), normal(rng));
    return d / cv::norm(d);
}

/// The lab of data/scenes/lab.xml without its objects: sand on a slope, lit from the camera.
render::Scene labBackground() {
    render::Scene s;
    s.name = "servo";
    s.seabed.distanceMm = 1300;
    s.seabed.tiltDeg = 35;
    s.seabed.albedo = {0.62, 0.56, 0.45};
    s.seabed.textureContrast = 0.25;
    s.seabed.textureScaleMm = 30;
    s.seabed.textureSeed = 11;
    s.lighting.ambient = {0.35, 0.35, 0.35};
    s.lighting.lightIntensity = {0.55, 0.55, 0.55};
    s.lighting.lightPositionMm = {0, -150, 0};
    s.sensor.readNoiseDn = 8;
    s.sensor.shotNoise = true;
    return s;
}

render::TargetSpec ball(std::string name, std::string type, const cv::Point3d& centre, double radius,
                        const render::Rgb& albedo) {
    render::TargetSpec t;
    t.name = std::move(name);
    t.type = std::move(type);
    t.shape = render::Shape::Sphere;
    t.centreMm = vec(centre);
    t.radiusMm = radius;
    t.albedo = albedo;
    return t;
}

}  // namespace

const char* toString(Scenario scenario) {
    switch (scenario) {
        case Scenario::Static: return "static";
        case Scenario::Moving: return "moving";
        case Scenario::Lost: return "lost";
        case Scenario::Distractor: return "distractor";
    }
    return "?";
}

Scenario parseScenario(const std::string& word) {
    for (Scenario s : {Scenario::Static, Scenario::Moving, Scenario::Lost, Scenario::Distractor}) {
        if (word == toString(s)) return s;
    }
    throw InvalidArgument("unknown scenario '" + word + "' (expected static, moving, lost or distractor)");
}

/// Vision data through TAUNet, the scene brought up to date first.
class ServoWorld::Vision final : public servo::VisionSource {
public:
    Vision(ServoWorld& world, tau::TauUnit& unit) : world_(world), tau_(unit) {}
    VisionTargets acquire(std::chrono::milliseconds timeout) override {
        world_.prepareLook();
        return tau_.acquire(timeout);
    }

private:
    ServoWorld& world_;
    servo::TauUnitVision tau_;
};

ServoWorld::ServoWorld(const WorldSpec& spec) : spec_(spec), background_(labBackground()) {
    if (!spec_.config.stereo.baseTVision) {
        throw InvalidArgument("servo world: the configuration has no <baseTVision> (the true registration)");
    }
    if (!spec_.config.servo) {
        throw InvalidArgument("servo world: the configuration has no <servo> section");
    }
    trueRegistration_ = *spec_.config.stereo.baseTVision;
    std::mt19937_64 rng(spec_.seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };

    // The registration the vision system is given: rotated about a random axis
    // of the vision frame and shifted in a random direction.
    const cv::Vec3d axis = randomDirection(rng) * (spec_.registrationErrorDeg * kPi / 180.0);
    const cv::Matx33d rotationError = rodrigues({axis[0], axis[1], axis[2]});
    const cv::Vec3d shift = randomDirection(rng) * spec_.registrationErrorMm;
    visionConfig_ = spec_.config;
    visionConfig_.stereo.baseTVision = makeRigidTransform(rotationMatrix(trueRegistration_) * rotationError,
                                                          translationVector(trueRegistration_) + shift);

    const StereoGeometry geometry = stereoGeometry(spec_.config.stereo);
    const double width = spec_.config.camera.width;
    const double height = spec_.config.camera.height;
    const auto inView = [&](const cv::Point3d& v, double radiusMm) {
        if (v.z < 450.0) return false;
        for (int side = 0; side < 2; ++side) {
            const cv::Point3d c = side == 0 ? v : transformPoint(geometry.rightTLeft, v);
            const CameraIntrinsics& in = side == 0 ? geometry.left : geometry.right;
            const std::optional<cv::Point2d> px = projectPoint(in, c);
            if (!px) return false;
            const double r = in.fc[0] * radiusMm / c.z + kMarginPx;
            if (px->x < r || px->y < r || px->x > width - 1 - r || px->y > height - 1 - r) return false;
        }
        return true;
    };

    // Two balls apart in both images (neither hides the other).
    const auto apartInViews = [&](const cv::Point3d& a, double ra, const cv::Point3d& b, double rb) {
        for (int side = 0; side < 2; ++side) {
            const cv::Point3d ca = side == 0 ? a : transformPoint(geometry.rightTLeft, a);
            const cv::Point3d cb = side == 0 ? b : transformPoint(geometry.rightTLeft, b);
            const CameraIntrinsics& in = side == 0 ? geometry.left : geometry.right;
            const std::optional<cv::Point2d> pa = projectPoint(in, ca);
            const std::optional<cv::Point2d> pb = projectPoint(in, cb);
            if (!pa || !pb) return false;
            const double gap = in.fc[0] * (ra / ca.z + rb / cb.z) + 15.0;
            if (cv::norm(*pa - *pb) < gap) return false;
        }
        return true;
    };

    // The sample, and the tool tip's start 150-300 mm from it, both in view
    // with the marker beside the tip.
    const ServoConfig& servo = *spec_.config.servo;
    const cv::Matx33d toolRotation = cv::Matx33d::eye();
    const cv::Vec3d offsetBase = toolRotation * cv::Vec3d(servo.toolOffsetMm.data());
    const RigidTransform visionTBase = inverse(trueRegistration_);
    const cv::Matx33d baseToVision = rotationMatrix(visionTBase);
    const cv::Vec3d offsetVision = baseToVision * offsetBase;
    cv::Point3d tipVision;
    bool placed = false;
    for (int attempt = 0; attempt < 1000 && !placed; ++attempt) {
        sampleVision0_ = {uniform(-200, 200), uniform(-110, 150), uniform(650, 1000)};
        tipVision = sampleVision0_ + point(randomDirection(rng) * uniform(150, 300));
        const cv::Point3d markerVision = tipVision - point(offsetVision);
        placed = inView(sampleVision0_, kSampleRadiusMm) && inView(markerVision, kMarkerRadiusMm) &&
                 inView(sampleVision0_ - point(offsetVision), kMarkerRadiusMm) &&
                 apartInViews(markerVision, kMarkerRadiusMm, sampleVision0_, kSampleRadiusMm);
    }
    if (!placed) {
        throw InvalidArgument("servo world: no layout in view for seed " + std::to_string(spec_.seed));
    }
    if (spec_.scenario == Scenario::Moving) {
        // horizontal in the base frame (along the seabed, not into it)
        cv::Vec3d d = randomDirection(rng);
        d[2] = 0.0;
        d /= std::max(1e-9, cv::norm(d));
        sampleDrift_ = baseToVision * d * spec_.sampleSpeedMmPerLook;
    }
    if (spec_.scenario == Scenario::Distractor) {
        for (int attempt = 0; attempt < 1000 && !distractorVision_; ++attempt) {
            const cv::Point3d d = sampleVision0_ + point(randomDirection(rng) * uniform(90, 140));
            if (inView(d, kSampleRadiusMm) && apartInViews(d, kSampleRadiusMm, sampleVision0_, kSampleRadiusMm) &&
                apartInViews(d, kSampleRadiusMm, tipVision - point(offsetVision), kMarkerRadiusMm)) {
                distractorVision_ = d;
            }
        }
    }

    const cv::Vec3d bias = randomDirection(rng) * spec_.armBiasMm;
    const cv::Vec3d trueTipBase = vec(transformPoint(trueRegistration_, tipVision));
    armOptions_.startBaseTTool = makeRigidTransform(toolRotation, trueTipBase - bias);
    armOptions_.staticBiasMm = bias;
    armOptions_.repeatabilityMm = spec_.repeatabilityMm;
    armOptions_.moveDuration = spec_.moveDuration;
    const std::uint64_t noise = spec_.noiseSeed != 0 ? spec_.noiseSeed * 31337u + 17u : spec_.seed;
    armOptions_.seed = noise * 7919u + 1u;
    arm_ = std::make_unique<servo::SimulatedArm>(armOptions_);

    render::RenderOptions options;
    options.sensor = render::sensorFormatFrom(spec_.config.camera);
    options.supersampling = spec_.supersampling;
    options.seed = noise * 1000003u;
    auto backend = std::make_unique<AcquireSIPSimulation>(sceneNow(), spec_.config.stereo, options);
    backend_ = backend.get();
    visionInterface_ = std::make_unique<VisionInterface>(std::move(backend), visionConfig_);
    tau::TauNetOptions net;
    net.port = 0;
    net.serverName = "TAUNet (servo simulation)";
    server_ = std::make_unique<tau::TauNetServer>(*visionInterface_, net);
    tau::TauUnitOptions client;
    client.port = server_->port();
    client.clientName = "avatar-servo-sim";
    client.snapshotTimeout = std::chrono::milliseconds(servo.visionTimeoutMs);
    unit_ = std::make_unique<tau::TauUnit>(client);
    unit_->connect();
    vision_ = std::make_unique<Vision>(*this, *unit_);
}

ServoWorld::~ServoWorld() {
    vision_.reset();
    unit_.reset();
    server_.reset();
    visionInterface_.reset();
}

servo::VisionSource& ServoWorld::vision() {
    return *vision_;
}

cv::Point3d ServoWorld::sampleVisionMm(int look) const {
    return sampleVision0_ + point(sampleDrift_ * static_cast<double>(look));
}

cv::Point3d ServoWorld::sampleHintBaseMm() const {
    return transformPoint(*visionConfig_.stereo.baseTVision, sampleVision0_);
}

cv::Point3d ServoWorld::startTelemetryMm() const {
    return point(translationVector(armOptions_.startBaseTTool));
}

WorldTruth ServoWorld::truth() const {
    WorldTruth t;
    t.toolTipBaseMm = point(translationVector(arm_->trueBaseTTool()));
    t.sampleBaseMm = transformPoint(trueRegistration_, sampleVisionMm(std::max(0, look_ - 1)));
    t.errorMm = cv::norm(t.toolTipBaseMm - t.sampleBaseMm);
    return t;
}

void ServoWorld::resetArm() {
    armOptions_.seed += 104729u;
    arm_ = std::make_unique<servo::SimulatedArm>(armOptions_);
    look_ = 0;
    looks_.clear();
}

void ServoWorld::applyRegistration(const RigidTransform& baseTVision) {
    AvatarConfig next = visionConfig_;
    next.stereo.baseTVision = baseTVision;
    unit_->sendConfig(writeConfigString(next));
    visionConfig_ = next;
}

std::vector<cv::Point3d> ServoWorld::registrationWaypoints() const {
    const cv::Vec3d offset(spec_.config.servo->toolOffsetMm.data());
    const RigidTransform& given = *visionConfig_.stereo.baseTVision;
    std::vector<cv::Point3d> out;
    for (double z : {700.0, 950.0}) {
        for (double y : {-90.0, 70.0}) {
            for (double x : {-160.0, 0.0, 160.0}) {
                // the marker at (x, y, z) in the vision frame; the tip beside it
                const cv::Point3d markerBase = transformPoint(given, cv::Point3d(x, y, z));
                out.push_back(markerBase + point(offset));
            }
        }
    }
    return out;
}

render::Scene ServoWorld::sceneNow() const {
    render::Scene scene = background_;
    const bool hidden = spec_.scenario == Scenario::Lost && look_ >= spec_.lostFrom &&
                        look_ < spec_.lostFrom + spec_.lostLooks;
    if (!hidden) {
        scene.targets.push_back(ball("sample", spec_.config.servo->sampleType, sampleVisionMm(look_),
                                     kSampleRadiusMm, kSampleAlbedo));
    }
    if (distractorVision_) {
        scene.targets.push_back(
            ball("distractor", spec_.config.servo->sampleType, *distractorVision_, kSampleRadiusMm, kSampleAlbedo));
    }
    if (arm_) {
        const RigidTransform tool = arm_->trueBaseTTool();
        const cv::Vec3d markerBase =
            translationVector(tool) - rotationMatrix(tool) * cv::Vec3d(spec_.config.servo->toolOffsetMm.data());
        const cv::Point3d markerVision = transformPoint(inverse(trueRegistration_), point(markerBase));
        scene.targets.push_back(
            ball("marker", spec_.config.servo->armType, markerVision, kMarkerRadiusMm, kMarkerAlbedo));
    }
    return scene;
}

void ServoWorld::prepareLook() {
    backend_->setScene(sceneNow());
    looks_.push_back(WorldTruth{});
    ++look_;
    looks_.back() = truth();
}

TaskOutcome runSamplingTask(const WorldSpec& spec, servo::ServoOptions options) {
    ServoWorld world(spec);
    TaskOutcome out;
    servo::ServoTask task;
    task.sampleHintBaseMm = world.sampleHintBaseMm();
    {
        servo::VisualServo controller(world.arm(), world.vision(), world.servoConfig(), options);
        out.servo = controller.run(task);
    }
    out.servoLooks = world.truthAtLooks();
    out.servoFinal = world.truth();

    world.resetArm();
    ServoConfig once = world.servoConfig();
    once.mode = ServoMode::DeadReckoning;
    servo::VisualServo deadReckoning(world.arm(), world.vision(), once, options);
    out.deadReckoning = deadReckoning.run(task);
    out.deadReckoningFinal = world.truth();
    return out;
}

}  // namespace avatar::servosim
