#pragma once
// One yellow sphere 0.8 m in front of the half-resolution Scorpion pair
// (640x480 16-bit Bayer) and the configuration that finds it: the small,
// fast end-to-end scene of the vision interface, TAUNet tests and benchmark.

#include "SampleConfigs.h"

#include <avatar/acquire/AcquireSIPSimulation.h>
#include <avatar/config/AvatarConfig.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>

#include <opencv2/core/types.hpp>

#include <memory>

namespace avatar::test {

/// The sphere's centre in the left camera frame, mm.
inline const cv::Point3d kSphereMm{30, 20, 800};

/// The configuration: the camera of the simulation, one sphere target type
/// ("sample", the duck's colours) and a disparity box for 0.4..3 m.
inline AvatarConfig sphereSceneConfig() {
    AvatarConfig c;
    c.camera.width = 640;
    c.camera.height = 480;
    c.camera.bitDepth = 16;
    c.camera.channels = 1;
    c.camera.bayer = true;
    c.camera.bayerPattern = BayerPattern::BG;
    c.stereo = halfScorpion();
    TargetType sample;
    sample.name = "sample";
    sample.redGreen = {0.9, 1.6};
    sample.redBlue = {2.5, 100};
    sample.blueGreen = {0, 0.45};
    sample.area = {100, 1e6};
    sample.shape = TargetShape::Sphere;
    c.targets.targets = {sample};
    c.match.boxDxMin = 5;
    c.match.boxDxMax = 200;
    c.match.boxDyMin = -20;
    c.match.boxDyMax = 25;
    return c;
}

/// The scene: the sphere (radius 30 mm) before the seabed at 1.2 m, read noise 8 DN.
inline render::Scene sphereScene() {
    render::Scene scene;
    scene.seabed.distanceMm = 1200;
    scene.sensor.readNoiseDn = 8;
    render::TargetSpec sphere;
    sphere.name = "ball";
    sphere.type = "sample";
    sphere.shape = render::Shape::Sphere;
    sphere.centreMm = {kSphereMm.x, kSphereMm.y, kSphereMm.z};
    sphere.radiusMm = 30;
    scene.targets = {sphere};
    return scene;
}

/// The simulation backend rendering it (first seed 7).
inline std::unique_ptr<AcquireSIPSimulation> sphereSimulation() {
    render::RenderOptions options;
    options.sensor.width = 640;
    options.sensor.height = 480;
    options.seed = 7;
    return std::make_unique<AcquireSIPSimulation>(sphereScene(), halfScorpion(), options);
}

}  // namespace avatar::test
