// The shipped sample configurations in data/config/ parse to the documented values.

#include <avatar/config/ConfigXml.h>

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace avatar {
namespace {

const std::filesystem::path kConfigDir = std::filesystem::path(AVATAR_DATA_DIR) / "config";

bool disjoint(const Range& a, const Range& b) {
    return a.max < b.min || b.max < a.min;
}

const TargetType* findTarget(const AvatarConfig& c, const std::string& name) {
    for (const TargetType& t : c.targets.targets) {
        if (t.name == name) {
            return &t;
        }
    }
    return nullptr;
}

/// Thesis Table 6-4.
void expectScorpionCalibration(const StereoSystemConfig& s) {
    EXPECT_EQ(s.left.fc, (std::array<double, 2>{1049.13, 1050.38}));
    EXPECT_EQ(s.left.cc, (std::array<double, 2>{712.28, 564.45}));
    EXPECT_EQ(s.right.fc, (std::array<double, 2>{1047.20, 1048.66}));
    EXPECT_EQ(s.right.cc, (std::array<double, 2>{702.74, 561.13}));
    EXPECT_EQ(s.left.alphaC, 0.0);
    EXPECT_EQ(s.right.alphaC, 0.0);
    EXPECT_EQ(s.left.kc, (std::array<double, 5>{0, 0, 0, 0, 0}));
    EXPECT_EQ(s.right.kc, (std::array<double, 5>{0, 0, 0, 0, 0}));
    EXPECT_EQ(s.om, (std::array<double, 3>{0.002, 0.003, 0.047}));
    EXPECT_EQ(s.translationMm, (std::array<double, 3>{-106.53, -2.58, 0.82}));
}

void expectScorpionCamera(const CameraHardwareConfig& c) {
    EXPECT_EQ(c.width, 1280);
    EXPECT_EQ(c.height, 960);
    EXPECT_EQ(c.bitDepth, 16);
    EXPECT_EQ(c.channels, 1);
    EXPECT_TRUE(c.bayer);
    EXPECT_EQ(c.bayerPattern, BayerPattern::BG);
    EXPECT_FALSE(c.endianSwap);
    EXPECT_EQ(c.leftCameraId, "");
    EXPECT_EQ(c.rightCameraId, "");
    EXPECT_FALSE(c.features.exposure.automatic);
    EXPECT_FALSE(c.features.whiteBalance.automatic);
}

TEST(ConfigSamples, Scorpion) {
    const std::filesystem::path path = kConfigDir / "scorpion.xml";
    const AvatarConfig c = readConfigFile(path);
    expectScorpionCamera(c.camera);
    expectScorpionCalibration(c.stereo);

    ASSERT_EQ(c.targets.targets.size(), 2u);
    const TargetType* duck = findTarget(c, "sample");
    ASSERT_NE(duck, nullptr);
    EXPECT_EQ(duck->filter, ColorFilterMethod::RgbRatio);
    EXPECT_EQ(duck->redGreen, (Range{0.9, 1.6}));
    EXPECT_EQ(duck->redBlue, (Range{2.5, 100}));
    EXPECT_EQ(duck->blueGreen, (Range{0, 0.45}));
    EXPECT_FALSE(duck->brightness.has_value());
    EXPECT_TRUE(duck->erodeRestore);
    EXPECT_EQ(duck->erodeKernelSize, 3);
    EXPECT_EQ(duck->area.min, 150.0);
    EXPECT_TRUE(duck->window.wholeImage());

    const TargetType* marker = findTarget(c, "arm_marker");
    ASSERT_NE(marker, nullptr);
    EXPECT_EQ(marker->redGreen, (Range{1.65, 2.2}));
    EXPECT_EQ(marker->redBlue, (Range{1.8, 6}));
    EXPECT_EQ(marker->blueGreen, (Range{0.25, 0.75}));
    // No pixel may pass both filters, or the duck could be taken for the marker.
    EXPECT_TRUE(disjoint(duck->redGreen, marker->redGreen) || disjoint(duck->redBlue, marker->redBlue) ||
                disjoint(duck->blueGreen, marker->blueGreen));

    EXPECT_EQ(c.match.method, MatchMethod::EpipolarBox);
    EXPECT_EQ(c.match.boxDxMin, 15.0);
    EXPECT_EQ(c.match.boxDxMax, 310.0);
    EXPECT_EQ(c.match.boxDyMin, -25.0);
    EXPECT_EQ(c.match.boxDyMax, 40.0);
    // The box covers 0.4 m .. 3 m for this calibration: dx = fx * |T| / Z.
    const double baseline = std::hypot(c.stereo.translationMm[0], c.stereo.translationMm[1], c.stereo.translationMm[2]);
    EXPECT_LE(c.match.boxDxMin, c.stereo.left.fc[0] * baseline / 3000.0);
    EXPECT_GE(c.match.boxDxMax, c.stereo.left.fc[0] * baseline / 400.0);
    EXPECT_EQ(c.match.minRangeMm, 400.0);
    EXPECT_EQ(c.match.maxRangeMm, 3000.0);

    ASSERT_TRUE(c.stereo.baseTVision.has_value());
    EXPECT_EQ(c.stereo.baseTVision->rotation, (std::array<double, 9>{0, 0, 1, -1, 0, 0, 0, -1, 0}));
    EXPECT_EQ(c.stereo.baseTVision->translationMm, (std::array<double, 3>{250, 0, -150}));

    EXPECT_FALSE(c.lighting.frameAverageEnabled);
    EXPECT_FALSE(c.lighting.patternEnabled);
    EXPECT_TRUE(c.lighting == LightingConfig{});
}

// The servo simulation's configuration: the Scorpion pair and filters, both
// types declared spheres, and the servo tuning that docs/servo.md measures.
TEST(ConfigSamples, ServoSimulation) {
    const AvatarConfig c = readConfigFile(kConfigDir / "servo-sim.xml");
    const AvatarConfig scorpion = readConfigFile(kConfigDir / "scorpion.xml");
    expectScorpionCamera(c.camera);
    expectScorpionCalibration(c.stereo);
    EXPECT_EQ(c.stereo.baseTVision, scorpion.stereo.baseTVision);
    ASSERT_EQ(c.targets.targets.size(), 2u);
    for (const char* name : {"sample", "arm_marker"}) {
        const TargetType* t = findTarget(c, name);
        const TargetType* s = findTarget(scorpion, name);
        ASSERT_NE(t, nullptr);
        ASSERT_NE(s, nullptr);
        EXPECT_EQ(t->shape, TargetShape::Sphere) << name;
        EXPECT_EQ(t->redGreen, s->redGreen) << name;
        EXPECT_EQ(t->redBlue, s->redBlue) << name;
        EXPECT_EQ(t->blueGreen, s->blueGreen) << name;
    }
    ASSERT_TRUE(c.servo.has_value());
    const ServoConfig& v = *c.servo;
    EXPECT_EQ(v.sampleType, "sample");
    EXPECT_EQ(v.armType, "arm_marker");
    EXPECT_EQ(v.mode, ServoMode::Hybrid);
    EXPECT_EQ(v.filter, ServoFilter::None);
    EXPECT_EQ(v.maxMoveMm, 50.0);
    EXPECT_EQ(v.finalDistanceMm, 15.0);
    EXPECT_EQ(v.toolOffsetMm, (std::array<double, 3>{0, -50, 0}));
    EXPECT_EQ(v.armToleranceMm, 200.0);
    EXPECT_TRUE(v.refineRegistration);
    // Without a <servo> section a vision-only document has none.
    EXPECT_FALSE(scorpion.servo.has_value());
}

TEST(ConfigSamples, Seabed) {
    const AvatarConfig c = readConfigFile(kConfigDir / "seabed.xml");
    expectScorpionCamera(c.camera);
    expectScorpionCalibration(c.stereo);
    EXPECT_FALSE(c.stereo.baseTVision.has_value());

    ASSERT_EQ(c.targets.targets.size(), 1u);
    const TargetType& dollar = c.targets.targets[0];
    EXPECT_EQ(dollar.name, "sand_dollar");
    ASSERT_TRUE(dollar.brightness.has_value());
    EXPECT_EQ(*dollar.brightness, (Range{3500, 196605}));
    EXPECT_EQ(dollar.erodeKernelSize, 5);

    const LightingConfig& l = c.lighting;
    EXPECT_FALSE(l.frameAverageEnabled);
    EXPECT_TRUE(l.patternEnabled);
    EXPECT_EQ(l.patternCentrePx, (std::array<double, 2>{640, 480}));
    EXPECT_EQ(l.red, (FalloffChannel{1, 0.0015}));
    EXPECT_EQ(l.green, (FalloffChannel{1, 0.0010}));
    EXPECT_EQ(l.blue, (FalloffChannel{1, 0.0008}));
    EXPECT_EQ(l.templateImagePath, "");

    // Same calibration as the Scorpion sample, apart from the registration.
    StereoSystemConfig scorpion = readConfigFile(kConfigDir / "scorpion.xml").stereo;
    scorpion.baseTVision.reset();
    EXPECT_TRUE(c.stereo == scorpion);
}

TEST(ConfigSamples, SurviveAWriteReadCycle) {
    for (const char* name : {"scorpion.xml", "seabed.xml"}) {
        SCOPED_TRACE(name);
        const AvatarConfig c = readConfigFile(kConfigDir / name);
        EXPECT_TRUE(readConfigString(writeConfigString(c)) == c);
    }
}

// The complete example in docs/config.md is a valid document.
TEST(ConfigSamples, DocumentationExample) {
    std::ifstream in(std::filesystem::path(AVATAR_SOURCE_DIR) / "docs" / "config.md");
    ASSERT_TRUE(in) << "docs/config.md";
    const std::string doc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::size_t begin = doc.find("```xml\n");
    ASSERT_NE(begin, std::string::npos);
    const std::size_t end = doc.find("```", begin + 7);
    ASSERT_NE(end, std::string::npos);
    const AvatarConfig c = readConfigString(doc.substr(begin + 7, end - begin - 7), "docs/config.md");
    ASSERT_EQ(c.targets.targets.size(), 2u);
    EXPECT_EQ(c.targets.targets[1].filter, ColorFilterMethod::Hsv);
    EXPECT_EQ(c.targets.targets[1].hsv.hue, (Range{340, 20}));
    EXPECT_EQ(c.camera.rightCameraId, "0x00b09d01004a2c20");
    EXPECT_TRUE(c.lighting.frameAverageEnabled);
    EXPECT_EQ(c.lighting.gainsRgb, (std::array<double, 3>{1.4, 1.1, 0.9}));
    EXPECT_TRUE(c.stereo.baseTVision.has_value());
    EXPECT_EQ(c.targets.targets[1].shape, TargetShape::Sphere);
    EXPECT_EQ(c.analysis.demosaic, DemosaicAlgorithm::EdgeAware);
    EXPECT_EQ(c.analysis.stages, AnalysisConfig{}.stages);
    ASSERT_TRUE(c.servo.has_value());
    EXPECT_EQ(c.servo->armType, "red_ball");
    EXPECT_EQ(c.servo->mode, ServoMode::Hybrid);
    EXPECT_EQ(c.servo->toolOffsetMm, (std::array<double, 3>{0, -50, 0}));
}

}  // namespace
}  // namespace avatar
