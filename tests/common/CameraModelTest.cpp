#include "SampleConfigs.h"

#include <avatar/common/CameraModel.h>

#include <gtest/gtest.h>

#include <cmath>

namespace avatar {
namespace {

CameraIntrinsics strongDistortion() {
    CameraIntrinsics c;
    c.fc = {800.0, 820.0};
    c.cc = {330.5, 242.25};
    c.alphaC = 0.01;
    c.kc = {-0.35, 0.15, 0.002, -0.003, -0.03};
    return c;
}

// A grid of 3-D points over the field of view at several depths.
template <typename F>
void forEachViewPoint(F&& f) {
    for (double z : {300.0, 1000.0, 2500.0})
        for (double ny = -0.4; ny <= 0.4001; ny += 0.1)
            for (double nx = -0.55; nx <= 0.5501; nx += 0.11) f(cv::Point3d(nx * z, ny * z, z));
}

TEST(CameraModel, HandComputedBouguetCase) {
    CameraIntrinsics c;
    c.fc = {1000.0, 1100.0};
    c.cc = {640.0, 480.0};
    c.alphaC = 0.002;
    c.kc = {0.1, 0.01, 0.001, 0.002, 0.001};
    // x = (0.2, 0.1): r2 = 0.05, radial = 1 + 0.1*0.05 + 0.01*0.0025 + 0.001*0.000125
    // = 1.005025125; dx = 2*0.001*0.02 + 0.002*(0.05+0.08) = 0.0003,
    // dy = 0.001*(0.05+0.02) + 2*0.002*0.02 = 0.00015;
    // xd = (0.201305025, 0.1006525125);
    // u = 1000*(0.201305025 + 0.002*0.1006525125) + 640 = 841.506330025,
    // v = 1100*0.1006525125 + 480 = 590.71776375.
    const auto px = projectPoint(c, {200.0, 100.0, 1000.0});
    ASSERT_TRUE(px);
    EXPECT_NEAR(px->x, 841.506330025, 1e-9);
    EXPECT_NEAR(px->y, 590.71776375, 1e-9);
    const cv::Point2d xd = pixelToNormalized(c, {841.506330025, 590.71776375});
    EXPECT_NEAR(xd.x, 0.201305025, 1e-12);
    EXPECT_NEAR(xd.y, 0.1006525125, 1e-12);
    const cv::Point2d xn = normalizePixel(c, {841.506330025, 590.71776375});
    EXPECT_NEAR(xn.x, 0.2, 1e-12);
    EXPECT_NEAR(xn.y, 0.1, 1e-12);
}

TEST(CameraModel, NoDistortionIsPlainPinholeWithSkew) {
    CameraIntrinsics c;
    c.fc = {500.0, 400.0};
    c.cc = {100.0, 50.0};
    c.alphaC = 0.1;
    // x = (0.5, 0.25): u = 500*(0.5 + 0.1*0.25) + 100 = 362.5, v = 400*0.25 + 50 = 150.
    const auto px = projectPoint(c, {1.0, 0.5, 2.0});
    ASSERT_TRUE(px);
    EXPECT_DOUBLE_EQ(px->x, 362.5);
    EXPECT_DOUBLE_EQ(px->y, 150.0);
    const cv::Point2d xn = normalizePixel(c, *px);
    EXPECT_DOUBLE_EQ(xn.x, 0.5);
    EXPECT_DOUBLE_EQ(xn.y, 0.25);
}

TEST(CameraModel, PointsBehindTheCameraDoNotProject) {
    const CameraIntrinsics c;
    EXPECT_FALSE(projectPoint(c, {0.0, 0.0, 0.0}));
    EXPECT_FALSE(projectPoint(c, {10.0, 0.0, -5.0}));
}

TEST(CameraModel, ScorpionRoundTrip) {
    const StereoSystemConfig config = test::scorpionCalibration();
    for (const CameraIntrinsics* c : {&config.left, &config.right}) {
        forEachViewPoint([&](const cv::Point3d& p) {
            const auto px = projectPoint(*c, p);
            ASSERT_TRUE(px);
            const cv::Point2d xn = normalizePixel(*c, *px);
            EXPECT_NEAR(xn.x, p.x / p.z, 1e-14);
            EXPECT_NEAR(xn.y, p.y / p.z, 1e-14);
        });
    }
}

TEST(CameraModel, StrongDistortionAndSkewRoundTrip) {
    const CameraIntrinsics c = strongDistortion();
    double worstBouguet = 0.0;
    forEachViewPoint([&](const cv::Point3d& p) {
        const auto px = projectPoint(c, p);
        ASSERT_TRUE(px);
        const auto exact = normalizePixelExact(c, *px);
        ASSERT_TRUE(exact) << "at " << p.x << " " << p.y << " " << p.z;
        EXPECT_NEAR(exact->x, p.x / p.z, 1e-12);
        EXPECT_NEAR(exact->y, p.y / p.z, 1e-12);
        // The toolbox's 20 fixed-point iterations converge more slowly under
        // strong barrel distortion; it stays within a few hundredths of a pixel here.
        const cv::Point2d bouguet = normalizePixel(c, *px);
        worstBouguet = std::max(worstBouguet, std::hypot(bouguet.x - p.x / p.z,
                                                         bouguet.y - p.y / p.z) * c.fc[0]);
    });
    EXPECT_LT(worstBouguet, 0.05) << "pixels";
}

TEST(CameraModel, ExactUndistortionRefusesTheFoldedRegion) {
    CameraIntrinsics c;
    c.kc = {-0.5, 0.0, 0.0, 0.0, 0.0};
    // radial(r) r has its maximum at r = sqrt(1/1.5) (value 0.544); beyond it no preimage.
    EXPECT_FALSE(undistortNormalizedExact(c, {0.7, 0.0}));
    const auto inside = undistortNormalizedExact(c, {0.3, 0.0});
    ASSERT_TRUE(inside);
    EXPECT_NEAR(inside->x * (1.0 - 0.5 * inside->x * inside->x), 0.3, 1e-14);
}

TEST(CameraModel, RodriguesMatchesAxisAngle) {
    const cv::Matx33d r = rodrigues({0.0, 0.0, M_PI / 2.0});
    EXPECT_NEAR(r(0, 1), -1.0, 1e-15);
    EXPECT_NEAR(r(1, 0), 1.0, 1e-15);
    EXPECT_NEAR(r(2, 2), 1.0, 1e-15);
    const std::array<double, 3> om{0.002, 0.003, 0.047};
    const auto back = rodriguesVector(rodrigues(om));
    for (std::size_t i = 0; i < 3; ++i) EXPECT_NEAR(back[i], om[i], 1e-13);
}

TEST(CameraModel, RigidTransformInverse) {
    const RigidTransform t =
        makeRigidTransform(rodrigues({0.3, -0.2, 1.1}), cv::Vec3d(100.0, -50.0, 12.5));
    const cv::Point3d p(1.0, 2.0, 3.0);
    const cv::Point3d back = transformPoint(inverse(t), transformPoint(t, p));
    EXPECT_NEAR(back.x, p.x, 1e-12);
    EXPECT_NEAR(back.y, p.y, 1e-12);
    EXPECT_NEAR(back.z, p.z, 1e-12);
}

}  // namespace
}  // namespace avatar
