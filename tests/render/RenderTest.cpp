#include "RenderFixtures.h"

#include <avatar/common/CameraModel.h>
#include <avatar/common/StereoCoordinateCalculator.h>
#include <avatar/common/ImageUtils.h>
#include <avatar/common/StereoImagePairFileIO.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cmath>
#include <filesystem>

#include <unistd.h>

namespace avatar {
namespace {

using render::Scene;
using render::Shape;
using render::TargetSpec;
using render::TargetVisibility;

TargetSpec target(const std::string& name, Shape shape, cv::Vec3d centre, double radius) {
    TargetSpec t;
    t.name = name;
    t.shape = shape;
    t.centreMm = centre;
    t.radiusMm = radius;
    return t;
}

double distance(const cv::Point2d& a, const cv::Point2d& b) { return std::hypot(a.x - b.x, a.y - b.y); }

/// The y (mm) that puts the lowest point of a 40 mm sphere's silhouette at
/// 1000 mm (on the y-z plane, scorpion's left camera, lens ignored) at row
/// @p bottom: v = cc_y + f tan(asin(r / d) + atan(y / z)), solved by bisection.
double sphereYForBottom(double bottom) {
    const auto bottomOf = [](double y, double z, double r) {
        const double f = 1050.38, cy = 564.45;
        return cy + f * std::tan(std::asin(r / std::hypot(y, z)) + std::atan2(y, z));
    };
    double lo = 0, hi = 600;
    for (int i = 0; i < 60; ++i) (bottomOf(0.5 * (lo + hi), 1000, 40) < bottom ? lo : hi) = 0.5 * (lo + hi);
    return 0.5 * (lo + hi);
}

TEST(Render, ProjectedCentresTriangulateToTheTruth) {
    Scene scene = test::flatScene({0.5, 0.5, 0.5}, 0.5);
    scene.seabed.distanceMm = 3000.0;
    scene.targets = {target("a", Shape::Sphere, {-300, 150, 600}, 30),
                     target("b", Shape::Duck, {200, -100, 1200}, 40),
                     target("c", Shape::Disc, {450, 300, 2400}, 50),
                     target("d", Shape::Sphere, {-600, -350, 1800}, 35)};
    StereoSystemConfig config = test::scorpion();
    config.baseTVision = makeRigidTransform(rodrigues({0.1, -1.2, 0.3}), cv::Vec3d(-400, 250, 900));
    const auto result = render::render(scene, config, test::noiseFree(320, 240));
    const StereoCoordinateCalculator calc(stereoGeometry(config));
    for (const auto& t : result.truth.targets) {
        ASSERT_TRUE(t.left.projectedCentrePx && t.right.projectedCentrePx);
        const auto p = calc.triangulate(*t.left.projectedCentrePx, *t.right.projectedCentrePx);
        ASSERT_TRUE(p);
        EXPECT_LT(cv::norm(p->leftMm - t.centreLeftMm), 0.01) << t.name;
        EXPECT_LT(cv::norm(p->rightMm - t.centreRightMm), 0.01) << t.name;
        ASSERT_TRUE(p->baseMm && t.centreBaseMm);
        EXPECT_LT(cv::norm(*p->baseMm - *t.centreBaseMm), 0.01) << t.name;
    }
}

TEST(Render, FrontoParallelDiscCentroidIsItsProjectedCentre) {
    Scene scene = test::flatScene({0.4, 0.4, 0.4}, 0.6);
    scene.lighting.lightIntensity = {0.5, 0.5, 0.5};
    // Discs parallel to the left image plane, off-centre, at two ranges.
    scene.targets = {target("near", Shape::Disc, {-180.0, 95.0, 800.0}, 40.0),
                     target("far", Shape::Disc, {310.0, -170.0, 1400.0}, 45.0)};
    const auto result = render::render(scene, test::scorpion(), test::noiseFree());
    for (const auto& t : result.truth.targets) {
        for (const render::TargetView* v : {&t.left, &t.right}) {
            ASSERT_EQ(v->visibility, TargetVisibility::Full) << t.name;
            ASSERT_TRUE(v->silhouetteCentroidPx && v->projectedCentrePx);
            EXPECT_LT(distance(*v->silhouetteCentroidPx, *v->projectedCentrePx), 0.02) << t.name;
        }
        // Area of the left view: the disc's image is a circle of radius f r / z.
        const auto& fc = test::scorpion().left.fc;
        const double rPx = std::sqrt(fc[0] * fc[1]) * 40.0 / 800.0;
        if (t.name == "near") {
            EXPECT_NEAR(t.left.areaPx, M_PI * rPx * rPx, 0.002 * M_PI * rPx * rPx);
        }
    }
    RecordProperty("render_ms", std::to_string(result.truth.stats.milliseconds));
}

TEST(Render, UniformFieldHasTheExpectedValuesInEveryBayerPattern) {
    const render::Rgb albedo{0.5, 0.3, 0.2};
    const Scene scene = test::flatScene(albedo, 0.8);
    // Radiance = albedo * ambient = (0.4, 0.24, 0.16) of full scale.
    const double expected[3] = {std::round(0.4 * 65535.0), std::round(0.24 * 65535.0),
                                std::round(0.16 * 65535.0)};
    for (BayerPattern pattern : {BayerPattern::BG, BayerPattern::GB, BayerPattern::RG, BayerPattern::GR}) {
        auto options = test::noiseFree(64, 48);
        options.sensor.bayerPattern = pattern;
        const auto result = render::render(scene, test::scorpion(), options);
        const cv::Mat& raw = result.pair.left();
        ASSERT_EQ(raw.type(), CV_16UC1);
        // The first row names the pattern: BG starts blue, green.
        const std::string name(toString(pattern));
        auto channelOf = [](char c) { return c == 'R' ? 0 : c == 'G' ? 1 : 2; };
        EXPECT_EQ(raw.at<std::uint16_t>(0, 0), expected[channelOf(name[0])]) << name;
        EXPECT_EQ(raw.at<std::uint16_t>(0, 1), expected[channelOf(name[1])]) << name;
        const cv::Mat bgr = demosaic(raw, pattern);
        for (const cv::Point p : {cv::Point(10, 10), cv::Point(31, 20), cv::Point(40, 33)}) {
            const cv::Vec3w v = bgr.at<cv::Vec3w>(p);
            EXPECT_EQ(v[2], expected[0]) << name << " red at " << p.x << "," << p.y;
            EXPECT_EQ(v[1], expected[1]) << name << " green";
            EXPECT_EQ(v[0], expected[2]) << name << " blue";
        }
    }
}

TEST(Render, MonoSensorIsTheMeanOfTheBands) {
    const Scene scene = test::flatScene({0.5, 0.3, 0.2}, 0.8);
    auto options = test::noiseFree(64, 48);
    options.sensor.format = PixelFormat::Mono;
    const auto result = render::render(scene, test::scorpion(), options);
    ASSERT_EQ(result.pair.cvType(), CV_16UC1);
    EXPECT_EQ(result.pair.layout().format, PixelFormat::Mono);
    // Radiance (0.4, 0.24, 0.16) of full scale: a panchromatic pixel sees their mean.
    const double expected = std::round((0.4 + 0.24 + 0.16) / 3.0 * 65535.0);
    double minV, maxV;
    cv::minMaxLoc(result.pair.left(), &minV, &maxV);
    EXPECT_EQ(minV, expected);
    EXPECT_EQ(maxV, expected);

    // A camera configuration that says mono (one channel, no mosaic) gives a mono sensor.
    CameraHardwareConfig camera;
    camera.channels = 1;
    camera.bayer = false;
    EXPECT_EQ(render::sensorFormatFrom(camera).format, PixelFormat::Mono);
    camera.bayer = true;
    EXPECT_EQ(render::sensorFormatFrom(camera).format, PixelFormat::Bayer);
    camera.channels = 3;
    EXPECT_EQ(render::sensorFormatFrom(camera).format, PixelFormat::Bgr);
}

TEST(Render, LambertianLightAtTheCameraStrobeAndWater) {
    Scene scene = test::flatScene({0.6, 0.5, 0.4}, 0.0);
    scene.lighting.lightIntensity = {1.0, 1.0, 1.0};
    auto options = test::noiseFree(96, 64);
    options.sensor.format = PixelFormat::Bgr;
    StereoSystemConfig config = test::scorpion();
    config.left.cc = {47.5, 31.5};
    const auto plain = render::render(scene, config, options);
    // Light at the left camera, plane z = 1500 facing it: cos = 1 / |(xn, yn, 1)|.
    for (const cv::Point p : {cv::Point(47, 31), cv::Point(5, 60), cv::Point(90, 2)}) {
        const cv::Point2d xn = normalizePixel(config.left, cv::Point2d(p));
        const double cosine = 1.0 / std::sqrt(xn.x * xn.x + xn.y * xn.y + 1.0);
        const cv::Vec3w v = plain.pair.left().at<cv::Vec3w>(p);
        EXPECT_EQ(v[2], std::round(0.6 * cosine * 65535.0));
        EXPECT_EQ(v[1], std::round(0.5 * cosine * 65535.0));
        EXPECT_EQ(v[0], std::round(0.4 * cosine * 65535.0));
    }
    // Strobe: factor c exp(e d) with e <= 0; water: exp(-a (light + view path) / 1000).
    scene.lighting.strobe.enabled = true;
    scene.lighting.strobe.centrePx = {47.0, 31.0};
    scene.lighting.strobe.rgb = {{{0.9, -0.01}, {1.0, -0.005}, {1.0, 0.0}}};
    scene.lighting.attenuationPerM = {0.5, 0.1, 0.05};
    const auto wet = render::render(scene, config, options);
    const cv::Point p(87, 31);  // 40 px right of the strobe centre
    const cv::Point2d xn = normalizePixel(config.left, cv::Point2d(p));
    const double range = 1500.0 * std::sqrt(xn.x * xn.x + xn.y * xn.y + 1.0);
    const double cosine = 1500.0 / range;
    const double strobe[3] = {0.9 * std::exp(-0.4), std::exp(-0.2), 1.0};
    const double attenuation[3] = {0.5, 0.1, 0.05};
    const double albedo[3] = {0.6, 0.5, 0.4};
    const cv::Vec3w v = wet.pair.left().at<cv::Vec3w>(p);
    for (int c = 0; c < 3; ++c)
        EXPECT_EQ(v[2 - c], std::round(albedo[c] * cosine * strobe[c] *
                                       std::exp(-attenuation[c] * 2.0 * range / 1000.0) * 65535.0))
            << "channel " << c;
    // Haze: the turbidity adds to the extinction of both paths and the
    // backscatter fills in what the view path loses.
    scene.lighting.turbidityPerM = 0.3;
    scene.lighting.backscatter = {0.1, 0.2, 0.3};
    const auto hazy = render::render(scene, config, options);
    const cv::Vec3w h = hazy.pair.left().at<cv::Vec3w>(p);
    const double backscatter[3] = {0.1, 0.2, 0.3};
    for (int c = 0; c < 3; ++c) {
        const double view = std::exp(-(attenuation[c] + 0.3) * range / 1000.0);
        const double surface = albedo[c] * cosine * view * view;  // light path = view path here
        EXPECT_NEAR(h[2 - c], (surface + backscatter[c] * (1.0 - view)) * strobe[c] * 65535.0, 0.5 + 1e-9)
            << "channel " << c;
    }
}

TEST(Render, BitDepths) {
    const Scene scene = test::flatScene({0.5, 0.5, 0.5}, 0.5);
    for (int bits : {8, 12, 16}) {
        auto options = test::noiseFree(32, 24);
        options.sensor.bitDepth = bits;
        const auto r = render::render(scene, test::scorpion(), options);
        EXPECT_EQ(r.pair.cvType(), bits == 8 ? CV_8UC1 : CV_16UC1);
        EXPECT_EQ(r.pair.layout().bitDepth, bits);
        const double expected = std::round(0.25 * (std::ldexp(1.0, bits) - 1.0));
        double minV, maxV;
        cv::minMaxLoc(r.pair.left(), &minV, &maxV);
        EXPECT_EQ(minV, expected);
        EXPECT_EQ(maxV, expected);
    }
}

TEST(Render, RawFilesRoundTripInBothByteOrders) {
    const Scene scene = test::flatScene({0.5, 0.3, 0.2}, 0.7);
    const auto dir = std::filesystem::temp_directory_path() /
                     ("avatar_render_test_" + std::to_string(::getpid()));
    for (ByteOrder order : {ByteOrder::Little, ByteOrder::Big}) {
        auto options = test::noiseFree(40, 30);
        options.sensor.bitDepth = 12;
        options.sensor.fileByteOrder = order;
        const auto r = render::render(scene, test::scorpion(), options);
        const auto files = render::writeRender(r, options.sensor, dir, 3, 7, false);
        EXPECT_EQ(files.leftRaw.filename().string(),
                  std::string("L_00003_00007_40x30_12b_1c_BG_") + (order == ByteOrder::Big ? "be" : "le") + ".raw");
        const cv::Mat back = StereoImagePairFileIO::readRaw(files.rightRaw);
        EXPECT_EQ(cv::norm(back, r.pair.right(), cv::NORM_INF), 0.0);
        EXPECT_TRUE(std::filesystem::exists(files.groundTruth));
    }
    std::filesystem::remove_all(dir);
}

TEST(Render, DeterministicForASeed) {
    Scene scene = test::flatScene({0.5, 0.4, 0.3}, 0.4);
    scene.seabed.textureContrast = 0.3;
    scene.sensor.readNoiseDn = 40.0;
    scene.sensor.shotNoise = true;
    scene.targets = {target("t", Shape::Duck, {0, 0, 900}, 40)};
    auto options = test::noiseFree(160, 120);
    options.noise = true;
    options.seed = 42;
    StereoSystemConfig config = test::scorpion();
    config.left.cc = config.right.cc = {80.0, 60.0};
    const auto a = render::render(scene, config, options);
    const auto b = render::render(scene, config, options);
    EXPECT_EQ(cv::norm(a.pair.left(), b.pair.left(), cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(a.pair.right(), b.pair.right(), cv::NORM_INF), 0.0);
    EXPECT_EQ(a.truth.target("t").left.silhouetteCentroidPx, b.truth.target("t").left.silhouetteCentroidPx);
    options.seed = 43;
    const auto c = render::render(scene, config, options);
    EXPECT_GT(cv::norm(a.pair.left(), c.pair.left(), cv::NORM_INF), 0.0);
    // The geometry does not depend on the noise seed.
    EXPECT_EQ(a.truth.target("t").left.silhouetteCentroidPx, c.truth.target("t").left.silhouetteCentroidPx);
}

TEST(Render, OcclusionVisibility) {
    Scene scene = test::flatScene({0.5, 0.5, 0.5}, 0.5);
    scene.targets = {target("behind", Shape::Sphere, {0, 0, 1000}, 50),
                     target("free", Shape::Sphere, {250, 150, 1000}, 40),
                     target("hidden", Shape::Sphere, {-300, -200, 1200}, 30)};
    // Covers the left part of "behind" in the left camera only (the right camera,
    // 106 mm to the right, looks past it), and all of "hidden" in both.
    render::Occluder o;
    o.centreMm = {-40, 0, 600};
    o.radiusMm = 30;
    render::Occluder wall;
    wall.shape = Shape::Box;
    wall.centreMm = {-300, -200, 700};
    wall.halfSizeMm = {250, 150, 5};
    scene.occluders = {o, wall};
    const auto r = render::render(scene, test::scorpion(), test::noiseFree());
    const auto& behind = r.truth.target("behind");
    EXPECT_EQ(behind.left.visibility, TargetVisibility::Partial);
    EXPECT_TRUE(behind.left.occluded);
    EXPECT_FALSE(behind.left.atBorder);
    EXPECT_EQ(behind.right.visibility, TargetVisibility::Full);
    EXPECT_EQ(r.truth.target("free").left.visibility, TargetVisibility::Full);
    EXPECT_EQ(r.truth.target("free").right.visibility, TargetVisibility::Full);
    EXPECT_EQ(r.truth.target("hidden").left.visibility, TargetVisibility::None);
    EXPECT_EQ(r.truth.target("hidden").right.visibility, TargetVisibility::None);
    EXPECT_FALSE(r.truth.target("hidden").left.silhouetteCentroidPx);
    EXPECT_EQ(r.truth.target("hidden").left.areaPx, 0.0);
}

TEST(Render, BorderVisibility) {
    Scene scene = test::flatScene({0.5, 0.5, 0.5}, 0.5);
    // u = cc + f x / z = 0 at x / z = -0.679: cut by the left border of the left
    // image, out of the right image (which looks 106 mm further right).
    scene.targets = {target("edge", Shape::Sphere, {-679, 0, 1000}, 40),
                     target("inside", Shape::Sphere, {0, 100, 1000}, 40),
                     target("outside", Shape::Sphere, {0, 2000, 1000}, 40)};
    const auto r = render::render(scene, test::scorpion(), test::noiseFree());
    const auto& edge = r.truth.target("edge");
    EXPECT_EQ(edge.left.visibility, TargetVisibility::Partial);
    EXPECT_TRUE(edge.left.atBorder);
    EXPECT_TRUE(edge.left.cut);
    EXPECT_FALSE(edge.left.occluded);
    EXPECT_LT(edge.left.areaPx, 0.6 * M_PI * std::pow(1049.13 * 40 / 1000, 2));  // about half of it is outside
    EXPECT_EQ(edge.right.visibility, TargetVisibility::None);
    EXPECT_EQ(r.truth.target("inside").left.visibility, TargetVisibility::Full);
    EXPECT_EQ(r.truth.target("outside").left.visibility, TargetVisibility::None);
    EXPECT_EQ(r.truth.target("outside").right.visibility, TargetVisibility::None);
}

// A whole target whose silhouette only touches the last row is full, not cut;
// one that continues beyond it is cut (sphereYForBottom()).
TEST(Render, TouchingTheBorderIsNotCut) {
    // The silhouette's lowest point at 959.3 (inside the last row, whose
    // outer edge is 959.5) and 960.5 (a pixel beyond it).
    Scene scene = test::flatScene({0.5, 0.5, 0.5}, 0.5);
    scene.targets = {target("touching", Shape::Sphere, {-150, sphereYForBottom(959.3), 1000}, 40),
                     target("crossing", Shape::Sphere, {150, sphereYForBottom(960.5), 1000}, 40)};
    const auto r = render::render(scene, test::scorpion(), test::noiseFree());
    const auto& touching = r.truth.target("touching").left;
    EXPECT_TRUE(touching.atBorder);
    EXPECT_FALSE(touching.cut);
    EXPECT_EQ(touching.visibility, TargetVisibility::Full);
    EXPECT_NEAR(touching.potentialAreaPx, touching.areaPx, 1e-9);
    const auto& crossing = r.truth.target("crossing").left;
    EXPECT_TRUE(crossing.atBorder);
    EXPECT_TRUE(crossing.cut);
    EXPECT_EQ(crossing.visibility, TargetVisibility::Partial);
    EXPECT_EQ(crossing.hiddenFraction(), 0.0);  // nothing in front of it: cut, not hidden
}

// How much of a cut silhouette lies beyond the image is what an image 10 px
// larger each way (the principal points moved with it: the same rays) shows
// more of it; not cut, nothing; beyond the 2 px band measured, no bound.
TEST(Render, TheAreaBeyondTheEdgeIsWhatALargerImageShows) {
    Scene scene = test::flatScene({0.5, 0.5, 0.5}, 0.5);
    scene.targets = {target("touching", Shape::Sphere, {-300, sphereYForBottom(959.3), 1000}, 40),
                     target("grazing", Shape::Sphere, {-100, sphereYForBottom(959.65), 1000}, 40),
                     target("crossing", Shape::Sphere, {100, sphereYForBottom(960.7), 1000}, 40),
                     target("deep", Shape::Sphere, {300, sphereYForBottom(963.0), 1000}, 40)};
    const StereoSystemConfig config = test::scorpion();
    const auto r = render::render(scene, config, test::noiseFree());
    StereoSystemConfig larger = config;
    for (CameraIntrinsics* c : {&larger.left, &larger.right}) c->cc = {c->cc[0] + 10.0, c->cc[1] + 10.0};
    const auto big = render::render(scene, larger, test::noiseFree(1300, 980));
    for (const char* name : {"touching", "grazing", "crossing"}) {
        const auto& in = r.truth.target(name).left;
        const auto& all = big.truth.target(name).left;
        ASSERT_FALSE(all.cut) << name;
        const double beyond = all.potentialAreaPx - in.potentialAreaPx;
        EXPECT_NEAR(in.outsideAreaPx, beyond, 0.1 + 0.03 * beyond) << name;
    }
    EXPECT_FALSE(r.truth.target("touching").left.cut);
    EXPECT_EQ(r.truth.target("touching").left.outsideAreaPx, 0.0);
    EXPECT_TRUE(r.truth.target("grazing").left.cut);
    EXPECT_GT(r.truth.target("grazing").left.outsideAreaPx, 0.0);
    EXPECT_LT(r.truth.target("grazing").left.outsideAreaPx, 1.0);
    EXPECT_GT(r.truth.target("crossing").left.outsideAreaPx, 1.0);
    EXPECT_TRUE(std::isinf(r.truth.target("deep").left.outsideAreaPx));
}

TEST(Render, ArmMarkerNeedsARegistration) {
    Scene scene = test::flatScene({0.5, 0.5, 0.5}, 0.5);
    scene.armMarkers.push_back({});
    EXPECT_THROW(render::render(scene, test::scorpion(), test::noiseFree(32, 24)), render::SceneError);
    // With a registration the marker is placed from its base-frame pose.
    StereoSystemConfig config = test::scorpion();
    config.baseTVision = makeRigidTransform(rodrigues({0.0, 0.0, 0.0}), cv::Vec3d(0, 0, -800));
    scene.armMarkers[0].positionBaseMm = {0, 0, 0};
    const auto r = render::render(scene, config, test::noiseFree(32, 24));
    const auto& arm = r.truth.target("arm");
    EXPECT_EQ(arm.type, "arm_marker");
    EXPECT_NEAR(arm.centreLeftMm.z, 800.0, 1e-12);
    ASSERT_TRUE(arm.centreBaseMm);
    EXPECT_NEAR(cv::norm(*arm.centreBaseMm), 0.0, 1e-12);
}

TEST(Render, CheckerboardCornersAreExactProjections) {
    Scene scene = test::flatScene({0.5, 0.5, 0.5}, 0.5);
    render::Checkerboard board;
    board.squaresX = 6;
    board.squaresY = 5;
    board.squareMm = 40.0;
    board.om = {0.2, -0.3, 0.05};
    board.positionMm = {-100, -80, 900};
    scene.checkerboard = board;
    const StereoSystemConfig config = test::scorpion();
    const auto r = render::render(scene, config, test::noiseFree(320, 240));
    ASSERT_TRUE(r.truth.checkerboard);
    const auto& cb = *r.truth.checkerboard;
    ASSERT_EQ(cb.cornersLeftPx.size(), 20u);
    const cv::Point3d corner = transformPoint(
        makeRigidTransform(rodrigues(board.om), board.positionMm), {2 * 40.0, 1 * 40.0, 0.0});
    EXPECT_LT(cv::norm(cb.cornersLeftMm[1 * 5 + 2] - corner), 1e-9);
    EXPECT_LT(distance(cb.cornersLeftPx[7], *projectPoint(config.left, corner)), 1e-9);
}

}  // namespace
}  // namespace avatar
