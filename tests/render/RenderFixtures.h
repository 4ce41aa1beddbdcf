#pragma once
// Shared calibration and scenes for the renderer tests.

#include "SampleConfigs.h"

#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>

namespace avatar::test {

/// The Scorpion calibration of data/config/scorpion.xml (thesis Table 6-4).
inline StereoSystemConfig scorpion() { return scorpionCalibration(); }

inline render::RenderOptions noiseFree(int width = 1280, int height = 960) {
    render::RenderOptions o;
    o.sensor.width = width;
    o.sensor.height = height;
    o.noise = false;
    return o;
}

/// A scene with only ambient light on a flat, untextured seabed facing the camera.
inline render::Scene flatScene(const render::Rgb& albedo, double ambient) {
    render::Scene s;
    s.name = "flat";
    s.seabed.distanceMm = 1500.0;
    s.seabed.textureContrast = 0.0;
    s.seabed.albedo = albedo;
    s.lighting.ambient = {ambient, ambient, ambient};
    s.lighting.lightIntensity = {0.0, 0.0, 0.0};
    return s;
}

}  // namespace avatar::test
