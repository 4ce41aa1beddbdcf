// The visibility verdict (thesis 3.6.1) on rendered scenes: the lab scene in
// clear water, in haze (backscatter and turbidity) and in silt (particles in
// front of everything, with haze): the verdict, its reason and the flag every
// target then carries.
#include <avatar/analyze/AnalyzeStereoImagePair.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>

#include <gtest/gtest.h>

#include <string>

namespace avatar {
namespace {

struct Seen {
    VisionTargets result;
    int stereo{0}, flaggedPoor{0};
};

Seen analyse(const render::Scene& scene) {
    const AvatarConfig config = readConfigFile(std::string(AVATAR_DATA_DIR) + "/config/scorpion.xml");
    render::RenderOptions options;
    options.seed = 5;
    const render::RenderResult r = render::render(scene, config.stereo, options);
    AnalyzeStereoImagePair analysis(config);
    Seen s{analysis.analyze(r.pair, 1)};
    for (const VisionTarget& v : s.result.targets) {
        s.stereo += (v.flags & kTargetStereo) != 0;
        s.flaggedPoor += (v.flags & kTargetPoorVisibility) != 0;
    }
    return s;
}

render::Scene lab() { return render::readSceneFile(std::string(AVATAR_DATA_DIR) + "/scenes/lab.xml"); }

/// Grey water between the camera and everything: 0.5 of full light scattered
/// back at 1.6 per metre (the lab's targets at 0.6-0.8 m keep a third of
/// their light).
void addHaze(render::Scene& s) {
    s.lighting.backscatter = {0.45, 0.5, 0.5};
    s.lighting.turbidityPerM = 1.6;
}

TEST(VisibilityScenes, ClearLabIsGoodAndItsTargetsAreNotFlagged) {
    const Seen s = analyse(lab());
    EXPECT_EQ(s.result.visibility, Visibility::Good) << s.result.visibilityReason;
    EXPECT_EQ(s.stereo, 2);
    EXPECT_EQ(s.flaggedPoor, 0);
}

TEST(VisibilityScenes, HazeIsPoorAndEveryTargetSaysSo) {
    render::Scene s = lab();
    addHaze(s);
    const Seen seen = analyse(s);
    EXPECT_EQ(seen.result.visibility, Visibility::Poor);
    // The veil flattens the image before it lifts its dark channel to the
    // haze limit: contrast 0.012 against the limit 0.02 in both images.
    EXPECT_NE(seen.result.visibilityReason.find("left: contrast"), std::string::npos) << seen.result.visibilityReason;
    EXPECT_NE(seen.result.visibilityReason.find("right: contrast"), std::string::npos) << seen.result.visibilityReason;
    EXPECT_EQ(seen.flaggedPoor, static_cast<int>(seen.result.targets.size()));
    for (const VisionTarget& v : seen.result.targets) EXPECT_TRUE(v.flags & kTargetPoorVisibility);
}

TEST(VisibilityScenes, SiltInHazeIsPoor) {
    render::Scene s = lab();
    addHaze(s);
    // 150 bright particles of 1-3 mm between 0.15 and 0.6 m.
    for (int k = 0; k < 150; ++k) {
        render::Occluder o;
        o.name = "silt" + std::to_string(k + 1);
        o.radiusMm = 1.0 + (k % 5) * 0.5;
        const double z = 150.0 + (k * 37 % 450);
        o.centreMm = {((k * 53) % 200 - 100) / 100.0 * 0.55 * z, ((k * 71) % 200 - 100) / 100.0 * 0.42 * z, z};
        o.albedo = {0.8, 0.8, 0.76};
        s.occluders.push_back(o);
    }
    const Seen seen = analyse(s);
    EXPECT_EQ(seen.result.visibility, Visibility::Poor) << seen.result.visibilityReason;
    for (const VisionTarget& v : seen.result.targets) EXPECT_TRUE(v.flags & kTargetPoorVisibility);
}

}  // namespace
}  // namespace avatar
