// Documents that are accepted: defaults of optional parts, free order, comments, white space.

#include <avatar/config/ConfigXml.h>

#include <gtest/gtest.h>

#include <array>
#include <string>

namespace avatar {
namespace {

// Only what is required.
const std::string kMinimal = R"(<avatar version="1">
  <camera>
    <width>640</width><height>480</height><bitDepth>8</bitDepth><channels>3</channels>
    <bayer>false</bayer>
  </camera>
  <targets>
    <target name="t">
      <redGreen><min>1</min><max>2</max></redGreen>
      <redBlue><min>1</min><max>2</max></redBlue>
      <blueGreen><min>0</min><max>1</max></blueGreen>
    </target>
  </targets>
  <match><method>shape</method></match>
  <stereo>
    <left><fc>800 801</fc><cc>320 240</cc></left>
    <right><fc>802 803</fc><cc>321 241</cc></right>
    <om>0 0 0</om>
    <translationMm>-120 0 0</translationMm>
  </stereo>
</avatar>)";

TEST(ConfigRead, MinimalDocumentTakesTheDefaults) {
    const AvatarConfig c = readConfigString(kMinimal);
    const AvatarConfig defaults;
    const TargetType defaultTarget;

    EXPECT_EQ(c.camera.width, 640);
    EXPECT_EQ(c.camera.channels, 3);
    EXPECT_FALSE(c.camera.bayer);
    EXPECT_EQ(c.camera.bayerPattern, defaults.camera.bayerPattern);
    EXPECT_EQ(c.camera.endianSwap, false);
    EXPECT_EQ(c.camera.leftCameraId, "");
    EXPECT_TRUE(c.camera.features == CameraFeatureSet{});

    ASSERT_EQ(c.targets.targets.size(), 1u);
    const TargetType& t = c.targets.targets[0];
    EXPECT_EQ(t.filter, ColorFilterMethod::RgbRatio);
    EXPECT_EQ(t.redGreen, (Range{1, 2}));
    EXPECT_FALSE(t.brightness.has_value());
    EXPECT_TRUE(t.hsv == defaultTarget.hsv);
    EXPECT_EQ(t.erodeRestore, false);
    EXPECT_EQ(t.erodeKernelSize, 3);
    EXPECT_EQ(t.area, defaultTarget.area);
    EXPECT_EQ(t.aspectRatio, defaultTarget.aspectRatio);
    EXPECT_EQ(t.areaRatio, defaultTarget.areaRatio);
    EXPECT_TRUE(t.window.wholeImage());

    EXPECT_EQ(c.match.method, MatchMethod::Shape);
    MatchConfig expectedMatch;
    expectedMatch.method = MatchMethod::Shape;
    EXPECT_TRUE(c.match == expectedMatch);

    EXPECT_EQ(c.stereo.left.alphaC, 0.0);
    EXPECT_EQ(c.stereo.left.kc, (std::array<double, 5>{0, 0, 0, 0, 0}));
    EXPECT_EQ(c.stereo.right.fc, (std::array<double, 2>{802, 803}));
    EXPECT_FALSE(c.stereo.baseTVision.has_value());
    EXPECT_TRUE(c.lighting == LightingConfig{});
    EXPECT_EQ(t.shape, TargetShape::None);
    EXPECT_TRUE(c.analysis == AnalysisConfig{});
}

TEST(ConfigRead, OrderCommentsAndWhiteSpaceDoNotMatter) {
    const std::string doc = R"(<?xml version="1.0" encoding="UTF-8"?>
<!-- leading comment -->
<avatar version="1">
  <stereo>
    <translationMm>
        -120   0
        0
    </translationMm>
    <om>0 0 0</om>
    <right><cc>321 241</cc><fc>802 803</fc></right>
    <left><cc>320 240</cc><fc>800 801</fc></left>
  </stereo>
  <match><!-- c --><method> shape </method></match>
  <targets>
    <!-- c -->
    <target name="t">
      <blueGreen><max>1</max><min>0</min></blueGreen>
      <redBlue><min>1</min><max>2</max></redBlue>
      <redGreen><min>1</min><max><!-- c -->2</max></redGreen>
    </target>
  </targets>
  <camera>
    <bayer>false</bayer><channels>3</channels><bitDepth>8</bitDepth>
    <height>
      480
    </height>
    <width>640</width>
  </camera>
</avatar>
<!-- trailing comment -->
)";
    EXPECT_TRUE(readConfigString(doc) == readConfigString(kMinimal));
}

TEST(ConfigRead, ConditionalElementsAreOptionalOtherwise) {
    // An hsv target needs no ratio ranges; a pattern with a template image needs
    // no falloff channels; a disabled frame average needs no gains.
    std::string doc = kMinimal;
    doc.replace(doc.find("<redGreen>"), doc.find("</target>") - doc.find("<redGreen>"),
                "<filter>hsv</filter><hsv><hue><min>340</min><max>20</max></hue>"
                "<saturation><min>0.5</min><max>1</max></saturation><value><min>0.2</min><max>1</max></value></hsv>");
    doc.replace(doc.find("</avatar>"), 9,
                "<lighting><frameAverage><enabled>false</enabled></frameAverage>"
                "<pattern><enabled>true</enabled><templateImage>strobe.exr</templateImage></pattern></lighting>"
                "</avatar>");
    const AvatarConfig c = readConfigString(doc);
    const TargetType& t = c.targets.targets.at(0);
    EXPECT_EQ(t.filter, ColorFilterMethod::Hsv);
    EXPECT_EQ(t.hsv.hue, (Range{340, 20}));  // wraps through 0
    EXPECT_EQ(t.redGreen, TargetType{}.redGreen);
    EXPECT_TRUE(c.lighting.patternEnabled);
    EXPECT_EQ(c.lighting.templateImagePath, "strobe.exr");
    EXPECT_EQ(c.lighting.red, FalloffChannel{});
    EXPECT_FALSE(c.lighting.frameAverageEnabled);
}

TEST(ConfigRead, EntitiesAndCdataInText) {
    std::string doc = kMinimal;
    doc.replace(doc.find("<bayer>"), 0,
                "<leftCameraId>a&amp;b &lt;1&gt;</leftCameraId><rightCameraId><![CDATA[x<y]]></rightCameraId>");
    const AvatarConfig c = readConfigString(doc);
    EXPECT_EQ(c.camera.leftCameraId, "a&b <1>");
    EXPECT_EQ(c.camera.rightCameraId, "x<y");
}

TEST(ConfigRead, NumberForms) {
    std::string doc = kMinimal;
    doc.replace(doc.find("<om>0 0 0</om>"), 14, "<om>1e-3 -.5 2.5E-1</om>");
    EXPECT_EQ(readConfigString(doc).stereo.om, (std::array<double, 3>{0.001, -0.5, 0.25}));
    for (const char* bad : {"0x10", "+1", "1,5", "inf", "1e", "--1"}) {
        SCOPED_TRACE(bad);
        std::string d = kMinimal;
        d.replace(d.find("<om>0 0 0</om>"), 14, std::string("<om>0 0 ") + bad + "</om>");
        EXPECT_THROW(readConfigString(d), ConfigError);
    }
}

}  // namespace
}  // namespace avatar
