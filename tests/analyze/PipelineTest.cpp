// The analysis orchestrator on synthetic pairs drawn with exact geometry:
// discs facing the left camera, projected with the Scorpion calibration.

#include "SampleConfigs.h"

#include <avatar/analyze/AnalyzeStereoImagePair.h>
#include <avatar/common/CameraModel.h>
#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>
#include <avatar/config/ConfigXml.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <array>
#include <cmath>
#include <filesystem>

using namespace avatar;

namespace {

const cv::Scalar kBackground(8000, 9000, 6000);   // B, G, R: blue-grey seabed
const cv::Scalar kYellow(4000, 36000, 40000);     // R/G 1.11, R/B 10, B/G 0.11

AvatarConfig pipelineConfig() {
    AvatarConfig c;
    c.camera.width = 1280;
    c.camera.height = 960;
    c.camera.bitDepth = 16;
    c.camera.channels = 3;
    c.camera.bayer = false;
    c.stereo = test::scorpionCalibration();
    TargetType sample;
    sample.name = "sample";
    sample.redGreen = {0.9, 1.4};
    sample.redBlue = {5.0, 100.0};
    sample.blueGreen = {0.0, 0.3};
    sample.area = {50, 1e9};
    c.targets.targets = {sample};
    c.match.method = MatchMethod::EpipolarBox;
    c.match.boxDxMin = 30;
    c.match.boxDxMax = 400;
    c.match.boxDyMin = -40;
    c.match.boxDyMax = 40;
    return c;
}

// Draws a disc of radius @p radiusMm facing the camera, centred at a point of
// that camera's frame, with sub-pixel accuracy (8 fractional bits).
void drawDisc(cv::Mat& image, const CameraIntrinsics& cam, const cv::Point3d& centre, double radiusMm) {
    const auto px = projectPoint(cam, centre);
    ASSERT_TRUE(px.has_value());
    const double radiusPx = cam.fc[0] * radiusMm / centre.z;
    cv::circle(image, cv::Point(cvRound(px->x * 256), cvRound(px->y * 256)), cvRound(radiusPx * 256), kYellow,
               cv::FILLED, cv::LINE_8, 8);
}

struct Scene {
    StereoImagePair pair;
    std::vector<cv::Point3d> stereoTruth;   // visible in both
    cv::Point2d leftOnlyPx;                 // a disc only the left camera sees
};

Scene makeScene() {
    const StereoSystemConfig s = test::scorpionCalibration();
    const RigidTransform rTl = rightTLeft(s);
    cv::Mat left(960, 1280, CV_16UC3, kBackground), right(960, 1280, CV_16UC3, kBackground);
    Scene scene;
    scene.stereoTruth = {{-150, 50, 700}, {100, -80, 900}, {250, 120, 600}};
    for (const auto& p : scene.stereoTruth) {
        drawDisc(left, s.left, p, 20);
        drawDisc(right, s.right, transformPoint(rTl, p), 20);
    }
    const cv::Point3d edge(-435, 0, 700);  // u ~ 60 px left, off the right image
    drawDisc(left, s.left, edge, 15);
    scene.leftOnlyPx = *projectPoint(s.left, edge);
    scene.pair = StereoImagePair(left, right, {PixelFormat::Bgr, BayerPattern::BG, 16}, {1, 4, {}, {}});
    return scene;
}

}  // namespace

TEST(Pipeline, TriangulatesDiscsToTheirTruePositions) {
    const Scene scene = makeScene();
    AnalyzeStereoImagePair analyzer(pipelineConfig());
    const VisionTargets result = analyzer.analyze(scene.pair, 17);
    EXPECT_EQ(result.iteration, 17u);
    EXPECT_EQ(result.acquisition.member, 4u);

    std::vector<VisionTarget> stereo, single;
    for (const auto& t : result.targets) ((t.flags & kTargetStereo) ? stereo : single).push_back(t);
    ASSERT_EQ(stereo.size(), 3u);
    for (const auto& truth : scene.stereoTruth) {
        double best = 1e9;
        for (const auto& t : stereo) best = std::min(best, cv::norm(*t.positionVisionMm - truth));
        EXPECT_LT(best, 1.5) << "no target within 1.5 mm of " << truth;
    }
    ASSERT_EQ(single.size(), 1u);
    EXPECT_TRUE(single[0].flags & kTargetLeftOnly);
    EXPECT_FALSE(single[0].positionVisionMm.has_value());
    ASSERT_TRUE(single[0].centroidLeftPx.has_value());
    EXPECT_LT(cv::norm(*single[0].centroidLeftPx - scene.leftOnlyPx), 0.5);
    EXPECT_EQ(result.visibility, Visibility::Good) << result.visibilityReason;
}

TEST(Pipeline, ParallelAndSerialRunsGiveIdenticalResults) {
    const Scene scene = makeScene();
    AvatarConfig two = pipelineConfig();
    two.analysis.threads = 2;
    AnalyzeStereoImagePair parallel(two), serial(pipelineConfig());  // serial: the default, one thread
    for (std::uint64_t i = 1; i <= 3; ++i) {  // buffers reused from the second frame on
        const auto a = parallel.analyze(scene.pair, i);
        const auto b = serial.analyze(scene.pair, i);
        EXPECT_EQ(a.targets, b.targets);  // bit for bit
        EXPECT_EQ(a.visibility, b.visibility);
        for (Side side : {Side::Left, Side::Right}) {
            const ImageWork& p = parallel.lastFrame().at(side);
            const ImageWork& q = serial.lastFrame().at(side);
            ASSERT_EQ(p.masks.size(), q.masks.size());
            for (std::size_t t = 0; t < p.masks.size(); ++t)
                EXPECT_EQ(cv::norm(p.masks[t], q.masks[t], cv::NORM_INF), 0.0) << toString(side) << " mask " << t;
            EXPECT_EQ(p.visibility.contrast, q.visibility.contrast) << toString(side);
            EXPECT_EQ(p.visibility.haze, q.visibility.haze) << toString(side);
            EXPECT_EQ(p.visibility.saturatedFraction, q.visibility.saturatedFraction) << toString(side);
        }
    }
}

namespace {

/// The threads of this process (Linux: the entries of /proc/self/task).
std::size_t processThreads() {
    std::size_t n = 0;
    for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator("/proc/self/task")) ++n;
    return n;
}

}  // namespace

TEST(Pipeline, RunsOnTheConfiguredNumberOfThreads) {
    // analysis/threads 1 (the default) analyses on the calling thread and
    // starts no other; 2 starts one worker at the first pair, kept for the
    // next, and setParallel() overrides the configuration either way.
    const Scene scene = makeScene();
    AvatarConfig two = pipelineConfig();
    two.analysis.threads = 2;
    {
        AnalyzeStereoImagePair warm(two);  // whatever OpenCV starts once per process, started now
        warm.analyze(scene.pair, 1);
    }
    const std::size_t before = processThreads();
    AnalyzeStereoImagePair one(pipelineConfig());
    one.analyze(scene.pair, 1);
    one.analyze(scene.pair, 2);
    EXPECT_EQ(processThreads(), before) << "one thread configured";
    AnalyzeStereoImagePair parallel(two);
    EXPECT_EQ(processThreads(), before) << "no worker before the first pair";
    parallel.analyze(scene.pair, 1);
    parallel.analyze(scene.pair, 2);
    EXPECT_EQ(processThreads(), before + 1) << "two threads configured";
    one.setParallel(true);
    one.analyze(scene.pair, 3);
    EXPECT_EQ(processThreads(), before + 2) << "setParallel(true) over one thread configured";
    AnalyzeStereoImagePair overridden(two);
    overridden.setParallel(false);
    overridden.analyze(scene.pair, 1);
    EXPECT_EQ(processThreads(), before + 2) << "setParallel(false) over two threads configured";
}

TEST(Pipeline, TimesEveryStageAndTheTotal) {
    const Scene scene = makeScene();
    AnalyzeStereoImagePair analyzer(pipelineConfig());
    const auto result = analyzer.analyze(scene.pair, 1);
    std::vector<std::string> names;
    for (const auto& t : result.timings) {
        names.push_back(t.stage);
        EXPECT_GE(t.milliseconds, 0.0);
    }
    std::vector<std::string> expected = pipelineConfig().analysis.stages;
    expected.push_back("total");
    EXPECT_EQ(names, expected);
}

TEST(Pipeline, KeepsOriginalFilteredAndMarkedImages) {
    const Scene scene = makeScene();
    AnalyzeStereoImagePair analyzer(pipelineConfig());
    analyzer.analyze(scene.pair, 1);
    // The original is the acquired pair, untouched.
    EXPECT_EQ(cv::norm(analyzer.originalImages().left(), scene.pair.left(), cv::NORM_INF), 0.0);
    const auto filtered = analyzer.filteredImages();
    // Background is filtered out, a disc centre is kept.
    EXPECT_EQ(filtered.left().at<cv::Vec3w>(5, 640), cv::Vec3w(0, 0, 0));
    const auto centre = *projectPoint(test::scorpionCalibration().left, {-150, 50, 700});
    EXPECT_EQ(filtered.left().at<cv::Vec3w>(cvRound(centre.y), cvRound(centre.x)), cv::Vec3w(4000, 36000, 40000));
    const auto marked = analyzer.markedImages();
    EXPECT_EQ(marked.left().type(), CV_8UC3);
    EXPECT_EQ(marked.size(), scene.pair.size());
    // The centroid cross of the disc is drawn in the first type's colour (yellow).
    EXPECT_EQ(marked.left().at<cv::Vec3b>(cvRound(centre.y), cvRound(centre.x)), cv::Vec3b(0, 255, 255));
    // Away from features the marked image is the 8-bit rendition of the working image.
    EXPECT_EQ(marked.left().at<cv::Vec3b>(5, 640), cv::Vec3b(31, 35, 23));
}

TEST(Pipeline, StageOrderAndNamesAreChecked) {
    auto config = pipelineConfig();
    config.analysis.stages = {"demosaic", "color_filter", "match", "locate_features"};
    try {
        AnalyzeStereoImagePair a(config);
        FAIL();
    } catch (const InvalidArgument& e) {
        // A configuration built in code: no file, no line (docs/config.md's form all the same).
        EXPECT_STREQ(e.what(), "<memory>:0: /avatar/analysis/stages: analysis stage 'match' needs 'locate_features' before it");
    }
    config.analysis.stages = {"demosaic", "sharpen"};
    try {
        AnalyzeStereoImagePair a(config);
        FAIL();
    } catch (const InvalidArgument& e) {
        EXPECT_STREQ(e.what(), "<memory>:0: /avatar/analysis/stages: unknown analysis stage 'sharpen' (known: "
                               "color_filter, demosaic, erode_restore, lighting, locate_features, match, triangulate, "
                               "visibility)");
    }
    config.analysis.stages = {"demosaic", "demosaic"};
    EXPECT_THROW(AnalyzeStereoImagePair a(config), InvalidArgument);
}

TEST(Pipeline, ANewStageIsOneClassAndOneName) {
    // A stage that counts features, inserted by name.
    struct CountStage : ProcessStereoImagePair {
        std::string_view name() const override { return "count"; }
        void processPair(AnalysisFrame& frame) override {
            frame.result.visibilityReason = "features: " + std::to_string(frame.at(Side::Left).features[0].size());
        }
    };
    StageRegistry registry = StageRegistry::builtin();
    registry.add("count", [](const StageContext&) { return std::make_unique<CountStage>(); });
    auto config = pipelineConfig();
    config.analysis.stages = {"demosaic", "color_filter", "locate_features", "count"};
    AnalyzeStereoImagePair analyzer(config, {}, registry);
    EXPECT_EQ(analyzer.analyze(makeScene().pair, 1).visibilityReason, "features: 4");
}

TEST(Pipeline, TheDemosaicIsTheConfiguredOneOnOneThreadOrTwo) {
    // A raw pair of smooth colour and noise: the working images are the
    // configured method's demosaic (the bilinear one through the fused pass),
    // on one thread or two.
    auto config = pipelineConfig();
    config.camera.bayer = true;
    config.camera.channels = 1;
    config.analysis.stages = {"demosaic"};
    std::array<cv::Mat, 2> raw;
    cv::RNG rng(7);
    for (cv::Mat& m : raw) {
        m.create(config.camera.height, config.camera.width, CV_16UC1);
        rng.fill(m, cv::RNG::UNIFORM, 0, 4000);
        for (int y = 0; y < m.rows; ++y)
            for (int x = 0; x < m.cols; ++x) m.at<std::uint16_t>(y, x) += static_cast<std::uint16_t>(20 * x + 30 * y);
    }
    const PairLayout layout{PixelFormat::Bayer, BayerPattern::GR, 16};
    const StereoImagePair pair(raw[0], raw[1], layout);
    for (const auto& [algorithm, method] : {std::pair(DemosaicAlgorithm::Bilinear, DemosaicMethod::Bilinear),
                                            std::pair(DemosaicAlgorithm::EdgeAware, DemosaicMethod::EdgeAware)})
        for (const bool parallel : {true, false}) {
            config.analysis.demosaic = algorithm;
            AnalyzeStereoImagePair analyzer(config);
            analyzer.setParallel(parallel);
            analyzer.analyze(pair, 1);
            for (const Side side : {Side::Left, Side::Right}) {
                const cv::Mat want = demosaic(pair.image(side), layout.bayerPattern, method);
                const cv::Mat& got = analyzer.lastFrame().at(side).image;
                ASSERT_EQ(got.type(), want.type());
                EXPECT_EQ(cv::norm(got, want, cv::NORM_INF), 0.0)
                    << (method == DemosaicMethod::EdgeAware ? "edge-aware" : "bilinear")
                    << (parallel ? ", two threads, " : ", one thread, ") << (side == Side::Left ? "left" : "right");
            }
        }
}

TEST(Pipeline, RejectsPairsThatDoNotFitTheCamera) {
    AnalyzeStereoImagePair analyzer(pipelineConfig());
    cv::Mat small(480, 640, CV_16UC3, kBackground);
    try {
        analyzer.analyze(StereoImagePair(small, small, {PixelFormat::Bgr, BayerPattern::BG, 16}), 1);
        FAIL();
    } catch (const InvalidArgument& e) {
        EXPECT_STREQ(e.what(), "analyze: pair is 640x480 but the camera configuration says 1280x960");
    }
}

TEST(Pipeline, FlatImageIsPoorVisibility) {
    AnalyzeStereoImagePair analyzer(pipelineConfig());
    cv::Mat flat(960, 1280, CV_16UC3, cv::Scalar(30000, 30000, 30000));
    const auto result = analyzer.analyze(StereoImagePair(flat, flat.clone(), {PixelFormat::Bgr, BayerPattern::BG, 16}), 1);
    EXPECT_EQ(result.visibility, Visibility::Poor);
    EXPECT_EQ(result.visibilityReason, "left: contrast 0.0000 below 0.0200; right: contrast 0.0000 below 0.0200");
}

TEST(SampleConfig, ScorpionDisparityBoxCoversTheWorkspace) {
    // Every point 0.4..3 m away that both cameras see must fall inside the
    // shipped epipolar box, or the matcher would never pair it.
    const AvatarConfig c = readConfigFile(std::string(AVATAR_DATA_DIR) + "/config/scorpion.xml");
    const RigidTransform rTl = rightTLeft(c.stereo);
    int visible = 0;
    for (double u = 0; u < 1280; u += 40) {
        for (double v = 0; v < 960; v += 40) {
            for (double z : {400.0, 600.0, 1000.0, 2000.0, 3000.0}) {
                const cv::Point2d n = normalizePixel(c.stereo.left, {u, v});
                const cv::Point3d p(n.x * z, n.y * z, z);
                const auto r = projectPoint(c.stereo.right, transformPoint(rTl, p));
                if (!r || r->x < 0 || r->y < 0 || r->x >= 1280 || r->y >= 960) continue;
                ++visible;
                const double dx = u - r->x, dy = v - r->y;
                EXPECT_TRUE(c.match.boxDxMin < dx && dx < c.match.boxDxMax) << u << "," << v << " at " << z << ": dx " << dx;
                EXPECT_TRUE(c.match.boxDyMin < dy && dy < c.match.boxDyMax) << u << "," << v << " at " << z << ": dy " << dy;
            }
        }
    }
    EXPECT_GT(visible, 1500);
}
