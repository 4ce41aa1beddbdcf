// The haze's veil (TargetConfig.h, Veil) on a rendered scene: a green sphere
// 1 m away in haze whose backscatter moves its colour out of its clear
// colour's ranges. Without the veil the filter loses it; with it the sphere
// is found whole and placed where it is (0.35-0.45 mm off over three render
// seeds), and the hazy seabed is not taken.
#include <avatar/analyze/AnalyzeStereoImagePair.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>

#include <gtest/gtest.h>

#include <string>

namespace avatar {
namespace {

constexpr double kRadiusMm = 30.0;
const cv::Point3d kCentreMm(40.0, -30.0, 1000.0);

render::Scene hazyGreenSphere() {
    render::Scene s = render::readSceneFile(std::string(AVATAR_DATA_DIR) + "/scenes/lab.xml");
    s.targets.clear();
    s.armMarkers.clear();
    s.occluders.clear();
    s.seabed.distanceMm = 2500.0;
    s.seabed.tiltDeg = 10.0;
    render::TargetSpec t;
    t.name = "ball";
    t.type = "green";
    t.shape = render::Shape::Sphere;
    t.centreMm = {kCentreMm.x, kCentreMm.y, kCentreMm.z};
    t.radiusMm = kRadiusMm;
    t.albedo = {0.12, 0.6, 0.15};
    s.targets.push_back(t);
    // The scene sets' haze (acquire/simulation/SceneSet.cpp): backscatter
    // 0.7 : 1 : 1, here strong enough to take the sphere's B/G from 0.25 to
    // about 0.35.
    s.lighting.backscatter = {0.105, 0.15, 0.15};
    s.lighting.turbidityPerM = 0.4;
    return s;
}

/// scorpion.xml with one type: green spheres, its ranges those of the
/// colour in clear water.
AvatarConfig greenConfig(bool veil) {
    AvatarConfig c = readConfigFile(std::string(AVATAR_DATA_DIR) + "/config/scorpion.xml");
    TargetType green = c.targets.targets[0];
    green.name = "green";
    green.redGreen = {0.13, 0.3};
    green.redBlue = {0.0, 1e9};
    green.blueGreen = {0.18, 0.3};
    green.shape = TargetShape::Sphere;
    green.area = {150.0, 400000.0};
    if (veil) green.veil = Veil{{0.7, 1.0, 1.0}, 0.35, std::nullopt, std::nullopt};
    c.targets.targets = {green};
    return c;
}

VisionTargets analyse(bool veil) {
    const AvatarConfig config = greenConfig(veil);
    render::RenderOptions options;
    options.seed = 3;
    const render::RenderResult r = render::render(hazyGreenSphere(), config.stereo, options);
    AnalyzeStereoImagePair analysis(config);
    return analysis.analyze(r.pair, 1);
}

TEST(VeilScene, WithoutTheVeilTheHazySphereIsNotWhole) {
    for (const VisionTarget& v : analyse(false).targets) EXPECT_FALSE(v.flags & kTargetWhole);
}

TEST(VeilScene, WithTheVeilItIsWholeWhereItIsAndNothingElseIsReported) {
    const VisionTargets result = analyse(true);
    int stereo = 0;
    for (const VisionTarget& v : result.targets) {
        if (!(v.flags & kTargetStereo)) continue;
        ++stereo;
        EXPECT_TRUE(v.flags & kTargetWhole) << v.flags;
        EXPECT_EQ(v.model, ShapeModel::Sphere);
        ASSERT_TRUE(v.positionVisionMm);
        EXPECT_LT(cv::norm(*v.positionVisionMm - kCentreMm), 1.0)
            << v.positionVisionMm->x << " " << v.positionVisionMm->y << " " << v.positionVisionMm->z;
    }
    EXPECT_EQ(stereo, 1);
}

}  // namespace
}  // namespace avatar
