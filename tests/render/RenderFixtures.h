#pragma once
// Shared calibration and scenes for the renderer tests.

#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>

namespace avatar::test {

/// Thesis Table 6-4 (Scorpion cameras; no distortion published).
inline StereoSystemConfig scorpion() {
    StereoSystemConfig c;
    c.left.fc = {1049.13, 1050.38};
    c.left.cc = {712.28, 564.45};
    c.right.fc = {1047.20, 1048.66};
    c.right.cc = {702.74, 561.13};
    c.om = {0.002, 0.003, 0.047};
    c.translationMm = {-106.53, -2.58, 0.82};
    return c;
}

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
