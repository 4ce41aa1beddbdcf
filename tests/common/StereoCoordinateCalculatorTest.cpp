#include "SampleConfigs.h"

#include <avatar/common/CameraModel.h>
#include <avatar/common/StereoCoordinateCalculator.h>
#include <avatar/common/Error.h>

#include <gtest/gtest.h>

namespace avatar {
namespace {

void expectNear(const cv::Point3d& a, const cv::Point3d& b, double tolerance) {
    EXPECT_NEAR(a.x, b.x, tolerance);
    EXPECT_NEAR(a.y, b.y, tolerance);
    EXPECT_NEAR(a.z, b.z, tolerance);
}

TEST(StereoCoordinateCalculator, HandComputedRectifiedPair) {
    StereoSystemConfig c;
    c.left.fc = c.right.fc = {1000.0, 1000.0};
    c.left.cc = c.right.cc = {500.0, 400.0};
    c.om = {0.0, 0.0, 0.0};
    c.translationMm = {-100.0, 0.0, 0.0};
    // (50, 20, 1000) projects to (550, 420) left and (450, 420) right (disparity 100 px
    // = f B / Z). Xl = (0.05, 0.02, 1), Xr = (-0.05, 0.02, 1), u = Xl, T = (-100, 0, 0):
    // |Xl|^2 = |Xr|^2 = 1.0029, Xr.u = 0.9979, Xr.T = 5, u.T = -5,
    // DD = 1.0029^2 - 0.9979^2 = 0.010004, NN1 = NN2 = 0.9979*5 + 1.0029*5 = 10.004,
    // Zl = Zr = 1000, X1 = (50, 20, 1000), X2 = Xr*1000 - T = (50, 20, 1000).
    const StereoCoordinateCalculator calc(stereoGeometry(c));
    const auto p = calc.triangulate({550.0, 420.0}, {450.0, 420.0});
    ASSERT_TRUE(p);
    expectNear(p->leftMm, {50.0, 20.0, 1000.0}, 1e-9);
    expectNear(p->rightMm, {-50.0, 20.0, 1000.0}, 1e-9);
    EXPECT_FALSE(p->baseMm);
}

TEST(StereoCoordinateCalculator, ExactProjectionsGiveTheTruth) {
    StereoSystemConfig configs[2] = {test::scorpionCalibration(), test::scorpionCalibration()};
    configs[1].left.kc = {-0.2, 0.08, 0.001, -0.0015, -0.01};
    configs[1].right.kc = {-0.18, 0.05, -0.002, 0.001, 0.0};
    configs[1].left.alphaC = 0.002;
    for (const StereoSystemConfig& c : configs) {
        const StereoCoordinateCalculator calc(stereoGeometry(c));
        const RigidTransform rTl = rightTLeft(c);
        for (double z : {400.0, 900.0, 1700.0, 2500.0})
            for (double y : {-0.3, 0.0, 0.25})
                for (double x : {-0.4, -0.1, 0.2, 0.45}) {
                    const cv::Point3d truth(x * z, y * z, z);
                    const auto l = projectPoint(c.left, truth);
                    const auto r = projectPoint(c.right, transformPoint(rTl, truth));
                    ASSERT_TRUE(l && r);
                    const auto p = calc.triangulate(*l, *r);
                    ASSERT_TRUE(p);
                    expectNear(p->leftMm, truth, 1e-6);
                    expectNear(p->rightMm, transformPoint(rTl, truth), 1e-6);
                }
    }
}

TEST(StereoCoordinateCalculator, TransformsToTheBaseFrame) {
    StereoSystemConfig c = test::scorpionCalibration();
    c.baseTVision = makeRigidTransform(rodrigues({0.0, M_PI / 2.0, 0.0}),
                                       cv::Vec3d(500.0, -200.0, 100.0));
    const StereoCoordinateCalculator calc(stereoGeometry(c));
    ASSERT_TRUE(calc.hasRegistration());
    const cv::Point3d truth(100.0, 50.0, 800.0);
    const auto l = projectPoint(c.left, truth);
    const auto r = projectPoint(c.right, transformPoint(rightTLeft(c), truth));
    const auto p = calc.triangulate(*l, *r);
    ASSERT_TRUE(p && p->baseMm);
    // Rotation of +90 deg about y: (x, y, z) -> (z, y, -x), then translate.
    expectNear(*p->baseMm, {800.0 + 500.0, 50.0 - 200.0, -100.0 + 100.0}, 1e-6);
}

TEST(StereoCoordinateCalculator, NoRegistrationIsAnError) {
    const StereoCoordinateCalculator calc(stereoGeometry(test::scorpionCalibration()));
    EXPECT_FALSE(calc.hasRegistration());
    EXPECT_THROW(calc.visionToBase({0.0, 0.0, 1.0}), InvalidArgument);
}

TEST(StereoCoordinateCalculator, ParallelRaysGiveNoPoint) {
    StereoSystemConfig c;
    c.om = {0.0, 0.0, 0.0};
    c.translationMm = {-100.0, 0.0, 0.0};
    const StereoCoordinateCalculator calc(stereoGeometry(c));
    // Same pixel in both cameras of a pure-translation rig: the rays are parallel.
    EXPECT_FALSE(calc.triangulate({640.0, 480.0}, {640.0, 480.0}));
}

}  // namespace
}  // namespace avatar
