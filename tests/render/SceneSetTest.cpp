#include "RenderFixtures.h"

#include <avatar/common/CameraModel.h>
#include <avatar/common/Error.h>
#include <avatar/render/SceneSet.h>

#include <gtest/gtest.h>

namespace avatar {
namespace {

TEST(SceneSet, DeterministicValidAndStablePerIndex) {
    render::SceneSetSpec spec;
    spec.count = 20;
    spec.seed = 7;
    const render::SensorFormat sensor;
    const auto a = render::makeSceneSet(spec, test::scorpion(), sensor);
    const auto b = render::makeSceneSet(spec, test::scorpion(), sensor);
    ASSERT_EQ(a.size(), 20u);
    spec.count = 3;
    const auto c = render::makeSceneSet(spec, test::scorpion(), sensor);
    int occluded = 0, distractors = 0, nearBorder = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        const std::string text = render::writeSceneString(a[i]);
        EXPECT_EQ(text, render::writeSceneString(b[i]));
        if (i < c.size()) {
            EXPECT_EQ(text, render::writeSceneString(c[i]));
        }
        // Every generated scene survives the file format.
        EXPECT_EQ(render::writeSceneString(render::readSceneString(text)), text);
        EXPECT_GE(a[i].targets.size(), 1u);
        EXPECT_LE(a[i].targets.size(), 8u + 3u);  // plus a border target and a touching pair
        for (const auto& o : a[i].occluders) {
            occluded += o.name.rfind("occluder_", 0) == 0;
            distractors += o.name.rfind("distractor_", 0) == 0;
        }
        for (const auto& t : a[i].targets) {
            const double range = cv::norm(t.centreMm);
            EXPECT_GE(range, 500.0 - 1e-9);
            EXPECT_LE(range, 2500.0 + 100.0);  // a touching partner may sit a little further
            const auto px = projectPoint(test::scorpion().left, {t.centreMm[0], t.centreMm[1], t.centreMm[2]});
            ASSERT_TRUE(px);
            nearBorder += px->x < 25.5 || px->y < 25.5 || px->x > 1254 || px->y > 934;
        }
    }
    EXPECT_GT(occluded, 0);
    EXPECT_GT(distractors, 0);
    EXPECT_GT(nearBorder, 0);
    spec.seed = 8;
    EXPECT_NE(render::writeSceneString(render::makeSceneSet(spec, test::scorpion(), sensor)[0]),
              render::writeSceneString(c[0]));
}

TEST(SceneSet, OneCameraOcclusionIsReported) {
    // A scene-set occluder hides part of its target in one camera only.
    render::SceneSetSpec spec;
    spec.count = 1;
    spec.minTargets = spec.maxTargets = 1;
    spec.occludedInOneCameraProbability = 1.0;
    spec.nearBorderProbability = spec.touchingProbability = spec.distractorProbability = 0.0;
    spec.seed = 3;
    render::Scene scene = render::makeSceneSet(spec, test::scorpion(), render::SensorFormat{})[0];
    scene.occluders.resize(1);  // no random rocks
    const auto r = render::render(scene, test::scorpion(), test::noiseFree());
    const auto& t = r.truth.targets.at(0);
    const bool fromRight = scene.occluders[0].name.rfind("occluder_right_", 0) == 0;
    EXPECT_EQ((fromRight ? t.right : t.left).visibility, render::TargetVisibility::Partial);
    EXPECT_TRUE((fromRight ? t.right : t.left).occluded);
    EXPECT_FALSE((fromRight ? t.left : t.right).occluded);
}

TEST(SceneSet, CheckerboardViewsAreVisibleInBothCameras) {
    render::CheckerboardSpec spec;
    spec.views = 6;
    spec.seed = 11;
    const auto config = test::scorpion();
    const render::SensorFormat sensor;
    const auto views = render::makeCheckerboardViews(spec, config, sensor);
    ASSERT_EQ(views.size(), 6u);
    const RigidTransform rTl = rightTLeft(config);
    for (const auto& s : views) {
        ASSERT_TRUE(s.checkerboard);
        const auto& b = *s.checkerboard;
        const RigidTransform leftTBoard = makeRigidTransform(rodrigues(b.om), b.positionMm);
        for (int y = 0; y < b.squaresY - 1; ++y)
            for (int x = 0; x < b.squaresX - 1; ++x) {
                const cv::Point3d p = transformPoint(leftTBoard, {x * b.squareMm, y * b.squareMm, 0.0});
                for (const auto& px : {projectPoint(config.left, p), projectPoint(config.right, transformPoint(rTl, p))}) {
                    ASSERT_TRUE(px);
                    EXPECT_GT(px->x, 10.0);
                    EXPECT_GT(px->y, 10.0);
                    EXPECT_LT(px->x, 1269.0);
                    EXPECT_LT(px->y, 949.0);
                }
            }
    }
    spec.squareMm = 500.0;  // a 4.5 m board cannot fit
    EXPECT_THROW(render::makeCheckerboardViews(spec, config, sensor), InvalidArgument);
}

}  // namespace
}  // namespace avatar
