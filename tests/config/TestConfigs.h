#pragma once
// Configurations shared by the config tests.

#include <avatar/config/AvatarConfig.h>

#include <cmath>

namespace avatar::test {

/// A valid configuration in which every field differs from its default, with
/// values that are awkward to print: 17 significant digits, huge, tiny,
/// negative zero, text that needs XML escaping.
inline AvatarConfig unusualConfig() {
    AvatarConfig c;
    CameraHardwareConfig& cam = c.camera;
    cam.width = 1023;
    cam.height = 767;
    cam.bitDepth = 12;
    cam.channels = 1;
    cam.bayer = true;
    cam.bayerPattern = BayerPattern::GR;
    cam.endianSwap = true;
    cam.leftCameraId = "0x00b09d01004a2c1f";
    cam.rightCameraId = "cam <R> & \"2\" 'x' \xc3\xa9";  // needs escaping; UTF-8 e-acute
    cam.features.exposure = {312.5, true};
    cam.features.shutter = {0.0123, false};
    cam.features.gain = {-3.25, true};
    cam.features.whiteBalance = {77.125, 93.0625, true};
    cam.features.brightness = {1.0 / 3.0, true};
    cam.features.gamma = {2.2, true};

    TargetType duck;
    duck.name = "duck_1";
    duck.filter = ColorFilterMethod::Hsv;
    duck.redGreen = {0.1 + 0.2, 1.6};
    duck.redBlue = {2.5, 1e300};
    duck.blueGreen = {5e-324, 0.45};
    duck.brightness = Range{1e-7, 196605};
    duck.hsv = HsvRanges{{340.5, 20.25}, {0.25, 0.875}, {0.0625, 0.9990234375}};
    duck.erodeRestore = true;
    duck.erodeKernelSize = 7;
    duck.area = {150, 123456789012.0};
    duck.aspectRatio = {0.3, 3.75};
    duck.areaRatio = {0.4, 0.95};
    duck.window = {16, 8, 1000, 700};
    duck.shape = TargetShape::Sphere;
    duck.sizeMm = Range{61.25, 1e-3 + 98.5};

    TargetType marker;
    marker.name = "arm-Marker";
    marker.filter = ColorFilterMethod::RgbRatio;
    marker.redGreen = {1.3, 2.2};
    marker.redBlue = {1.8, 6};
    marker.blueGreen = {0.05, 0.6};
    marker.erodeKernelSize = 1;
    marker.area = {40, 90000};
    c.targets.targets = {duck, marker};

    MatchConfig& m = c.match;
    m.method = MatchMethod::EpipolarLine;
    m.boxDxMin = -12.5;
    m.boxDxMax = 280.25;
    m.boxDyMin = -8.125;
    m.boxDyMax = 7.875;
    m.maxEpipolarDistancePx = 2.75;
    m.minRangeMm = 350;
    m.maxRangeMm = 2999.5;
    m.shape = {0.7, 1.3, 12345.678, 2.5};
    m.repeats = RepeatMatchPolicy::Void;

    StereoSystemConfig& s = c.stereo;
    s.left = {{1049.13, 1050.38}, {712.28, 564.45}, 0.00123, {-0.21, 0.17, -0.0, -0.002, 0.03}};
    s.right = {{1047.2, 1048.66}, {702.74, 561.13}, -0.0004, {-0.2, 0.16, 0.0011, 0.0021, -0.031}};
    s.om = {0.002, 0.003, 0.047};
    s.translationMm = {-106.53, -2.58, 0.82};
    const double a = 0.5236;  // about 30 degrees about z
    s.baseTVision = RigidTransform{{std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1},
                                   {512.5, -33.25, 1200.125}};

    LightingConfig& l = c.lighting;
    l.frameAverageEnabled = true;
    l.gainsRgb = {1.25, 0.875, 2.5};
    l.patternEnabled = true;
    l.patternCentrePx = {633.5, 471.25};
    l.red = {1.1, 0.0015};
    l.green = {0.95, 0.001};
    l.blue = {1.05, 0.0008};
    l.templateImagePath = "lighting/strobe template.exr";

    AnalysisConfig& an = c.analysis;
    an.stages = {"demosaic", "color_filter", "locate_features", "match", "triangulate", "count_2"};
    an.demosaic = DemosaicAlgorithm::EdgeAware;
    an.centroid = CentroidMode::Pixel;
    an.triangulation = TriangulationMode::Centroid;
    an.visibility = {0.05, 0.125, 0.4375};
    return c;
}

}  // namespace avatar::test
