#include <avatar/acquire/AcquireSIPSimulation.h>

#include <chrono>

namespace avatar {

using render::GroundTruth;
using render::RenderOptions;
using render::Scene;
using render::RenderResult;
using render::SensorFormat;
using render::sensorFormatFrom;

AcquireSIPSimulation::AcquireSIPSimulation(Scene scene, StereoSystemConfig trueStereo, RenderOptions options)
    : scene_(std::move(scene)), trueStereo_(std::move(trueStereo)), options_(options) {
    options_.validate();
}

void AcquireSIPSimulation::setScene(Scene scene) {
    std::lock_guard<std::mutex> lock(mutex_);
    scene_ = std::move(scene);
}

GroundTruth AcquireSIPSimulation::lastTruth() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return lastTruth_;
}

void AcquireSIPSimulation::setCameraIds(std::string left, std::string right) {
    std::lock_guard<std::mutex> lock(mutex_);
    leftId_ = std::move(left);
    rightId_ = std::move(right);
}

std::array<CameraFeatureReadback, 2> AcquireSIPSimulation::readFeatures() const {
    std::lock_guard<std::mutex> lock(mutex_);
    std::array<CameraFeatureReadback, 2> out;
    for (const Side side : {Side::Left, Side::Right}) {
        CameraFeatureReadback& r = out[side == Side::Left ? 0 : 1];
        r.side = side;
        r.cameraId = side == Side::Left ? leftId_ : rightId_;
        for (const std::string& name : cameraFeatureNames()) {
            FeatureReading f;
            f.name = name;
            f.note = "the simulated camera has no " + name + " control: the scene's <sensor> sets its response";
            r.features.push_back(std::move(f));
        }
    }
    return out;
}

AcquiredPair AcquireSIPSimulation::grab() {
    Scene scene;
    RenderOptions options;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        scene = scene_;
        options = options_;
        options.seed = options_.seed + grabs_++;
    }
    RenderResult rendered = render::render(scene, trueStereo_, options);
    const auto now = std::chrono::duration_cast<std::chrono::microseconds>(
                         std::chrono::system_clock::now().time_since_epoch())
                         .count();
    AcquiredPair out;
    std::lock_guard<std::mutex> lock(mutex_);
    AcquisitionId id;
    id.left = {leftId_, now};
    id.right = {rightId_, now};
    rendered.pair.setId(id);
    out.pair = std::move(rendered.pair);
    lastTruth_ = std::move(rendered.truth);
    return out;
}

void AcquireSIPSimulation::configure(const AvatarConfig& config) {
    SensorFormat sensor = sensorFormatFrom(config.camera);
    RenderOptions options;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        options = options_;
    }
    options.sensor = sensor;
    options.validate();  // throws and keeps the old format
    std::lock_guard<std::mutex> lock(mutex_);
    options_ = options;
}

}  // namespace avatar
