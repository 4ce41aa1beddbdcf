// The site's water (TargetConfig.h, Water) on a rendered scene: an orange
// sphere 2.2 m away under blue-green water that absorbs red first, so its
// R/G falls from 2.3 to about 1.0, far below its clear colour's ranges.
// Without the water the filter loses it; with it the sphere is found whole
// and placed where it is (1.0-1.4 mm off over three render seeds), and a
// green sphere (found whole as green, through green's water) and the seabed
// seen through the same water are not taken for orange.
#include <avatar/analyze/AnalyzeStereoImagePair.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>

#include <gtest/gtest.h>

#include <string>

namespace avatar {
namespace {

const cv::Point3d kOrangeMm(60.0, -40.0, 2200.0);
const cv::Point3d kGreenMm(-150.0, 60.0, 1200.0);
/// Below the far orange's B/G (0.095 with render seed 3), within the type
/// margin (0.1 in log) of it.
constexpr double kYellowBlueGreenMax = 0.088;

render::TargetSpec sphere(const std::string& name, const std::string& type, const cv::Point3d& centre,
                          const render::Rgb& albedo) {
    render::TargetSpec t;
    t.name = name;
    t.type = type;
    t.shape = render::Shape::Sphere;
    t.centreMm = {centre.x, centre.y, centre.z};
    t.radiusMm = 40.0;
    t.albedo = albedo;
    return t;
}

render::Scene underWater() {
    render::Scene s = render::readSceneFile(std::string(AVATAR_DATA_DIR) + "/scenes/lab.xml");
    s.targets = {sphere("far", "orange", kOrangeMm, {0.95, 0.42, 0.05}),
                 sphere("near", "green", kGreenMm, {0.12, 0.6, 0.15})};
    s.armMarkers.clear();
    s.occluders.clear();
    s.seabed.distanceMm = 2600.0;
    s.seabed.tiltDeg = 10.0;
    // The scene sets' murkier water (acquire/simulation/SceneSet.cpp).
    s.lighting.attenuationPerM = {0.28, 0.03, 0.1};
    s.lighting.ambient[0] *= 0.6;
    s.lighting.background = {0.0, 0.02, 0.03};
    return s;
}

/// scorpion.xml with two sphere types, their ranges those of the colours in
/// clear water, each with the site's water when @p water.
AvatarConfig config(bool water) {
    AvatarConfig c = readConfigFile(std::string(AVATAR_DATA_DIR) + "/config/scorpion.xml");
    TargetType orange = c.targets.targets[0];
    orange.name = "orange";
    orange.redGreen = {1.9, 2.7};
    orange.redBlue = {0.0, 1e9};
    orange.blueGreen = {0.09, 0.15};
    orange.shape = TargetShape::Sphere;
    orange.area = {150.0, 400000.0};
    if (water) orange.water = Water{{0.3, 0.03, 0.12}, 5.0, std::nullopt, std::nullopt};
    TargetType green = orange;
    green.name = "green";
    green.redGreen = {0.13, 0.3};
    green.blueGreen = {0.18, 0.3};
    c.targets.targets = {orange, green};
    validateConfig(c);
    return c;
}

/// The water scene (render seed @p seed) analysed with @p c.
VisionTargets analyse(const AvatarConfig& c, std::uint64_t seed = 3) {
    render::RenderOptions options;
    options.seed = seed;
    const render::RenderResult r = render::render(underWater(), c.stereo, options);
    AnalyzeStereoImagePair analysis(c);
    return analysis.analyze(r.pair, 1);
}

VisionTargets analyse(bool water, std::uint64_t seed = 3) { return analyse(config(water), seed); }

TEST(WaterScene, WithoutTheWaterTheFarOrangeSphereIsNotWhole) {
    for (const VisionTarget& v : analyse(false).targets) {
        if (v.type == "orange") {
            EXPECT_FALSE(v.flags & kTargetWhole) << v.flags;
        }
    }
}

TEST(WaterScene, WithTheWaterItIsWholeWhereItIsAndNothingElseIsOrange) {
    for (const std::uint64_t seed : {3, 4, 5}) {
        SCOPED_TRACE(seed);
        int orange = 0, green = 0;
        for (const VisionTarget& v : analyse(true, seed).targets) {
            green += v.type == "green" && (v.flags & kTargetWhole) && v.positionVisionMm &&
                     cv::norm(*v.positionVisionMm - kGreenMm) < 3.0;
            if (v.type != "orange" || !(v.flags & kTargetStereo)) continue;
            ++orange;
            EXPECT_TRUE(v.flags & kTargetWhole) << v.flags;
            EXPECT_EQ(v.model, ShapeModel::Sphere);
            ASSERT_TRUE(v.positionVisionMm);
            EXPECT_LT(cv::norm(*v.positionVisionMm - kOrangeMm), 3.0)
                << v.positionVisionMm->x << " " << v.positionVisionMm->y << " " << v.positionVisionMm->z;
        }
        EXPECT_EQ(orange, 1);
        EXPECT_EQ(green, 1);
    }
}

// A type's trained ranges may take in what no target of it looks like
// (yellow's, trained on ducks with their orange beaks, reach R/G 2.8 in the
// trust report): the far orange's mean colour lies within the type margin
// of such a "yellow" box, in B/G alone, and was ambiguous. Named for the
// colour its water acts on (its clear colour), yellow's targets cannot
// look so through any of the site's water: the orange is decided, whole.
AvatarConfig withYellow(bool clearColour) {
    AvatarConfig c = config(true);
    TargetType yellow = c.targets.targets[0];
    yellow.name = "yellow";
    yellow.redGreen = {0.1, 2.9};
    yellow.blueGreen = {0.033, kYellowBlueGreenMax};
    yellow.water = Water{{0.3, 0.03, 0.12}, 5.0, std::nullopt, std::nullopt};
    if (clearColour) {
        yellow.water->redGreen = Range{1.15, 1.42};
        yellow.water->blueGreen = Range{0.05, 0.062};
    }
    c.targets.targets.push_back(yellow);
    validateConfig(c);
    return c;
}

TEST(WaterScene, AColourNoTargetOfAnotherTypeCanHaveThroughTheWaterIsNotAmbiguous) {
    for (const bool clearColour : {false, true}) {
        SCOPED_TRACE(clearColour ? "yellow's clear colour named" : "yellow's ranges alone");
        int orange = 0;
        for (const VisionTarget& v : analyse(withYellow(clearColour)).targets) {
            if (v.type != "orange" || !(v.flags & kTargetStereo)) continue;
            ++orange;
            ASSERT_TRUE(v.positionVisionMm);
            EXPECT_LT(cv::norm(*v.positionVisionMm - kOrangeMm), 3.0);
            EXPECT_EQ(bool(v.flags & kTargetAmbiguous), !clearColour) << v.flags;
            EXPECT_EQ(bool(v.flags & kTargetWhole), clearColour) << v.flags;
        }
        EXPECT_EQ(orange, 1);
    }
}

}  // namespace
}  // namespace avatar
