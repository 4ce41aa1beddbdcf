#include "RenderFixtures.h"

#include <avatar/common/Error.h>

#include <gtest/gtest.h>

#include <filesystem>

namespace avatar {
namespace {

using render::SceneError;

/// The SceneError of reading @p body inside <scene>.
SceneError errorOf(const std::string& body) {
    try {
        render::readSceneString("<scene name=\"t\">\n" + body + "\n</scene>\n", "t.xml");
    } catch (const SceneError& e) {
        return e;
    }
    ADD_FAILURE() << "no error for: " << body;
    return SceneError("", 0, "", "");
}

TEST(SceneFile, ReadsEveryElement) {
    const std::string xml = R"(<?xml version="1.0"?>
<scene name="all">
  <seabed distanceMm="1800" tiltDeg="30" albedo="0.5 0.45 0.35" textureContrast="0.2"
          textureScaleMm="25" textureSeed="9"/>
  <lighting ambient="0.1 0.1 0.1" lightIntensity="0.8 0.8 0.8" lightPositionMm="0 -50 0"
            inverseSquare="true" referenceDistanceMm="900" darknessFactor="0.2"/>
  <strobe centrePx="640 480"><red coefficient="1" exponent="-0.002"/><blue exponent="-0.001"/></strobe>
  <water attenuationPerM="0.5 0.12 0.08" background="0 0.01 0.02" backscatter="0.05 0.2 0.25" turbidityPerM="0.4"/>
  <sensor exposure="1.2" readNoiseDn="3" shotNoise="true" fullWellElectrons="15000" blackLevelDn="64"/>
  <registration om="0 1.5707963267948966 0" translationMm="100 0 0"/>
  <target name="duck" shape="duck" centreMm="0 0 900" radiusMm="40" albedo="0.9 0.8 0.1" om="0 0.3 0"/>
  <target name="sd" type="sanddollar" shape="disc" centreMm="100 50 1200" radiusMm="35"
          normal="0 -0.5 -0.87" albedo="0.6 0.55 0.4"/>
  <target name="cube" shape="box" centreMm="-100 0 1000" halfSizeMm="10 20 30" albedo="1 0 0"/>
  <armMarker name="ieem" positionBaseMm="0 0 500" omBase="0 0 0.1" halfSizeMm="20 15 10"/>
  <occluder shape="box" centreMm="0 100 700" halfSizeMm="30 30 30" om="0.1 0 0"/>
  <occluder centreMm="0 -100 700" radiusMm="25" albedo="0.3 0.3 0.3"/>
  <checkerboard squaresX="8" squaresY="6" squareMm="25" om="0 0 0" positionMm="0 0 1000"/>
</scene>)";
    const render::Scene s = render::readSceneString(xml, "all.xml");
    EXPECT_EQ(s.name, "all");
    EXPECT_EQ(s.seabed.tiltDeg, 30.0);
    EXPECT_EQ(s.seabed.textureSeed, 9u);
    EXPECT_TRUE(s.lighting.inverseSquare);
    EXPECT_EQ(s.lighting.darknessFactor, 0.2);
    EXPECT_TRUE(s.lighting.strobe.enabled);
    EXPECT_EQ(s.lighting.strobe.rgb[0].exponent, -0.002);
    EXPECT_EQ(s.lighting.strobe.rgb[1].exponent, 0.0);
    EXPECT_EQ(s.lighting.strobe.rgb[2].exponent, -0.001);
    EXPECT_EQ(s.lighting.attenuationPerM[0], 0.5);
    EXPECT_EQ(s.lighting.backscatter[2], 0.25);
    EXPECT_EQ(s.lighting.turbidityPerM, 0.4);
    EXPECT_EQ(s.sensor.blackLevelDn, 64.0);
    ASSERT_TRUE(s.baseTVision);
    EXPECT_NEAR(s.baseTVision->rotation[2], 1.0, 1e-15);
    ASSERT_EQ(s.targets.size(), 3u);
    EXPECT_EQ(s.targets[0].type, "sample");
    EXPECT_EQ(s.targets[1].type, "sanddollar");
    EXPECT_EQ(s.targets[1].shape, render::Shape::Disc);
    EXPECT_EQ(s.targets[2].halfSizeMm, cv::Vec3d(10, 20, 30));
    ASSERT_EQ(s.armMarkers.size(), 1u);
    EXPECT_EQ(s.armMarkers[0].name, "ieem");
    ASSERT_EQ(s.occluders.size(), 2u);
    EXPECT_EQ(s.occluders[1].shape, render::Shape::Sphere);
    ASSERT_TRUE(s.checkerboard);
    EXPECT_EQ(s.checkerboard->squaresX, 8);

    // Writing and reading back gives the same document.
    const std::string written = render::writeSceneString(s);
    EXPECT_EQ(render::writeSceneString(render::readSceneString(written)), written);
}

TEST(SceneFile, ErrorsNameFileLineElementAndValue) {
    EXPECT_STREQ(errorOf(R"(<target shape="sphere" centreMm="0 0 1" radiusMm="-3" albedo="1 1 1"/>)").what(),
                 "t.xml:2: /scene/target[1]@radiusMm: expected a number > 0, got '-3'");
    EXPECT_STREQ(errorOf("<seabed distanceMm=\"abc\"/>").what(),
                 "t.xml:2: /scene/seabed@distanceMm: expected a number, got 'abc'");
    EXPECT_STREQ(errorOf("<seabed tiltDeg=\"85\"/>").what(),
                 "t.xml:2: /scene/seabed@tiltDeg: expected a number in [-80, 80], got '85'");
    const SceneError missing = errorOf("<target shape=\"sphere\" radiusMm=\"3\" albedo=\"1 1 1\"/>");
    EXPECT_EQ(missing.elementPath(), "/scene/target[1]@centreMm");
    EXPECT_EQ(missing.problem(), "missing required attribute");
    EXPECT_EQ(errorOf("<lighting ambiant=\"1 1 1\"/>").elementPath(), "/scene/lighting@ambiant");
    EXPECT_EQ(errorOf("<light/>").problem().rfind("unknown element", 0), 0u);
    EXPECT_EQ(errorOf("<seabed/>\n<seabed/>").line(), 3);
    EXPECT_EQ(errorOf(R"(<target shape="cone" centreMm="0 0 1" radiusMm="3" albedo="1 1 1"/>)").problem(),
              "expected sphere, disc, duck or box, got 'cone'");
    EXPECT_EQ(errorOf(R"(<target shape="sphere" centreMm="0 0 1" radiusMm="3" albedo="1 2 1"/>)").problem(),
              "expected three numbers in [0, 1], got '1 2 1'");
    EXPECT_EQ(errorOf(R"(<target shape="sphere" centreMm="0 0" radiusMm="3" albedo="1 1 1"/>)").problem(),
              "expected 3 numbers, got '0 0'");
    const SceneError strobe = errorOf("<strobe>\n<green exponent=\"0.01\"/>\n</strobe>");
    EXPECT_EQ(strobe.elementPath(), "/scene/strobe/green@exponent");
    EXPECT_EQ(strobe.line(), 3);
    EXPECT_NE(strobe.problem().find("must be <= 0"), std::string::npos);
    EXPECT_EQ(errorOf(R"(<target name="a" shape="sphere" centreMm="0 0 1" radiusMm="3" albedo="1 1 1"/>
<target name="a" shape="sphere" centreMm="0 0 1" radiusMm="3" albedo="1 1 1"/>)").problem(),
              "duplicate target name 'a'");
    EXPECT_EQ(errorOf(R"(<registration translationMm="0 0 0"/>)").problem(),
              "give exactly one of om (Rodrigues vector, rad) and rotation (9 numbers)");
    EXPECT_EQ(errorOf("<sensor shotNoise=\"yes\"/>").problem(), "expected true or false, got 'yes'");
    const SceneError malformed = errorOf("<seabed>");
    EXPECT_EQ(malformed.problem().rfind("malformed XML", 0), 0u);
}

TEST(SceneFile, MissingFileIsAnIoError) {
    EXPECT_THROW(render::readSceneFile("/nonexistent/scene.xml"), IoError);
}

TEST(SceneFile, ValidateSceneBuiltInCode) {
    render::Scene s;
    s.lighting.attenuationPerM = {-1.0, 0.0, 0.0};
    try {
        render::validateScene(s);
        FAIL() << "no error";
    } catch (const SceneError& e) {
        EXPECT_STREQ(e.what(), "<memory>:0: /scene/water@attenuationPerM: expected three numbers in "
                               "[0, 1000], got '-1 0 0'");
    }
}

TEST(SceneFile, StandardEvaluationScenesLoad) {
    const std::filesystem::path dir = std::filesystem::path(AVATAR_DATA_DIR) / "scenes";
    for (const char* name : {"lab.xml", "darklab.xml", "seabed.xml"}) {
        const render::Scene s = render::readSceneFile(dir / name);
        EXPECT_FALSE(s.targets.empty()) << name;
    }
}

}  // namespace
}  // namespace avatar
