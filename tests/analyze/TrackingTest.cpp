// The region-of-interest tracking mode (config.analysis.tracking,
// analyze/src/RegionTracker.h) on the rendered lab scene: after a
// whole-image search, frames are searched only around the targets found, and
// there the result is what the whole image gives (targets field for field,
// masks and image pixel for pixel); the whole image is searched again every
// fullFrameEvery frames and after a target is lost. And coarse-to-fine
// (config.analysis.coarseToFine): a 2x2-superpixel search, then full
// resolution only around what it found, with the full-resolution targets.

#include "AccuracyHarness.h"
#include "RegionTracker.h"

#include <avatar/analyze/AnalyzeStereoImagePair.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <algorithm>
#include <sstream>
#include <string>
#include <vector>

using namespace avatar;

namespace {

struct Lab {
    AvatarConfig config = readConfigFile(accuracy::dataDir() / "config/scorpion.xml");
    render::Scene scene = render::readSceneFile(accuracy::dataDir() / "scenes/lab.xml");

    /// The lab pair with the duck moved by @p shiftMm.
    StereoImagePair pair(cv::Vec3d shiftMm, std::uint64_t seed) const {
        render::Scene moved = scene;
        if (!moved.targets.empty()) moved.targets[0].centreMm += shiftMm;
        render::RenderOptions options;
        options.sensor = render::sensorFormatFrom(config.camera);
        options.seed = seed;
        return render::render(moved, config.stereo, options).pair;
    }

    AvatarConfig tracking(int fullFrameEvery) const {
        AvatarConfig c = config;
        c.analysis.tracking.enabled = true;
        c.analysis.tracking.fullFrameEvery = fullFrameEvery;
        return c;
    }
};

std::string describe(const VisionTarget& t) {
    std::ostringstream o;
    o.precision(17);
    o << "flags " << t.flags << " model " << static_cast<int>(t.model);
    if (t.positionVisionMm) o << " pos " << *t.positionVisionMm;
    if (t.centroidLeftPx) o << " L " << *t.centroidLeftPx;
    if (t.centroidRightPx) o << " R " << *t.centroidRightPx;
    o << " areas " << t.areaLeftPx << " " << t.areaRightPx << " err " << t.matchError << " res " << t.rayResidualMm
      << " " << t.rayResidualPx;
    if (t.covarianceVisionMm2) o << " cov00 " << t.covarianceVisionMm2->val[0];
    return o.str();
}

int wholeTargets(const VisionTargets& r) {
    int n = 0;
    for (const VisionTarget& t : r.targets) n += (t.flags & kTargetStereo) && (t.flags & kTargetWhole) ? 1 : 0;
    return n;
}

/// @p got equals @p full inside the regions and is 0 outside them.
void expectRegionsOf(const cv::Mat& got, const cv::Mat& full, const std::vector<cv::Rect>& regions,
                     const std::string& what) {
    ASSERT_EQ(got.size(), full.size()) << what;
    ASSERT_EQ(got.type(), full.type()) << what;
    cv::Mat inside(full.size(), CV_8UC1, cv::Scalar(0));
    for (const cv::Rect& r : regions) inside(r).setTo(255);
    cv::Mat expected(full.size(), full.type(), cv::Scalar::all(0));
    full.copyTo(expected, inside);
    cv::Mat diff;
    cv::absdiff(got.reshape(1), expected.reshape(1), diff);
    EXPECT_EQ(cv::countNonZero(diff), 0) << what;
}

/// The tracking frame's result and working images against a whole-image search of the same pair.
void expectTrackingEqualsWhole(const AnalysisFrame& tracked, const AnalysisFrame& whole) {
    ASSERT_TRUE(tracked.tracking());
    EXPECT_FALSE(whole.tracking());
    ASSERT_EQ(tracked.result.targets.size(), whole.result.targets.size());
    for (std::size_t i = 0; i < whole.result.targets.size(); ++i)
        EXPECT_TRUE(tracked.result.targets[i] == whole.result.targets[i])
            << "target " << i << " (" << whole.result.targets[i].type << ") differs: " << describe(tracked.result.targets[i]) << " vs " << describe(whole.result.targets[i]);
    EXPECT_EQ(tracked.result.visibility, whole.result.visibility);
    for (const Side side : {Side::Left, Side::Right}) {
        const std::string name = side == Side::Left ? "left" : "right";
        const std::vector<cv::Rect>& regions = tracked.regionsOf(side);
        ASSERT_FALSE(regions.empty()) << name;
        expectRegionsOf(tracked.at(side).image, AnalyzeStereoImagePair::workingImages(whole).image(side), regions,
                        name + " image");
        ASSERT_EQ(tracked.at(side).masks.size(), whole.at(side).masks.size());
        for (std::size_t t = 0; t < whole.at(side).masks.size(); ++t)
            expectRegionsOf(tracked.at(side).masks[t], whole.at(side).masks[t], regions,
                            name + " mask " + std::to_string(t));
    }
}

}  // namespace

// The duck moves 8 mm between the frames: the regions made around it on the
// first frame still hold it, and the second frame, searched only there, gives
// what a search of the whole image gives.
TEST(Tracking, ATrackingFrameGivesWhatTheWholeImageGives) {
    const Lab lab;
    AnalyzeStereoImagePair tracker(lab.tracking(30)), plain(lab.config);
    const VisionTargets first = tracker.analyze(lab.pair({0, 0, 0}, 1), 0);
    EXPECT_FALSE(tracker.lastFrame().tracking());
    ASSERT_EQ(wholeTargets(first), 2);  // the duck and the arm marker

    const StereoImagePair moved = lab.pair({8, -5, 3}, 2);
    tracker.analyze(moved, 1);
    plain.analyze(moved, 1);
    EXPECT_FALSE(plain.lastFrame().tracking());  // tracking is off by default
    expectTrackingEqualsWhole(tracker.lastFrame(), plain.lastFrame());
    EXPECT_EQ(wholeTargets(tracker.lastFrame().result), 2);
    // It searched a small part of the images.
    for (const Side side : {Side::Left, Side::Right}) {
        double area = 0.0;
        for (const cv::Rect& r : tracker.lastFrame().regionsOf(side)) area += r.area();
        EXPECT_LT(area, 0.2 * moved.size().area());
    }
}

// A whole-image frame's working images are computed only around the features
// (their boxes + 8 px, 0 elsewhere) unless a client keeps them whole: the
// masks, features and targets are the same either way, and workingImages()
// gives the whole images bit for bit.
TEST(Tracking, AWholeImageFrameKeepsItsImagesAroundTheFeaturesOnly) {
    const Lab lab;
    AnalyzeStereoImagePair around(lab.config), whole(lab.config);
    whole.setKeepWholeImages(true);
    const StereoImagePair pair = lab.pair({0, 0, 0}, 7);
    around.analyze(pair, 0);
    whole.analyze(pair, 0);
    const AnalysisFrame& a = around.lastFrame();
    const AnalysisFrame& w = whole.lastFrame();
    EXPECT_TRUE(a.imagesAroundFeatures);
    EXPECT_FALSE(w.imagesAroundFeatures);
    ASSERT_EQ(wholeTargets(a.result), 2);
    ASSERT_EQ(a.result.targets.size(), w.result.targets.size());
    for (std::size_t i = 0; i < w.result.targets.size(); ++i)
        EXPECT_TRUE(a.result.targets[i] == w.result.targets[i]) << describe(a.result.targets[i]);
    EXPECT_EQ(a.result.visibility, w.result.visibility);
    const StereoImagePair again = AnalyzeStereoImagePair::workingImages(a);
    for (const Side side : {Side::Left, Side::Right}) {
        const std::string name = side == Side::Left ? "left" : "right";
        std::vector<cv::Rect> boxes;
        for (const auto& features : a.at(side).features)
            for (const Feature& f : features) boxes.push_back(f.box);
        ASSERT_FALSE(boxes.empty());
        const auto regions = detail::regionsAround(boxes, AnalysisFrame::kImageMarginPx, pair.size());
        expectRegionsOf(a.at(side).image, w.at(side).image, regions, name + " image");
        double area = 0.0;
        for (const cv::Rect& r : regions) area += r.area();
        EXPECT_LT(area, 0.2 * pair.size().area()) << name;
        EXPECT_EQ(cv::norm(again.image(side), w.at(side).image, cv::NORM_INF), 0.0) << name;
        for (std::size_t t = 0; t < w.at(side).masks.size(); ++t)
            EXPECT_EQ(cv::norm(a.at(side).masks[t], w.at(side).masks[t], cv::NORM_INF), 0.0) << name << " mask " << t;
    }
    // The displays are drawn on the whole images.
    const StereoImagePair markedAround = around.markedImages(), markedWhole = whole.markedImages();
    EXPECT_EQ(cv::norm(markedAround.left(), markedWhole.left(), cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(around.filteredImages().right(), whole.filteredImages().right(), cv::NORM_INF), 0.0);

    // An intensity-weighted centroid reads the image before the features are
    // known: the image is then computed whole.
    AvatarConfig weighted = lab.config;
    weighted.analysis.centroid = CentroidMode::IntensityWeighted;
    AnalyzeStereoImagePair weighing(weighted);
    weighing.analyze(pair, 0);
    EXPECT_FALSE(weighing.lastFrame().imagesAroundFeatures);
}

// Around features that cover more than a third of the image, computing the
// image again costs more than writing it whole in the pass: the frame after
// one with such features has its images whole, and the one after a frame with
// small features has them around its features again. The results are the same.
TEST(Tracking, AfterLargeFeaturesTheImagesAreWrittenWhole) {
    const Lab lab;
    Lab near = lab;
    near.scene.targets[0].radiusMm = 230.0;  // the duck and its margin: over a third of each image
    const StereoImagePair large = near.pair({0, 0, 0}, 21), small = lab.pair({0, 0, 0}, 22);
    const auto share = [](const AnalysisFrame& f) {
        std::vector<cv::Rect> boxes;
        for (const auto& features : f.at(Side::Left).features)
            for (const Feature& x : features) boxes.push_back(x.box);
        double area = 0.0;
        for (const cv::Rect& r : detail::regionsAround(boxes, AnalysisFrame::kImageMarginPx, f.original.size()))
            area += r.area();
        return area / static_cast<double>(f.original.size().area());
    };
    AnalyzeStereoImagePair analyzer(lab.config);
    std::string pattern;
    for (const StereoImagePair* pair : {&large, &large, &small, &small}) {
        const VisionTargets got = analyzer.analyze(*pair, pattern.size());
        pattern += analyzer.lastFrame().imagesAroundFeatures ? 'A' : 'W';
        AnalyzeStereoImagePair fresh(lab.config);
        const VisionTargets expected = fresh.analyze(*pair, pattern.size() - 1);
        ASSERT_EQ(got.targets.size(), expected.targets.size()) << pattern;
        for (std::size_t i = 0; i < got.targets.size(); ++i) EXPECT_TRUE(got.targets[i] == expected.targets[i]) << pattern;
        if (pair == &large) EXPECT_GT(share(analyzer.lastFrame()), 1.0 / 3.0);
        else EXPECT_LT(share(analyzer.lastFrame()), 1.0 / 3.0);
    }
    EXPECT_EQ(pattern, "AWWA");
}

// The fused chain hands its masks on with where their on pixels lie, and
// erode_restore restores them in place (MaskRows.h). A chain where another
// stage comes between (here a pass-through one) reads them whole, into
// buffers of its own: the masks, features and targets are the same.
TEST(Tracking, MasksHandedOnWithTheirRowsGiveWhatReadingThemWholeGives) {
    struct PassThrough : ProcessStereoImagePair {
        std::string_view name() const override { return "pass_through"; }
    };
    const Lab lab;
    StageRegistry registry = StageRegistry::builtin();
    registry.add("pass_through", [](const StageContext&) { return std::make_unique<PassThrough>(); });
    AvatarConfig apart = lab.config;
    std::vector<std::string>& stages = apart.analysis.stages;
    stages.insert(std::find(stages.begin(), stages.end(), "erode_restore"), "pass_through");
    AnalyzeStereoImagePair handed(lab.config), whole(apart, {}, registry);
    for (std::uint64_t seed : {11, 12}) {
        const StereoImagePair pair = lab.pair({3.0 * static_cast<double>(seed - 11), 0, 0}, seed);
        const VisionTargets a = handed.analyze(pair, seed);
        const VisionTargets b = whole.analyze(pair, seed);
        ASSERT_EQ(wholeTargets(a), 2);
        ASSERT_EQ(a.targets.size(), b.targets.size());
        for (std::size_t i = 0; i < a.targets.size(); ++i)
            EXPECT_TRUE(a.targets[i] == b.targets[i]) << describe(a.targets[i]) << "\n" << describe(b.targets[i]);
        for (const Side side : {Side::Left, Side::Right}) {
            const ImageWork& x = handed.lastFrame().at(side);
            const ImageWork& y = whole.lastFrame().at(side);
            ASSERT_EQ(x.masks.size(), y.masks.size());
            for (std::size_t t = 0; t < x.masks.size(); ++t) {
                EXPECT_EQ(cv::norm(x.masks[t], y.masks[t], cv::NORM_INF), 0.0) << "mask " << t;
                EXPECT_GT(cv::countNonZero(x.masks[t]), 100) << "mask " << t;
                EXPECT_EQ(x.features[t].size(), y.features[t].size()) << "type " << t;
            }
        }
    }
}

// The same through the stages one by one (the edge-aware demosaic is not fused).
TEST(Tracking, ATrackingFrameOfTheUnfusedChainGivesWhatTheWholeImageGives) {
    Lab lab;
    lab.config.analysis.demosaic = DemosaicAlgorithm::EdgeAware;
    AnalyzeStereoImagePair tracker(lab.tracking(30)), plain(lab.config);
    // OpenCV's edge-aware demosaic leaves the arm marker's right silhouette a
    // little smaller than the bilinear one does (occluded-right): the tracking
    // frame follows the whole target alone, and finds it as the whole image does.
    const int followed = wholeTargets(tracker.analyze(lab.pair({0, 0, 0}, 3), 0));
    ASSERT_GE(followed, 1);
    const StereoImagePair moved = lab.pair({-6, 4, 0}, 4);
    tracker.analyze(moved, 1);
    plain.analyze(moved, 1);
    const AnalysisFrame& t = tracker.lastFrame();
    const AnalysisFrame& w = plain.lastFrame();
    ASSERT_TRUE(t.tracking());
    const auto whole = [](const VisionTargets& r) {
        std::vector<VisionTarget> out;
        for (const VisionTarget& v : r.targets)
            if ((v.flags & kTargetStereo) && (v.flags & kTargetWhole)) out.push_back(v);
        return out;
    };
    const std::vector<VisionTarget> got = whole(t.result), want = whole(w.result);
    ASSERT_EQ(static_cast<int>(want.size()), followed);
    ASSERT_EQ(got.size(), want.size());
    for (std::size_t i = 0; i < want.size(); ++i) EXPECT_TRUE(got[i] == want[i]) << describe(got[i]) << "\n" << describe(want[i]);
}

TEST(Tracking, TheWholeImageEveryNFramesAndAfterATargetIsLost) {
    const Lab lab;
    AnalyzeStereoImagePair tracker(lab.tracking(3)), plain(lab.config);
    const StereoImagePair still = lab.pair({0, 0, 0}, 5);
    std::string pattern;
    for (std::uint64_t i = 0; i < 7; ++i) {
        EXPECT_EQ(wholeTargets(tracker.analyze(still, i)), 2) << "frame " << i;
        pattern += tracker.lastFrame().tracking() ? 'T' : 'W';
    }
    EXPECT_EQ(pattern, "WTTWTTW");

    // The duck jumps 150 mm sideways, out of its region: the tracking frame
    // loses it, and the next frame searches the whole image and finds it.
    const StereoImagePair jumped = lab.pair({150, 0, 0}, 6);
    tracker.analyze(jumped, 7);
    ASSERT_TRUE(tracker.lastFrame().tracking());
    EXPECT_LT(wholeTargets(tracker.lastFrame().result), 2);
    const VisionTargets found = tracker.analyze(jumped, 8);
    EXPECT_FALSE(tracker.lastFrame().tracking());
    EXPECT_EQ(wholeTargets(found), 2);
    EXPECT_TRUE(found.targets == plain.analyze(jumped, 8).targets);
    tracker.analyze(jumped, 9);
    EXPECT_TRUE(tracker.lastFrame().tracking());  // following it again
}

TEST(Tracking, NothingToFollowKeepsSearchingTheWholeImage) {
    Lab lab;
    lab.scene.targets.clear();
    lab.scene.armMarkers.clear();
    AnalyzeStereoImagePair tracker(lab.tracking(30));
    const StereoImagePair empty = lab.pair({0, 0, 0}, 7);
    for (std::uint64_t i = 0; i < 3; ++i) {
        EXPECT_EQ(wholeTargets(tracker.analyze(empty, i)), 0);
        EXPECT_FALSE(tracker.lastFrame().tracking());
    }
}

// Boxes widened by the margin and clipped; regions closer than one clear
// pixel merged (an 8-connected feature cannot span two), the rest kept apart.
TEST(Tracking, RegionsAroundBoxes) {
    const cv::Size size(200, 100);
    EXPECT_EQ(detail::regionsAround({{10, 10, 20, 20}}, 5, size), (std::vector<cv::Rect>{{5, 5, 30, 30}}));
    EXPECT_EQ(detail::regionsAround({{0, 90, 20, 20}}, 5, size), (std::vector<cv::Rect>{{0, 85, 25, 15}}));
    // 5..34 and 36..: one clear column (35) between them: kept apart.
    EXPECT_EQ(detail::regionsAround({{10, 10, 20, 20}, {41, 10, 20, 20}}, 5, size),
              (std::vector<cv::Rect>{{5, 5, 30, 30}, {36, 5, 30, 30}}));
    // Touching diagonally (34,34) and (35,35): merged.
    EXPECT_EQ(detail::regionsAround({{10, 10, 20, 20}, {40, 40, 20, 20}}, 5, size),
              (std::vector<cv::Rect>{{5, 5, 60, 60}}));
    // A chain, given in any order: each joins the ones merged before it.
    EXPECT_EQ(detail::regionsAround({{150, 10, 10, 10}, {10, 10, 10, 10}, {40, 10, 100, 10}, {20, 10, 10, 10},
                                     {30, 10, 10, 10}},
                                    2, size),
              (std::vector<cv::Rect>{{8, 8, 134, 14}, {148, 8, 14, 14}}));
}

// Coarse-to-fine on the lab pair: the superpixel pass finds both targets, the
// full-resolution pass around them gives the targets of a whole-image search
// field for field (centroids equal, not only within 0.05 px).
TEST(CoarseToFine, GivesTheFullResolutionTargets) {
    const Lab lab;
    AvatarConfig config = lab.config;
    config.analysis.coarseToFine.enabled = true;
    AnalyzeStereoImagePair coarse(config), plain(lab.config);
    const StereoImagePair pair = lab.pair({0, 0, 0}, 11);
    const VisionTargets c = coarse.analyze(pair, 0);
    const VisionTargets w = plain.analyze(pair, 0);
    ASSERT_TRUE(coarse.lastFrame().coarse);
    EXPECT_FALSE(plain.lastFrame().coarse);
    ASSERT_EQ(wholeTargets(w), 2);
    ASSERT_EQ(c.targets.size(), w.targets.size());
    for (std::size_t i = 0; i < w.targets.size(); ++i)
        EXPECT_TRUE(c.targets[i] == w.targets[i]) << describe(c.targets[i]) << " vs " << describe(w.targets[i]);
    EXPECT_EQ(c.visibility, w.visibility);  // from the superpixels: the same verdict here
    for (const Side side : {Side::Left, Side::Right}) {
        double area = 0.0;
        for (const cv::Rect& r : coarse.lastFrame().regionsOf(side)) area += r.area();
        EXPECT_GT(area, 0.0);
        EXPECT_LT(area, 0.1 * pair.size().area());
    }
}

// On varied lab scenes (spheres and discs at 0.5-1 m, distractors, occluders,
// targets at the border): every target a whole-image search reports whole is
// reported, field for field, by the coarse-to-fine search.
TEST(CoarseToFine, FindsEveryWholeTargetOfVariedScenes) {
    const AvatarConfig scorpion = readConfigFile(accuracy::dataDir() / "config/scorpion.xml");
    const render::SensorFormat sensor = render::sensorFormatFrom(scorpion.camera);
    const accuracy::SetDefinition set = accuracy::standardSets().front();
    const accuracy::SetConfigs configs = accuracy::makeConfigs(set);
    AvatarConfig coarseConfig = configs.centroid;
    coarseConfig.analysis.coarseToFine.enabled = true;
    AnalyzeStereoImagePair coarse(coarseConfig), plain(configs.centroid);
    const auto scenes = accuracy::makeScenes(set, 4, 21, scorpion.stereo, sensor);
    int compared = 0;
    for (std::size_t k = 0; k < scenes.size(); ++k) {
        render::RenderOptions options;
        options.sensor = sensor;
        options.seed = 2100 + k;
        const StereoImagePair pair = render::render(scenes[k], scorpion.stereo, options).pair;
        const VisionTargets w = plain.analyze(pair, k);
        const VisionTargets c = coarse.analyze(pair, k);
        for (const VisionTarget& t : w.targets) {
            if (!(t.flags & kTargetWhole)) continue;
            ++compared;
            const auto same = std::find_if(c.targets.begin(), c.targets.end(),
                                           [&](const VisionTarget& o) { return o == t; });
            EXPECT_NE(same, c.targets.end()) << "scene " << k << ": " << describe(t) << " not found the same";
        }
    }
    EXPECT_GE(compared, 8);
}

// Nothing in the superpixels: the image is searched whole, and still nothing is found.
TEST(CoarseToFine, NothingCoarseSearchesTheWholeImage) {
    Lab lab;
    lab.config.analysis.coarseToFine.enabled = true;
    AnalyzeStereoImagePair coarse(lab.config);
    const cv::Mat grey(lab.config.camera.height, lab.config.camera.width, CV_16UC1, cv::Scalar(9000));
    const StereoImagePair pair(grey, grey.clone(), {PixelFormat::Bayer, BayerPattern::BG, 16}, {1, 1, {}, {}});
    EXPECT_EQ(coarse.analyze(pair, 0).targets.size(), 0u);
    EXPECT_TRUE(coarse.lastFrame().coarse);
    EXPECT_FALSE(coarse.lastFrame().tracking());
    EXPECT_EQ(coarse.lastFrame().result.visibility, Visibility::Poor);  // measured on the whole image: no contrast
}
