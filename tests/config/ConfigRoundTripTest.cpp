// Write -> read round trips: every field, exact doubles, byte-identical re-writes.

#include "TestConfigs.h"

#include <avatar/config/ConfigXml.h>

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace avatar {
namespace {

using test::unusualConfig;

TEST(ConfigRoundTrip, UnusualConfigReadsBackEqual) {
    const AvatarConfig original = unusualConfig();
    ASSERT_NO_THROW(validateConfig(original));
    const std::string xml = writeConfigString(original);
    const AvatarConfig back = readConfigString(xml);
    EXPECT_TRUE(back == original);
    // Spot checks that do not rely on operator==.
    EXPECT_EQ(back.targets.targets.at(0).redGreen.min, 0.1 + 0.2);
    EXPECT_EQ(back.targets.targets.at(0).blueGreen.min, 5e-324);
    EXPECT_EQ(back.targets.targets.at(0).redBlue.max, 1e300);
    EXPECT_EQ(back.camera.features.brightness.value, 1.0 / 3.0);
    EXPECT_EQ(back.camera.rightCameraId, "cam <R> & \"2\" 'x' \xc3\xa9");
    EXPECT_TRUE(std::signbit(back.stereo.left.kc[2]));
    ASSERT_TRUE(back.stereo.baseTVision.has_value());
    EXPECT_EQ(back.stereo.baseTVision->rotation[1], -std::sin(0.5236));
}

TEST(ConfigRoundTrip, RewriteIsByteIdentical) {
    const std::string first = writeConfigString(unusualConfig());
    const std::string second = writeConfigString(readConfigString(first));
    EXPECT_EQ(second, first);
}

TEST(ConfigRoundTrip, DefaultsExceptRequiredRoundTrip) {
    // The struct defaults plus one target: optional parts absent.
    AvatarConfig c;
    c.targets.targets.push_back(TargetType{});
    c.targets.targets[0].name = "t";
    ASSERT_FALSE(c.stereo.baseTVision.has_value());
    ASSERT_FALSE(c.targets.targets[0].brightness.has_value());
    ASSERT_FALSE(c.targets.targets[0].sizeMm.has_value());
    const std::string xml = writeConfigString(c);
    EXPECT_EQ(xml.find("<baseTVision>"), std::string::npos);
    EXPECT_EQ(xml.find("<sizeMm>"), std::string::npos);
    // <brightness> only as the camera feature, not as the target's optional range.
    ASSERT_NE(xml.find("<brightness>"), std::string::npos);
    EXPECT_EQ(xml.find("<brightness>"), xml.rfind("<brightness>"));
    EXPECT_EQ(xml.find("<templateImage>"), std::string::npos);
    const AvatarConfig back = readConfigString(xml);
    EXPECT_TRUE(back == c);
    EXPECT_EQ(writeConfigString(back), xml);
}

TEST(ConfigRoundTrip, WrittenFormat) {
    const std::string xml = writeConfigString(unusualConfig());
    EXPECT_EQ(xml.rfind("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n", 0), 0u) << xml.substr(0, 80);
    EXPECT_NE(xml.find("\n<avatar version=\"1\">\n    <camera>\n        <width>1023</width>\n"), std::string::npos);
    EXPECT_NE(xml.find("<fc>1049.13 1050.38</fc>"), std::string::npos);
    EXPECT_NE(xml.find("<kc>-0.21 0.17 -0 -0.002 0.03</kc>"), std::string::npos);
    EXPECT_NE(xml.find("<min>0.30000000000000004</min>"), std::string::npos);
    EXPECT_NE(xml.find("<max>1e+300</max>"), std::string::npos);
    EXPECT_NE(xml.find("<bayerPattern>GR</bayerPattern>"), std::string::npos);
    EXPECT_NE(xml.find("<method>epipolar_line</method>"), std::string::npos);
    EXPECT_NE(xml.find("<filter>hsv</filter>"), std::string::npos);
    EXPECT_NE(xml.find("<filter>rgb_ratio</filter>"), std::string::npos);
    EXPECT_NE(xml.find("<target name=\"duck_1\">"), std::string::npos);
    EXPECT_NE(xml.find("&lt;R&gt; &amp;"), std::string::npos);
    EXPECT_NE(xml.find("<shape>sphere</shape>"), std::string::npos);
    EXPECT_NE(xml.find("<stages>demosaic color_filter locate_features match triangulate count_2</stages>"),
              std::string::npos);
    EXPECT_NE(xml.find("<demosaic>edge_aware</demosaic>"), std::string::npos);
    EXPECT_NE(xml.find("<centroid>pixel</centroid>"), std::string::npos);
    EXPECT_NE(xml.find("<triangulation>centroid</triangulation>"), std::string::npos);
    EXPECT_EQ(xml.back(), '\n');
}

// The document's Bayer words are common's names (libdc1394 order).
TEST(ConfigRoundTrip, BayerPatternWordsAreCommonNames) {
    for (BayerPattern p : {BayerPattern::BG, BayerPattern::GB, BayerPattern::RG, BayerPattern::GR}) {
        AvatarConfig c = unusualConfig();
        c.camera.bayerPattern = p;
        const std::string xml = writeConfigString(c);
        EXPECT_NE(xml.find("<bayerPattern>" + std::string(toString(p)) + "</bayerPattern>"), std::string::npos);
        EXPECT_EQ(readConfigString(xml).camera.bayerPattern, p);
    }
}

struct Mutation {
    std::string field;
    std::function<void(AvatarConfig&)> apply;
};

/// One valid change per field of the configuration.
std::vector<Mutation> mutations() {
    std::vector<Mutation> m;
    auto add = [&m](std::string field, std::function<void(AvatarConfig&)> f) {
        m.push_back({std::move(field), std::move(f)});
    };
    auto feature = [&add](const std::string& name, CameraFeature CameraFeatureSet::*member) {
        add("camera.features." + name + ".value", [member](AvatarConfig& c) { (c.camera.features.*member).value += 1; });
        add("camera.features." + name + ".auto", [member](AvatarConfig& c) {
            (c.camera.features.*member).automatic = !(c.camera.features.*member).automatic;
        });
    };
    auto range = [&add](const std::string& name, Range TargetType::*member) {
        add("target[1]." + name + ".min", [member](AvatarConfig& c) { (c.targets.targets[0].*member).min *= 0.5; });
        add("target[1]." + name + ".max", [member](AvatarConfig& c) { (c.targets.targets[0].*member).max *= 0.75; });
    };
    auto hsv = [&add](const std::string& name, Range HsvRanges::*member) {
        add("target[1].hsv." + name + ".min", [member](AvatarConfig& c) { (c.targets.targets[0].hsv.*member).min /= 2; });
        add("target[1].hsv." + name + ".max", [member](AvatarConfig& c) { (c.targets.targets[0].hsv.*member).max /= 2; });
    };
    auto intrinsics = [&add](const std::string& side, CameraIntrinsics StereoSystemConfig::*member) {
        for (std::size_t i = 0; i < 2; ++i) {
            add("stereo." + side + ".fc[" + std::to_string(i) + "]",
                [member, i](AvatarConfig& c) { (c.stereo.*member).fc[i] += 0.5; });
            add("stereo." + side + ".cc[" + std::to_string(i) + "]",
                [member, i](AvatarConfig& c) { (c.stereo.*member).cc[i] -= 0.5; });
        }
        add("stereo." + side + ".alphaC", [member](AvatarConfig& c) { (c.stereo.*member).alphaC = 0.25; });
        for (std::size_t i = 0; i < 5; ++i) {
            add("stereo." + side + ".kc[" + std::to_string(i) + "]",
                [member, i](AvatarConfig& c) { (c.stereo.*member).kc[i] += 0.5; });
        }
    };

    add("camera.width", [](AvatarConfig& c) { c.camera.width = 1100; });
    add("camera.height", [](AvatarConfig& c) { c.camera.height = 800; });
    add("camera.bitDepth", [](AvatarConfig& c) { c.camera.bitDepth = 8; });
    add("camera.bayer", [](AvatarConfig& c) { c.camera.bayer = false; });
    add("camera.channels", [](AvatarConfig& c) {
        c.camera.bayer = false;
        c.camera.channels = 3;
    });
    add("camera.bayerPattern", [](AvatarConfig& c) { c.camera.bayerPattern = BayerPattern::RG; });
    add("camera.endianSwap", [](AvatarConfig& c) { c.camera.endianSwap = false; });
    add("camera.leftCameraId", [](AvatarConfig& c) { c.camera.leftCameraId = "left"; });
    add("camera.rightCameraId", [](AvatarConfig& c) { c.camera.rightCameraId = ""; });
    feature("exposure", &CameraFeatureSet::exposure);
    feature("shutter", &CameraFeatureSet::shutter);
    feature("gain", &CameraFeatureSet::gain);
    feature("brightness", &CameraFeatureSet::brightness);
    feature("gamma", &CameraFeatureSet::gamma);
    add("camera.features.whiteBalance.blueU", [](AvatarConfig& c) { c.camera.features.whiteBalance.blueU = 1; });
    add("camera.features.whiteBalance.redV", [](AvatarConfig& c) { c.camera.features.whiteBalance.redV = 2; });
    add("camera.features.whiteBalance.auto",
        [](AvatarConfig& c) { c.camera.features.whiteBalance.automatic = false; });

    add("target[1].name", [](AvatarConfig& c) { c.targets.targets[0].name = "duck_2"; });
    add("target[1].filter", [](AvatarConfig& c) { c.targets.targets[0].filter = ColorFilterMethod::RgbRatio; });
    range("redGreen", &TargetType::redGreen);
    range("redBlue", &TargetType::redBlue);
    range("blueGreen", &TargetType::blueGreen);
    range("area", &TargetType::area);
    range("aspectRatio", &TargetType::aspectRatio);
    range("areaRatio", &TargetType::areaRatio);
    add("target[1].brightness.min", [](AvatarConfig& c) { c.targets.targets[0].brightness->min = 2; });
    add("target[1].brightness.max", [](AvatarConfig& c) { c.targets.targets[0].brightness->max = 3; });
    add("target[1].brightness unset", [](AvatarConfig& c) { c.targets.targets[0].brightness.reset(); });
    add("target[1].sizeMm.min", [](AvatarConfig& c) { c.targets.targets[0].sizeMm->min = 2; });
    add("target[1].sizeMm.max", [](AvatarConfig& c) { c.targets.targets[0].sizeMm->max = 300; });
    add("target[1].sizeMm unset", [](AvatarConfig& c) { c.targets.targets[0].sizeMm.reset(); });
    add("target[2].brightness set", [](AvatarConfig& c) { c.targets.targets[1].brightness = Range{0, 1}; });
    add("target[2].brightnessBands set", [](AvatarConfig& c) {
        c.targets.targets[1].brightnessBands = {BrightnessBand{{0, 90.5}, {1.0 / 3.0, 2}, {0.5, 1e9}, {0, 0.25}},
                                                BrightnessBand{{91, 300}, {1.25, 1.5}, {0.75, 2}, {0.125, 1}}};
    });
    add("target[2].veil set", [](AvatarConfig& c) {
        c.targets.targets[1].veil = Veil{{0.7, 1.0, 0.97}, 0.35, std::nullopt, std::nullopt};
    });
    add("target[2].veil with its own ranges", [](AvatarConfig& c) {
        c.targets.targets[1].veil = Veil{{0.7, 1.0, 0.97}, 0.35, Range{0.125, 0.25}, Range{0.2, 0.3}};
    });
    add("target[2].water set", [](AvatarConfig& c) {
        c.targets.targets[1].water = Water{{0.2, 0.03, 0.08}, 5.0, std::nullopt, std::nullopt};
    });
    add("target[2].water with its own ranges", [](AvatarConfig& c) {
        c.targets.targets[1].water = Water{{0.2, 0.03, 0.08}, 4.5, Range{0.125, 0.25}, Range{0.2, 0.3}};
    });
    hsv("hue", &HsvRanges::hue);
    hsv("saturation", &HsvRanges::saturation);
    hsv("value", &HsvRanges::value);
    add("target[1].erodeRestore", [](AvatarConfig& c) { c.targets.targets[0].erodeRestore = false; });
    add("target[1].erodeKernelSize", [](AvatarConfig& c) { c.targets.targets[0].erodeKernelSize = 31; });
    add("target[1].window.x", [](AvatarConfig& c) { c.targets.targets[0].window.x = 17; });
    add("target[1].window.y", [](AvatarConfig& c) { c.targets.targets[0].window.y = 9; });
    add("target[1].window.width", [](AvatarConfig& c) { c.targets.targets[0].window.width = 999; });
    add("target[1].window.height", [](AvatarConfig& c) { c.targets.targets[0].window.height = 699; });
    add("target[1].shape", [](AvatarConfig& c) { c.targets.targets[0].shape = TargetShape::None; });
    add("target order", [](AvatarConfig& c) { std::swap(c.targets.targets[0], c.targets.targets[1]); });
    add("third target", [](AvatarConfig& c) {
        c.targets.targets.push_back(c.targets.targets[1]);
        c.targets.targets.back().name = "third";
    });

    add("match.method", [](AvatarConfig& c) { c.match.method = MatchMethod::Shape; });
    add("match.repeats", [](AvatarConfig& c) { c.match.repeats = RepeatMatchPolicy::Reassign; });
    add("match.boxDxMin", [](AvatarConfig& c) { c.match.boxDxMin = 37; });
    add("match.boxDxMax", [](AvatarConfig& c) { c.match.boxDxMax = 281; });
    add("match.boxDyMin", [](AvatarConfig& c) { c.match.boxDyMin = -7; });
    add("match.boxDyMax", [](AvatarConfig& c) { c.match.boxDyMax = 7; });
    add("match.maxEpipolarDistancePx", [](AvatarConfig& c) { c.match.maxEpipolarDistancePx = 1.5; });
    add("match.minRangeMm", [](AvatarConfig& c) { c.match.minRangeMm = 400; });
    add("match.maxRangeMm", [](AvatarConfig& c) { c.match.maxRangeMm = 3000; });
    add("match.shape.magnitudeWeight", [](AvatarConfig& c) { c.match.shape.magnitudeWeight = 0; });
    add("match.shape.directionWeight", [](AvatarConfig& c) { c.match.shape.directionWeight = 0; });
    add("match.shape.maxError", [](AvatarConfig& c) { c.match.shape.maxError = 1; });
    add("match.shape.maxAreaRatio", [](AvatarConfig& c) { c.match.shape.maxAreaRatio = 1; });

    intrinsics("left", &StereoSystemConfig::left);
    intrinsics("right", &StereoSystemConfig::right);
    for (std::size_t i = 0; i < 3; ++i) {
        add("stereo.om[" + std::to_string(i) + "]", [i](AvatarConfig& c) { c.stereo.om[i] = -0.125; });
        add("stereo.translationMm[" + std::to_string(i) + "]",
            [i](AvatarConfig& c) { c.stereo.translationMm[i] += 1; });
        add("stereo.baseTVision.translationMm[" + std::to_string(i) + "]",
            [i](AvatarConfig& c) { c.stereo.baseTVision->translationMm[i] += 1; });
    }
    add("stereo.baseTVision.rotation", [](AvatarConfig& c) {
        c.stereo.baseTVision->rotation = {0, 0, 1, 0, 1, 0, -1, 0, 0};  // 90 degrees about y
    });
    add("stereo.baseTVision unset", [](AvatarConfig& c) { c.stereo.baseTVision.reset(); });
    // The calibration's standard errors: every field, starting from one set of them.
    const auto withUncertainty = [](AvatarConfig& c) -> CalibrationUncertainty& {
        if (!c.stereo.uncertainty) {
            CalibrationUncertainty u;
            u.left = {{0.67, 0.68}, {1.13, 1.18}, 0.0, {0.0021, 0.011, 0.0003, 0.0002, 0.0}};
            u.right = {{0.67, 0.69}, {1.22, 1.16}, 0.0, {0.0022, 0.012, 0.0003, 0.0003, 0.0}};
            u.om = {0.001, 0.001, 0.0004};
            u.translationMm = {0.08, 0.07, 0.29};
            c.stereo.uncertainty = u;
        }
        return *c.stereo.uncertainty;
    };
    add("stereo.uncertainty", [withUncertainty](AvatarConfig& c) { withUncertainty(c); });
    for (const auto& [side, member] : {std::pair{"left", &CalibrationUncertainty::left},
                                       std::pair{"right", &CalibrationUncertainty::right}}) {
        for (std::size_t i = 0; i < 2; ++i) {
            add(std::string("stereo.uncertainty.") + side + ".fc[" + std::to_string(i) + "]",
                [=, member = member](AvatarConfig& c) { (withUncertainty(c).*member).fc[i] = 2.5; });
            add(std::string("stereo.uncertainty.") + side + ".cc[" + std::to_string(i) + "]",
                [=, member = member](AvatarConfig& c) { (withUncertainty(c).*member).cc[i] = 3.5; });
        }
        add(std::string("stereo.uncertainty.") + side + ".alphaC",
            [=, member = member](AvatarConfig& c) { (withUncertainty(c).*member).alphaC = 1e-4; });
        for (std::size_t i = 0; i < 5; ++i)
            add(std::string("stereo.uncertainty.") + side + ".kc[" + std::to_string(i) + "]",
                [=, member = member](AvatarConfig& c) { (withUncertainty(c).*member).kc[i] = 0.25; });
    }
    for (std::size_t i = 0; i < 3; ++i) {
        add("stereo.uncertainty.om[" + std::to_string(i) + "]",
            [=](AvatarConfig& c) { withUncertainty(c).om[i] = 0.125; });
        add("stereo.uncertainty.translationMm[" + std::to_string(i) + "]",
            [=](AvatarConfig& c) { withUncertainty(c).translationMm[i] = 1.5; });
    }

    add("lighting.frameAverageEnabled", [](AvatarConfig& c) { c.lighting.frameAverageEnabled = false; });
    for (std::size_t i = 0; i < 3; ++i) {
        add("lighting.gainsRgb[" + std::to_string(i) + "]", [i](AvatarConfig& c) { c.lighting.gainsRgb[i] = 3; });
    }
    add("lighting.patternEnabled", [](AvatarConfig& c) { c.lighting.patternEnabled = false; });
    add("lighting.patternCentrePx[0]", [](AvatarConfig& c) { c.lighting.patternCentrePx[0] = -20; });
    add("lighting.patternCentrePx[1]", [](AvatarConfig& c) { c.lighting.patternCentrePx[1] = 2000; });
    for (auto [name, member] : {std::pair{"red", &LightingConfig::red}, std::pair{"green", &LightingConfig::green},
                                std::pair{"blue", &LightingConfig::blue}}) {
        add(std::string("lighting.") + name + ".coefficient",
            [member = member](AvatarConfig& c) { (c.lighting.*member).coefficient = 0.5; });
        add(std::string("lighting.") + name + ".exponent",
            [member = member](AvatarConfig& c) { (c.lighting.*member).exponent = -0.002; });
    }
    add("lighting.templateImagePath", [](AvatarConfig& c) { c.lighting.templateImagePath = "/abs/t.exr"; });
    add("lighting.templateImagePath unset", [](AvatarConfig& c) { c.lighting.templateImagePath.clear(); });

    add("analysis.stages removed", [](AvatarConfig& c) { c.analysis.stages.pop_back(); });
    add("analysis.stages order", [](AvatarConfig& c) { std::swap(c.analysis.stages[3], c.analysis.stages[5]); });
    add("analysis.stages renamed", [](AvatarConfig& c) { c.analysis.stages[5] = "visibility"; });
    add("analysis.demosaic", [](AvatarConfig& c) { c.analysis.demosaic = DemosaicAlgorithm::Bilinear; });
    add("analysis.centroid", [](AvatarConfig& c) { c.analysis.centroid = CentroidMode::IntensityWeighted; });
    add("analysis.visibility.minContrast", [](AvatarConfig& c) { c.analysis.visibility.minContrast = 0; });
    add("analysis.visibility.maxSaturatedFraction",
        [](AvatarConfig& c) { c.analysis.visibility.maxSaturatedFraction = 1; });
    add("analysis.visibility.maxHaze", [](AvatarConfig& c) { c.analysis.visibility.maxHaze = 0.9; });
    add("analysis.tracking.enabled", [](AvatarConfig& c) { c.analysis.tracking.enabled = true; });
    add("analysis.tracking.fullFrameEvery", [](AvatarConfig& c) { c.analysis.tracking.fullFrameEvery = 7; });
    add("analysis.tracking.marginPx", [](AvatarConfig& c) { c.analysis.tracking.marginPx = 80; });
    add("analysis.coarseToFine.enabled", [](AvatarConfig& c) { c.analysis.coarseToFine.enabled = true; });
    add("analysis.coarseToFine.marginPx", [](AvatarConfig& c) { c.analysis.coarseToFine.marginPx = 24; });
    add("analysis.threads", [](AvatarConfig& c) { c.analysis.threads = 2; });

    // The servo tuning: every field, starting from a section of defaults
    // whose types name the configuration's targets.
    const auto servo = [](AvatarConfig& c) -> ServoConfig& {
        if (!c.servo) {
            c.servo = ServoConfig{};
            c.servo->sampleType = "duck_1";
            c.servo->armType = "arm-Marker";
        }
        return *c.servo;
    };
    add("servo", [servo](AvatarConfig& c) { servo(c); });
    add("servo.sampleType swapped with armType", [servo](AvatarConfig& c) {
        servo(c).sampleType = "arm-Marker";
        servo(c).armType = "duck_1";
    });
    add("servo.mode", [servo](AvatarConfig& c) { servo(c).mode = ServoMode::Hybrid; });
    add("servo.mode dead_reckoning", [servo](AvatarConfig& c) { servo(c).mode = ServoMode::DeadReckoning; });
    add("servo.filter", [servo](AvatarConfig& c) { servo(c).filter = ServoFilter::Kalman; });
    add("servo.maxMoveMm", [servo](AvatarConfig& c) { servo(c).maxMoveMm = 1.0 / 3.0 + 50; });
    add("servo.finalDistanceMm", [servo](AvatarConfig& c) { servo(c).finalDistanceMm = 7.25; });
    for (std::size_t i = 0; i < 3; ++i)
        add("servo.toolOffsetMm[" + std::to_string(i) + "]",
            [servo, i](AvatarConfig& c) { servo(c).toolOffsetMm[i] = -0.0 - 12.5 * (i + 1); });
    add("servo.armToleranceMm", [servo](AvatarConfig& c) { servo(c).armToleranceMm = 75; });
    add("servo.armDriftMm", [servo](AvatarConfig& c) { servo(c).armDriftMm = 0; });
    add("servo.armDriftPerMm", [servo](AvatarConfig& c) { servo(c).armDriftPerMm = 0.125; });
    add("servo.maxTargetJumpMm", [servo](AvatarConfig& c) { servo(c).maxTargetJumpMm = 33; });
    add("servo.trackingRadiusMm", [servo](AvatarConfig& c) { servo(c).trackingRadiusMm = 90; });
    add("servo.visionTimeoutMs", [servo](AvatarConfig& c) { servo(c).visionTimeoutMs = 1; });
    add("servo.moveTimeoutMs", [servo](AvatarConfig& c) { servo(c).moveTimeoutMs = 600000; });
    add("servo.lostTimeoutMs", [servo](AvatarConfig& c) { servo(c).lostTimeoutMs = 1234; });
    add("servo.maxIterations", [servo](AvatarConfig& c) { servo(c).maxIterations = 20; });
    add("servo.refineRegistration", [servo](AvatarConfig& c) { servo(c).refineRegistration = false; });
    add("servo.probeAngleDeg", [servo](AvatarConfig& c) { servo(c).probeAngleDeg = 0; });
    add("servo.registrationStdDeg", [servo](AvatarConfig& c) { servo(c).registrationStdDeg = 0.5; });
    add("servo.kalman.sampleNoiseMm", [servo](AvatarConfig& c) { servo(c).kalmanSampleNoiseMm = 0; });
    add("servo.kalman.armNoisePerMm", [servo](AvatarConfig& c) { servo(c).kalmanArmNoisePerMm = 0.5; });
    add("servo.kalman.defaultSigmaMm", [servo](AvatarConfig& c) { servo(c).kalmanDefaultSigmaMm = 0.75; });
    return m;
}

// Each field on its own: the change is visible to operator== (so the
// comparisons above cover it), reaches the XML text and reads back.
TEST(ConfigRoundTrip, EveryFieldOnItsOwn) {
    const AvatarConfig base = unusualConfig();
    const std::string baseXml = writeConfigString(base);
    const std::vector<Mutation> all = mutations();
    EXPECT_GE(all.size(), 100u);
    for (const Mutation& mutation : all) {
        SCOPED_TRACE(mutation.field);
        AvatarConfig changed = base;
        mutation.apply(changed);
        EXPECT_FALSE(changed == base);
        std::string xml;
        ASSERT_NO_THROW(xml = writeConfigString(changed));
        EXPECT_NE(xml, baseXml);
        const AvatarConfig back = readConfigString(xml);
        EXPECT_TRUE(back == changed);
        EXPECT_EQ(writeConfigString(back), xml);
    }
}

}  // namespace
}  // namespace avatar
