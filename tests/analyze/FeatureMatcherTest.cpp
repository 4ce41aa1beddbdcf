#include "CraftedFeature.h"
#include "SampleConfigs.h"

#include <avatar/analyze/SIPFeatureMatcher.h>
#include <avatar/common/CameraModel.h>
#include <avatar/common/Error.h>
#include <avatar/common/StereoCoordinateCalculator.h>
#include <avatar/config/ConfigXml.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <algorithm>
#include <functional>
#include <cmath>
#include <numeric>
#include <ostream>
#include <string>
#include <vector>

namespace avatar {

// Printing and comparing matches (by indices), for exact match-list
// assertions; static, so that argument-dependent lookup finds them in avatar.
static bool operator==(const FeatureMatch& a, const FeatureMatch& b) {
    return a.left == b.left && a.right == b.right;
}
static void PrintTo(const FeatureMatch& m, std::ostream* os) {
    *os << "{" << m.left << "->" << m.right << ", e=" << m.shapeError << "}";
}

namespace {

using test::featureFromPixels;

using Pairs = std::vector<FeatureMatch>;

// ---------------------------------------------------------------------------
// Crafted features: the geometry of Feature.h computed from a pixel set.


/// A filled w x h rectangle whose upper-left pixel is (x, y).
Feature rect(int x, int y, int w, int h) {
    std::vector<cv::Point> px;
    for (int r = 0; r < h; ++r)
        for (int c = 0; c < w; ++c) px.emplace_back(x + c, y + r);
    return featureFromPixels(px);
}

/// A filled ellipse of semi-axes (a, b) pixels centred on pixel (cx, cy).
Feature ellipse(int cx, int cy, int a, int b) {
    std::vector<cv::Point> px;
    for (int r = -b; r <= b; ++r)
        for (int c = -a; c <= a; ++c)
            if (static_cast<double>(c * c) / (a * a) + static_cast<double>(r * r) / (b * b) <= 1.0)
                px.emplace_back(cx + c, cy + r);
    return featureFromPixels(px);
}

/// A filled right triangle with legs of n pixels, right angle at the lower left.
Feature triangle(int x, int y, int n) {
    std::vector<cv::Point> px;
    for (int r = 0; r < n; ++r)
        for (int c = 0; c <= r; ++c) px.emplace_back(x + c, y + r);
    return featureFromPixels(px);
}

/// The feature moved by whole pixels.
Feature shifted(Feature f, int dx, int dy) {
    const cv::Point d(dx, dy);
    f.centroid += cv::Point2d(dx, dy);
    f.weightedCentroid = f.centroid;
    for (cv::Point& p : f.boundary) p += d;
    f.box.x += dx;
    f.box.y += dy;
    return f;
}

/// A w x h rectangle about @p centroid whose centroid is set to exactly that
/// (sub-pixel) point, e.g. a projection.
Feature rectAt(const cv::Point2d& centroid, int w, int h) {
    Feature f = rect(static_cast<int>(std::lround(centroid.x)) - w / 2,
                     static_cast<int>(std::lround(centroid.y)) - h / 2, w, h);
    f.centroid = f.weightedCentroid = centroid;
    return f;
}

/// A rig of parallel identical cameras, f = 1000 px, 100 mm baseline: a target
/// at depth Z mm appears 100000 / Z px further left in the right image.
StereoSystemConfig parallelRig() {
    StereoSystemConfig s;
    s.left.fc = s.right.fc = {1000.0, 1000.0};
    s.left.cc = s.right.cc = {640.0, 480.0};
    s.om = {0.0, 0.0, 0.0};
    s.translationMm = {-100.0, 0.0, 0.0};
    return s;
}

MatchConfig config(MatchMethod method) {
    MatchConfig m;
    m.method = method;
    return m;
}

Pairs matchWith(const MatchConfig& m, const StereoSystemConfig& s, const std::vector<Feature>& l,
                const std::vector<Feature>& r) {
    return SIPFeatureMatcher(m, s).match(l, r);
}

// ---------------------------------------------------------------------------
// shapeError

const ShapeMatchConfig kUnitWeights{};  // magnitude 1, direction 1

TEST(ShapeError, IsZeroForTranslatedCopiesAndSymmetric) {
    const Feature a = ellipse(300, 200, 12, 7);
    EXPECT_DOUBLE_EQ(shapeError(a, a, kUnitWeights), 0.0);
    EXPECT_DOUBLE_EQ(shapeError(a, shifted(a, -93, 4), kUnitWeights), 0.0);
    const Feature b = rect(0, 0, 30, 11);
    EXPECT_GT(shapeError(a, b, kUnitWeights), 0.0);
    EXPECT_DOUBLE_EQ(shapeError(a, b, kUnitWeights), shapeError(b, a, kUnitWeights));
}

TEST(ShapeError, OnePixelAgainstAOneRowFeatureByHand) {
    // A one-pixel feature: all nine points coincide, M = 0, S = 0.
    const Feature dot = rect(10, 10, 1, 1);
    // A 2 x 1 feature: four boundary points at (0,0), four at (1,0), centroid
    // (0.5, 0). Of the 36 pairs 12 coincide, the other 24 have unit S.
    const Feature bar = rect(0, 0, 2, 1);
    // magnitude: sum|M_a - M_b| / (0.5 (0 + sum M_b)) = 2;  direction: 24 / 36.
    EXPECT_NEAR(shapeError(dot, bar, {1.0, 0.0, 1e9, 4.0}), 2.0, 1e-12);
    EXPECT_NEAR(shapeError(dot, bar, {0.0, 1.0, 1e9, 4.0}), 24.0 / 36.0, 1e-12);
    EXPECT_NEAR(shapeError(dot, bar, {2.0, 3.0, 1e9, 4.0}), 4.0 + 2.0, 1e-12);
    // Two point-like features: no NaN, no difference.
    const double e = shapeError(dot, rect(400, 3, 1, 1), kUnitWeights);
    EXPECT_FALSE(std::isnan(e));
    EXPECT_EQ(e, 0.0);
}

TEST(ShapeError, InvariantToAScaleCommonToBothFeatures) {
    auto scaled = [](const Feature& f, int k) {
        Feature g = f;
        g.centroid *= k;
        for (cv::Point& p : g.boundary) p *= k;
        return g;
    };
    const Feature a = ellipse(100, 100, 9, 5);
    const Feature b = triangle(20, 30, 12);
    const double e = shapeError(a, b, kUnitWeights);
    EXPECT_NEAR(shapeError(scaled(a, 3), scaled(b, 3), kUnitWeights), e, 1e-12);
    // A size difference alone still counts: a 2x copy has mean |dM| = mean M_a
    // and scale 1.5 mean M_a, a magnitude term of 2/3 and no direction term.
    EXPECT_NEAR(shapeError(a, scaled(a, 2), kUnitWeights), 2.0 / 3.0, 1e-12);
}

TEST(ShapeError, BoundedByTheWeights) {
    const std::vector<Feature> shapes = {rect(0, 0, 1, 1),  rect(0, 0, 5, 1),      rect(0, 0, 1, 9),
                                         rect(0, 0, 8, 8),  ellipse(50, 50, 20, 3), triangle(0, 0, 15),
                                         ellipse(9, 9, 4, 4)};
    const ShapeMatchConfig w{0.7, 1.9, 1e9, 4.0};
    for (const Feature& a : shapes)
        for (const Feature& b : shapes) {
            const double e = shapeError(a, b, w);
            EXPECT_TRUE(std::isfinite(e));
            EXPECT_GE(e, 0.0);
            EXPECT_LE(e, 2.0 * (0.7 + 1.9) + 1e-12);
        }
}

// ---------------------------------------------------------------------------
// Behaviour every method shares, on the parallel rig where all three agree:
// the scene's targets are 1000 mm away (100 px disparity, same rows).

class EveryMethod : public ::testing::TestWithParam<MatchMethod> {
protected:
    MatchConfig cfg() const { return config(GetParam()); }
};

TEST_P(EveryMethod, TwoTargetScene) {
    const Feature box = rect(580, 390, 40, 20);
    const Feature disc = ellipse(300, 500, 15, 15);
    const std::vector<Feature> left = {box, disc};
    const std::vector<Feature> right = {shifted(disc, -100, 0), shifted(box, -100, 0)};
    const Pairs m = matchWith(cfg(), parallelRig(), left, right);
    EXPECT_EQ(m, (Pairs{{0, 1}, {1, 0}}));
    for (const FeatureMatch& x : m) EXPECT_EQ(x.shapeError, 0.0);
}

TEST_P(EveryMethod, NothingToMatchInEmptyLists) {
    const std::vector<Feature> some = {rect(500, 400, 10, 10)};
    const std::vector<Feature> none;
    EXPECT_TRUE(matchWith(cfg(), parallelRig(), none, none).empty());
    EXPECT_TRUE(matchWith(cfg(), parallelRig(), some, none).empty());
    EXPECT_TRUE(matchWith(cfg(), parallelRig(), none, some).empty());
}

TEST_P(EveryMethod, AreaRatioLimit) {
    // 20 x 20 = 400 px against 40 x 40 = 1600 px (ratio 4) and 41 x 40 = 1640 px (4.1).
    const std::vector<Feature> left = {rect(600, 300, 20, 20)};
    MatchConfig m = cfg();
    m.shape.maxAreaRatio = 4.0;
    EXPECT_EQ(matchWith(m, parallelRig(), left, {rect(490, 290, 40, 40)}), (Pairs{{0, 0}}));
    EXPECT_TRUE(matchWith(m, parallelRig(), left, {rect(490, 290, 41, 40)}).empty());
    // Either way round.
    EXPECT_TRUE(matchWith(m, parallelRig(), {rect(590, 290, 41, 40)}, {rect(500, 300, 20, 20)})
                    .empty());
}

TEST_P(EveryMethod, MaxShapeErrorLimit) {
    const std::vector<Feature> left = {rect(600, 300, 20, 20)};
    const std::vector<Feature> right = {ellipse(510, 310, 10, 10)};
    const double e = shapeError(left[0], right[0], kUnitWeights);
    MatchConfig m = cfg();
    m.shape.maxError = e;
    ASSERT_EQ(matchWith(m, parallelRig(), left, right).size(), 1u);
    EXPECT_DOUBLE_EQ(matchWith(m, parallelRig(), left, right)[0].shapeError, e);
    m.shape.maxError = e * 0.999;
    EXPECT_TRUE(matchWith(m, parallelRig(), left, right).empty());
}

TEST_P(EveryMethod, TwoLeftFeaturesClaimingOneRightFeature) {
    // Both left rectangles lie in each other's disparity range of the single
    // right one; the exact copy (error 0) keeps it, the other is voided.
    const Feature target = rect(500, 400, 40, 20);
    const std::vector<Feature> left = {rect(609, 400, 42, 20), shifted(target, 100, 0)};
    const std::vector<Feature> right = {target};
    MatchConfig m = cfg();
    m.maxEpipolarDistancePx = 3.0;
    const Pairs result = matchWith(m, parallelRig(), left, right);
    EXPECT_GT(shapeError(left[0], target, m.shape), 0.0);
    EXPECT_EQ(result, (Pairs{{1, 0}}));
    // Listed the other way round, the same feature wins.
    EXPECT_EQ(matchWith(m, parallelRig(), {left[1], left[0]}, right), (Pairs{{0, 0}}));
}

TEST_P(EveryMethod, OnePixelFeaturesMatchWithoutNaN) {
    const std::vector<Feature> left = {rect(700, 480, 1, 1), rect(300, 200, 1, 3)};
    const std::vector<Feature> right = {rect(200, 200, 1, 3), rect(600, 480, 1, 1)};
    const Pairs m = matchWith(cfg(), parallelRig(), left, right);
    ASSERT_EQ(m, (Pairs{{0, 1}, {1, 0}}));
    for (const FeatureMatch& x : m) EXPECT_EQ(x.shapeError, 0.0);
}

TEST_P(EveryMethod, RejectsFeaturesWithoutArea) {
    Feature empty = rect(500, 500, 3, 3);
    empty.area = 0;
    const std::vector<Feature> good = {rect(500, 500, 3, 3)};
    EXPECT_THROW(matchWith(cfg(), parallelRig(), {empty}, good), InvalidArgument);
    Feature nan = good[0];
    nan.centroid.x = std::nan("");
    EXPECT_THROW(matchWith(cfg(), parallelRig(), good, {nan}), InvalidArgument);
}

TEST_P(EveryMethod, ExactCopiesGoToTheLowestIndex) {
    // Three copies of the left target (equal errors, 0) in candidate places,
    // listed with the lowest index last in the image; a look-alike (one pixel
    // less) in front. The lowest index wins, in every method.
    const Feature l = rect(600, 400, 12, 8);
    const std::vector<Feature> right = {shifted(l, -120, 0), shifted(l, -100, 0),
                                        rect(506, 400, 11, 8), shifted(l, -60, 0)};
    MatchConfig m = cfg();
    m.minRangeMm = 500.0;
    m.maxEpipolarDistancePx = 1.0;
    const Pairs result = matchWith(m, parallelRig(), {l}, right);
    ASSERT_EQ(result, (Pairs{{0, 0}}));
    EXPECT_EQ(result[0].shapeError, 0.0);
    // Without the first copy, the next lowest index.
    EXPECT_EQ(matchWith(m, parallelRig(), {l}, {right[2], right[1], right[3]}), (Pairs{{0, 1}}));
}

INSTANTIATE_TEST_SUITE_P(Matcher, EveryMethod,
                         ::testing::Values(MatchMethod::Shape, MatchMethod::EpipolarBox,
                                           MatchMethod::EpipolarLine),
                         [](const ::testing::TestParamInfo<MatchMethod>& param) {
                             switch (param.param) {
                                 case MatchMethod::Shape:
                                     return std::string("Shape");
                                 case MatchMethod::EpipolarBox:
                                     return std::string("EpipolarBox");
                                 case MatchMethod::EpipolarLine:
                                     return std::string("EpipolarLine");
                             }
                             return std::string("Unknown");
                         });

// ---------------------------------------------------------------------------
// Where the methods differ.

TEST(ShapeMethod, CentroidXConstraint) {
    const MatchConfig m = config(MatchMethod::Shape);
    const Feature l = rect(300, 300, 20, 10);
    // The identical copy to the right (x_right > x_left) or straight across
    // (x_right == x_left) is behind the cameras / at infinity: not a match.
    EXPECT_TRUE(matchWith(m, parallelRig(), {l}, {shifted(l, 50, 0)}).empty());
    EXPECT_TRUE(matchWith(m, parallelRig(), {l}, {l}).empty());
    EXPECT_EQ(matchWith(m, parallelRig(), {l}, {shifted(l, -1, 0)}), (Pairs{{0, 0}}));
    // A perfect copy on the wrong side loses to a worse shape on the right side.
    const std::vector<Feature> right = {shifted(l, 50, 0), rect(200, 300, 22, 10)};
    EXPECT_EQ(matchWith(m, parallelRig(), {l}, right), (Pairs{{0, 1}}));
}

TEST(ShapeMethod, IgnoresRowsAndTakesTheBestShape) {
    // The shape method has no row constraint: a copy 300 rows away beats a
    // similar shape on the same row.
    const Feature l = triangle(600, 300, 20);
    const std::vector<Feature> right = {ellipse(510, 310, 10, 10), shifted(l, -100, 300)};
    EXPECT_EQ(matchWith(config(MatchMethod::Shape), parallelRig(), {l}, right), (Pairs{{0, 1}}));
    EXPECT_EQ(matchWith(config(MatchMethod::EpipolarBox), parallelRig(), {l}, right),
              (Pairs{{0, 0}}));
}

TEST(EpipolarBox, TwoCandidatesResolvedByShape) {
    const Feature l = rect(580, 390, 40, 20);
    // Both centroids fall in the box; the rectangle has the same shape.
    const std::vector<Feature> right = {ellipse(520, 402, 20, 10), shifted(l, -120, -3)};
    const Pairs m = matchWith(config(MatchMethod::EpipolarBox), parallelRig(), {l}, right);
    EXPECT_EQ(m, (Pairs{{0, 1}}));
    EXPECT_EQ(m[0].shapeError, 0.0);
    // A single candidate is a match whatever its shape (within the limits).
    EXPECT_EQ(matchWith(config(MatchMethod::EpipolarBox), parallelRig(), {l}, {right[0]}),
              (Pairs{{0, 0}}));
}

TEST(EpipolarBox, BoundsAreStrict) {
    MatchConfig m = config(MatchMethod::EpipolarBox);
    m.boxDxMin = 50.0;
    m.boxDxMax = 150.0;
    m.boxDyMin = -5.0;
    m.boxDyMax = 5.0;
    const Feature l = rect(600, 400, 10, 10);
    auto matches = [&](int dx, int dy) {
        return !matchWith(m, parallelRig(), {l}, {shifted(l, -dx, -dy)}).empty();
    };
    EXPECT_TRUE(matches(51, 0));
    EXPECT_FALSE(matches(50, 0));
    EXPECT_TRUE(matches(149, 4));
    EXPECT_FALSE(matches(150, 0));
    EXPECT_FALSE(matches(100, 5));
    EXPECT_FALSE(matches(100, -5));
    EXPECT_TRUE(matches(100, -4));
}

TEST(Methods, IdenticalTargetsSideBySide) {
    // Two identical rectangles 250 px apart at 1000 mm (disparity 100 px). The
    // right list has them in the other order: B' = 0, A' = 1.
    const Feature a = rect(680, 390, 40, 20);
    const Feature b = rect(430, 390, 40, 20);
    const std::vector<Feature> left = {a, b};
    const std::vector<Feature> right = {shifted(b, -100, 0), shifted(a, -100, 0)};
    const Pairs truth = {{0, 1}, {1, 0}};

    // Shape alone cannot tell them apart: A sees B' and A' with error 0 and
    // takes the lower index B'; B can only take B' (A' is right of it); the
    // tie of the repeat goes to A. Voided, B stays unmatched: one wrong match.
    MatchConfig shapeVoid = config(MatchMethod::Shape);
    shapeVoid.repeats = RepeatMatchPolicy::Void;
    EXPECT_EQ(matchWith(shapeVoid, parallelRig(), left, right), (Pairs{{0, 0}}));
    // Re-paired (the default), B takes B' back and A moves to A' (added error
    // 0, the only path): both right.
    EXPECT_EQ(matchWith(config(MatchMethod::Shape), parallelRig(), left, right), truth);

    // A box that holds the realistic disparities (50..150 px) pairs them right.
    MatchConfig box = config(MatchMethod::EpipolarBox);
    box.boxDxMin = 50.0;
    box.boxDxMax = 150.0;
    EXPECT_EQ(matchWith(box, parallelRig(), left, right), truth);
    // The default box (0..400 px) holds both for A: the same failure as shape
    // when voided, the same cure when re-paired.
    MatchConfig wideVoid = config(MatchMethod::EpipolarBox);
    wideVoid.repeats = RepeatMatchPolicy::Void;
    EXPECT_EQ(matchWith(wideVoid, parallelRig(), left, right), (Pairs{{0, 0}}));
    EXPECT_EQ(matchWith(config(MatchMethod::EpipolarBox), parallelRig(), left, right), truth);

    // The epipolar line with a depth range of 600..2000 mm (50..167 px).
    MatchConfig line = config(MatchMethod::EpipolarLine);
    line.minRangeMm = 600.0;
    line.maxRangeMm = 2000.0;
    EXPECT_EQ(matchWith(line, parallelRig(), left, right), truth);
}

TEST(RepeatMatches, ALookAlikeThatTookAnotherTargetsImageGivesItBack) {
    // Two look-alikes 250 px apart at 1000 mm (disparity 100 px), in a box of
    // 0..400 px: A (left 0) sees its own image A' and B's image B'; B (left
    // 1) sees B' only. A looks more like B' (error 0) than like its own A'
    // (the right camera sees it two rows taller), and more like B' than B
    // does, so HandleRepeatMatches gives B' to A and B loses it.
    const Feature a = rect(680, 390, 40, 20);
    const Feature b = rect(430, 390, 40, 19);
    const std::vector<Feature> left = {a, b};
    const std::vector<Feature> right = {rect(580, 391, 40, 22), shifted(a, -350, 0)};
    MatchConfig m = config(MatchMethod::EpipolarBox);
    const ShapeMatchConfig& w = m.shape;
    ASSERT_EQ(shapeError(a, right[1], w), 0.0);
    ASSERT_LT(shapeError(a, right[1], w), shapeError(b, right[1], w));
    ASSERT_LT(shapeError(a, right[1], w), shapeError(a, right[0], w));

    m.repeats = RepeatMatchPolicy::Void;
    const Pairs voided = matchWith(m, parallelRig(), left, right);
    EXPECT_EQ(voided, (Pairs{{0, 1}}));  // a wrong pair, and B unmatched

    m.repeats = RepeatMatchPolicy::Reassign;
    const Pairs repaired = matchWith(m, parallelRig(), left, right);
    ASSERT_EQ(repaired, (Pairs{{0, 0}, {1, 1}}));
    EXPECT_EQ(repaired[0].shapeError, shapeError(a, right[0], w));
    EXPECT_EQ(repaired[1].shapeError, shapeError(b, right[1], w));
}

TEST(RepeatMatches, NoPathLeavesTheLoserUnmatchedAndKeepsEveryOtherPair) {
    // Three left features claim one right feature; the two losers have no
    // other candidate, so re-pairing adds nothing, and an unrelated pair
    // elsewhere is untouched.
    const Feature target = rect(500, 400, 40, 20);
    const Feature other = ellipse(900, 700, 12, 12);
    const std::vector<Feature> left = {rect(609, 400, 42, 20), shifted(target, 100, 0),
                                       rect(611, 400, 44, 20), shifted(other, 100, 0)};
    const std::vector<Feature> right = {target, other};
    MatchConfig m = config(MatchMethod::EpipolarBox);
    m.boxDxMin = 50.0;
    m.boxDxMax = 150.0;
    const Pairs expected = {{1, 0}, {3, 1}};
    EXPECT_EQ(matchWith(m, parallelRig(), left, right), expected);
    m.repeats = RepeatMatchPolicy::Void;
    EXPECT_EQ(matchWith(m, parallelRig(), left, right), expected);
}

TEST(EpipolarLine, DepthRangeExcludesCandidatesOnTheLine) {
    MatchConfig m = config(MatchMethod::EpipolarLine);
    m.minRangeMm = 500.0;
    m.maxRangeMm = 2000.0;
    const Feature l = rect(600, 400, 20, 20);
    // On the same row: a perfect copy at 400 mm (250 px) and a circle at 1000 mm.
    const std::vector<Feature> right = {shifted(l, -250, 0), ellipse(510, 410, 10, 10)};
    EXPECT_EQ(matchWith(m, parallelRig(), {l}, right), (Pairs{{0, 1}}));
    m.minRangeMm = 300.0;
    EXPECT_EQ(matchWith(m, parallelRig(), {l}, right), (Pairs{{0, 0}}));
    // Just beyond the near limit (205 px: 488 mm < 500 mm) and just inside it.
    m.minRangeMm = 500.0;
    EXPECT_EQ(matchWith(m, parallelRig(), {l}, {shifted(l, -205, 0), right[1]}), (Pairs{{0, 1}}));
    EXPECT_EQ(matchWith(m, parallelRig(), {l}, {shifted(l, -199, 0), right[1]}), (Pairs{{0, 0}}));
    // Off the line by more than maxEpipolarDistancePx: not a candidate.
    m.maxEpipolarDistancePx = 3.5;
    EXPECT_TRUE(matchWith(m, parallelRig(), {l}, {shifted(l, -100, 4)}).empty());
    EXPECT_EQ(matchWith(m, parallelRig(), {l}, {shifted(l, -100, 3)}), (Pairs{{0, 0}}));
}

// ---------------------------------------------------------------------------
// A rotated (verging and rolled) rig with lens distortion and skew.

StereoSystemConfig rotatedRig() {
    StereoSystemConfig s;
    s.left.fc = {1000.0, 1004.0};
    s.left.cc = {640.0, 480.0};
    s.left.alphaC = 0.004;
    s.left.kc = {-0.12, 0.05, 0.001, -0.0008, 0.0};
    s.right.fc = {990.0, 995.0};
    s.right.cc = {652.0, 470.0};
    s.right.alphaC = -0.003;
    s.right.kc = {-0.1, 0.03, -0.0005, 0.001, 0.0};
    s.om = {0.03, -0.18, 0.12};  // toe-in about y, 7 degrees of roll
    s.translationMm = {-150.0, 12.0, 25.0};
    return s;
}

struct Scene {
    std::vector<Feature> left, right;
    Pairs truth;
};

/// Targets at the given left-camera points, imaged by both cameras as identical
/// 16 x 12 rectangles at the exact projections (shape cannot tell them apart);
/// the right list is reversed.
Scene sceneOf(const StereoSystemConfig& s, const std::vector<cv::Point3d>& pointsLeftMm) {
    Scene scene;
    const RigidTransform rTl = rightTLeft(s);
    const int n = static_cast<int>(pointsLeftMm.size());
    scene.right.resize(pointsLeftMm.size());
    for (int i = 0; i < n; ++i) {
        const cv::Point3d& X = pointsLeftMm[static_cast<std::size_t>(i)];
        const auto pl = projectPoint(s.left, X);
        const auto pr = projectPoint(s.right, transformPoint(rTl, X));
        EXPECT_TRUE(pl && pr);
        scene.left.push_back(rectAt(*pl, 16, 12));
        scene.right[static_cast<std::size_t>(n - 1 - i)] = rectAt(*pr, 16, 12);
        scene.truth.push_back({i, n - 1 - i});
    }
    return scene;
}

TEST(EpipolarLine, RotatedRigWhereTheBoxFails) {
    const StereoSystemConfig s = rotatedRig();
    std::vector<cv::Point3d> points;
    const double depths[] = {800.0, 1100.0, 1500.0, 2100.0};
    int k = 0;
    for (double y : {-0.25, 0.0, 0.25})
        for (double x : {-0.35, -0.1, 0.15, 0.4}) {
            const double z = depths[k++ % 4];
            points.emplace_back(x * z, y * z, z);
        }
    const Scene scene = sceneOf(s, points);

    MatchConfig line = config(MatchMethod::EpipolarLine);
    line.minRangeMm = 600.0;
    line.maxRangeMm = 2500.0;
    line.maxEpipolarDistancePx = 1.0;
    EXPECT_EQ(matchWith(line, s, scene.left, scene.right), scene.truth);

    // The same scene through the default box: the roll moves targets by tens
    // of rows and the toe-in changes disparities, so pairs are lost or wrong.
    const Pairs box = matchWith(config(MatchMethod::EpipolarBox), s, scene.left, scene.right);
    int correct = 0;
    for (const FeatureMatch& m : box)
        correct += std::count(scene.truth.begin(), scene.truth.end(), m) > 0 ? 1 : 0;
    EXPECT_LT(correct, static_cast<int>(scene.truth.size()) / 2);
}

TEST(FundamentalMatrix, ProjectedPointsLieOnTheirEpipolarLines) {
    StereoSystemConfig s = rotatedRig();
    s.left.kc = s.right.kc = {0, 0, 0, 0, 0};  // pixels are undistorted pixels
    const cv::Matx33d F = fundamentalMatrix(stereoGeometry(s));
    const RigidTransform rTl = rightTLeft(s);
    // The thesis's printed F = K_r^T E K_l^-1, for comparison.
    const cv::Matx33d R = rodrigues(s.om);
    const cv::Vec3d T(s.translationMm[0], s.translationMm[1], s.translationMm[2]);
    const cv::Matx33d Tx(0, -T[2], T[1], T[2], 0, -T[0], -T[1], T[0], 0);
    auto K = [](const CameraIntrinsics& c) {
        return cv::Matx33d(c.fc[0], c.fc[0] * c.alphaC, c.cc[0], 0, c.fc[1], c.cc[1], 0, 0, 1);
    };
    const cv::Matx33d typo = K(s.right).t() * Tx * R * K(s.left).inv();

    double worstTypo = 0.0;
    for (double z : {300.0, 1000.0, 4000.0})
        for (double y : {-0.3, 0.1, 0.3})
            for (double x : {-0.4, 0.0, 0.35}) {
                const cv::Point3d X(x * z, y * z, z);
                const auto pl = projectPoint(s.left, X);
                const auto pr = projectPoint(s.right, transformPoint(rTl, X));
                ASSERT_TRUE(pl && pr);
                const cv::Vec3d l(pl->x, pl->y, 1.0), r(pr->x, pr->y, 1.0);
                const cv::Vec3d line = F * l;
                // p_r^T F p_l as the pixel distance of p_r from the line F p_l.
                EXPECT_LT(std::abs(r.dot(line)) / std::hypot(line[0], line[1]), 1e-9);
                const cv::Vec3d lineT = typo * l;
                worstTypo = std::max(worstTypo, std::abs(r.dot(lineT)) / std::hypot(lineT[0], lineT[1]));
            }
    EXPECT_GT(worstTypo, 10.0);  // the printed formula is not a fundamental matrix

    // The left epipole (the right camera's centre seen by the left camera) is F's null vector.
    const cv::Vec3d centreRightInLeft = -(R.t() * T);
    const cv::Vec3d el = K(s.left) * centreRightInLeft;
    const cv::Vec3d Fe = F * el;
    EXPECT_LT(cv::norm(Fe), 1e-12 * cv::norm(F) * cv::norm(el));
}

TEST(FundamentalMatrix, HoldsForUndistortedPixelsOfADistortedRig) {
    const StereoSystemConfig s = rotatedRig();
    const cv::Matx33d F = fundamentalMatrix(stereoGeometry(s));
    const RigidTransform rTl = rightTLeft(s);
    auto undistorted = [](const CameraIntrinsics& c, const cv::Point2d& px) {
        const cv::Point2d u = normalizedToPixel(c, normalizePixel(c, px));
        return cv::Vec3d(u.x, u.y, 1.0);
    };
    for (double z : {500.0, 2000.0})
        for (double y : {-0.2, 0.2})
            for (double x : {-0.3, 0.3}) {
                const cv::Point3d X(x * z, y * z, z);
                const cv::Vec3d l = undistorted(s.left, *projectPoint(s.left, X));
                const cv::Vec3d r =
                    undistorted(s.right, *projectPoint(s.right, transformPoint(rTl, X)));
                const cv::Vec3d line = F * l;
                EXPECT_LT(std::abs(r.dot(line)) / std::hypot(line[0], line[1]), 1e-6);
            }
}

// ---------------------------------------------------------------------------
// The candidate grid never loses a candidate: crowded random scenes give the
// same matches as a brute-force scan of every pair with the documented rules.

struct Rng {
    unsigned state;
    double uniform(double lo, double hi) {
        state = state * 1664525u + 1013904223u;
        return lo + (hi - lo) * ((state >> 8) / 16777216.0);
    }
};

/// What a brute-force scan saw: the candidates that passed geometry, area and
/// maxError, the left features whose least error two or more candidates share
/// exactly, and those with another candidate within 1e-12 of the least but
/// not equal to it (look-alikes that differ only by rounding).
struct BruteForceStats {
    std::size_t candidates{0};
    std::size_t tiedBest{0};
    std::size_t nearTiedBest{0};
};

/// The documented rules of SIPFeatureMatcher (header), pair by pair.
Pairs bruteForce(const MatchConfig& m, const StereoSystemConfig& s, const std::vector<Feature>& l,
                 const std::vector<Feature>& r, BruteForceStats* stats = nullptr) {
    const cv::Matx33d F = fundamentalMatrix(stereoGeometry(s));
    const StereoCoordinateCalculator tri(stereoGeometry(s));
    auto ideal = [](const CameraIntrinsics& c, const cv::Point2d& px) {
        const cv::Point2d u = normalizedToPixel(c, normalizePixel(c, px));
        return cv::Vec3d(u.x, u.y, 1.0);
    };
    std::vector<int> best(l.size(), -1);
    std::vector<double> bestError(l.size(), 0.0);
    // Every admissible (right, error) of each left feature, for Reassign.
    std::vector<std::vector<std::pair<int, double>>> admissible(l.size());
    for (std::size_t i = 0; i < l.size(); ++i) {
        std::vector<double> errors;
        for (std::size_t j = 0; j < r.size(); ++j) {
            const double dx = l[i].centroid.x - r[j].centroid.x;
            const double dy = l[i].centroid.y - r[j].centroid.y;
            bool geometric = false;
            if (m.method == MatchMethod::Shape) {
                geometric = dx > 0.0;
            } else if (m.method == MatchMethod::EpipolarBox) {
                geometric = m.boxDxMin < dx && dx < m.boxDxMax && m.boxDyMin < dy && dy < m.boxDyMax;
            } else {
                // Each quantity in the matcher's own floating-point form, so
                // that targets exactly on a limit (the scenes have them) are
                // judged alike: the line normalised before the dot product,
                // the range ends as K_r (z R x_l + T).
                const cv::Point2d xl = normalizePixel(s.left, l[i].centroid);
                const cv::Matx33d kl(s.left.fc[0], s.left.fc[0] * s.left.alphaC, s.left.cc[0], 0.0,
                                     s.left.fc[1], s.left.cc[1], 0.0, 0.0, 1.0);
                const cv::Matx33d kr(s.right.fc[0], s.right.fc[0] * s.right.alphaC, s.right.cc[0], 0.0,
                                     s.right.fc[1], s.right.cc[1], 0.0, 0.0, 1.0);
                cv::Vec3d line = F * (kl * cv::Vec3d(xl.x, xl.y, 1.0));
                line /= std::hypot(line[0], line[1]);
                const cv::Vec3d q = ideal(s.right, r[j].centroid);
                const double d = std::abs(line[0] * q[0] + line[1] * q[1] + line[2]);
                // The right-image ends of the depth range on the left ray (both
                // in front of the right camera on the rigs of these tests).
                const cv::Vec3d Rd = rodrigues(s.om) * cv::Vec3d(xl.x, xl.y, 1.0);
                const cv::Vec3d T(s.translationMm[0], s.translationMm[1], s.translationMm[2]);
                auto endAt = [&](double z) {
                    const cv::Vec3d h = kr * (z * Rd + T);
                    return cv::Point2d(h[0] / h[2], h[1] / h[2]);
                };
                const cv::Point2d a = endAt(m.minRangeMm), b = endAt(m.maxRangeMm);
                const cv::Point2d ab = b - a;
                const double t = std::clamp((cv::Point2d(q[0], q[1]) - a).dot(ab) / ab.dot(ab), 0.0, 1.0);
                const cv::Point2d off = cv::Point2d(q[0], q[1]) - (a + ab * t);
                const double toSegment = std::hypot(off.x, off.y);
                const auto p = tri.triangulate(l[i].centroid, r[j].centroid);
                geometric = d <= m.maxEpipolarDistancePx &&
                            toSegment <= 2.0 * m.maxEpipolarDistancePx + 2.0 && p &&
                            p->leftMm.z >= m.minRangeMm && p->leftMm.z <= m.maxRangeMm;
            }
            const double lo = std::min(l[i].area, r[j].area), hi = std::max(l[i].area, r[j].area);
            if (!geometric || hi > m.shape.maxAreaRatio * lo) continue;
            const double e = shapeError(l[i], r[j], m.shape);
            if (e > m.shape.maxError) continue;
            errors.push_back(e);
            admissible[i].emplace_back(static_cast<int>(j), e);
            if (best[i] < 0 || e < bestError[i] || (e == bestError[i] && static_cast<int>(j) < best[i])) {
                best[i] = static_cast<int>(j);
                bestError[i] = e;
            }
        }
        if (stats && !errors.empty()) {
            stats->candidates += errors.size();
            const double least = bestError[i];
            stats->tiedBest += std::count(errors.begin(), errors.end(), least) > 1 ? 1 : 0;
            stats->nearTiedBest += std::any_of(errors.begin(), errors.end(), [&](double e) {
                return e != least && e - least <= 1e-12;
            });
        }
    }
    std::vector<int> held(l.size(), -1);
    std::vector<double> heldError(l.size(), 0.0);
    std::vector<int> owner(r.size(), -1);
    for (std::size_t i = 0; i < l.size(); ++i) {
        if (best[i] < 0) continue;
        bool keeps = true;
        for (std::size_t k = 0; k < l.size(); ++k)
            if (k != i && best[k] == best[i] &&
                (bestError[k] < bestError[i] || (bestError[k] == bestError[i] && k < i)))
                keeps = false;
        if (!keeps) continue;
        held[i] = best[i];
        heldError[i] = bestError[i];
        owner[static_cast<std::size_t>(best[i])] = static_cast<int>(i);
    }
    if (m.repeats == RepeatMatchPolicy::Reassign) {
        // Each left feature's four best admissible right features (error,
        // then index); every path of one, two and three left features from
        // each voided one, in left order; the best by (added error, length,
        // rights).
        for (auto& options : admissible) {
            std::sort(options.begin(), options.end(), [](const auto& a, const auto& b) {
                return a.second < b.second || (a.second == b.second && a.first < b.first);
            });
            if (options.size() > 4) options.resize(4);
        }
        struct Path {
            std::array<int, 3> lefts{}, rights{};
            std::array<double, 3> errors{};
            std::size_t length{0};
            double cost{0.0};
        };
        const auto better = [](const Path& a, const Path& b) {
            if (a.cost != b.cost) return a.cost < b.cost;
            if (a.length != b.length) return a.length < b.length;
            return std::lexicographical_compare(a.rights.begin(), a.rights.begin() + a.length,
                                                b.rights.begin(), b.rights.begin() + b.length);
        };
        for (std::size_t u = 0; u < l.size(); ++u) {
            if (best[u] < 0 || held[u] >= 0) continue;
            Path chosen;
            const auto offer = [&](const Path& p) {
                if (chosen.length == 0 || better(p, chosen)) chosen = p;
            };
            for (const auto& [r1, e1] : admissible[u]) {
                const int v = owner[static_cast<std::size_t>(r1)];
                if (v < 0) {
                    offer({{int(u)}, {r1}, {e1}, 1, e1});
                    continue;
                }
                for (const auto& [r2, e2] : admissible[static_cast<std::size_t>(v)]) {
                    if (r2 == r1) continue;
                    const double c2 = e1 + (e2 - heldError[static_cast<std::size_t>(v)]);
                    const int w = owner[static_cast<std::size_t>(r2)];
                    if (w < 0) {
                        offer({{int(u), v}, {r1, r2}, {e1, e2}, 2, c2});
                        continue;
                    }
                    for (const auto& [r3, e3] : admissible[static_cast<std::size_t>(w)])
                        if (owner[static_cast<std::size_t>(r3)] < 0)
                            offer({{int(u), v, w}, {r1, r2, r3}, {e1, e2, e3}, 3,
                                   c2 + (e3 - heldError[static_cast<std::size_t>(w)])});
                }
            }
            if (chosen.length == 0) continue;
            for (std::size_t k = 0; k < chosen.length; ++k) {
                held[static_cast<std::size_t>(chosen.lefts[k])] = chosen.rights[k];
                heldError[static_cast<std::size_t>(chosen.lefts[k])] = chosen.errors[k];
                owner[static_cast<std::size_t>(chosen.rights[k])] = chosen.lefts[k];
            }
        }
    }
    Pairs out;
    for (std::size_t i = 0; i < l.size(); ++i)
        if (held[i] >= 0) out.push_back({static_cast<int>(i), held[i], heldError[i]});
    return out;
}

std::vector<Feature> randomFeatures(Rng& rng, int n) {
    std::vector<Feature> f;
    for (int i = 0; i < n; ++i) {
        const int x = static_cast<int>(rng.uniform(0.0, 1260.0));
        const int y = static_cast<int>(rng.uniform(0.0, 940.0));
        const int a = static_cast<int>(rng.uniform(2.0, 10.0));
        const int b = static_cast<int>(rng.uniform(2.0, 10.0));
        f.push_back(rng.uniform(0.0, 1.0) < 0.5 ? rect(x, y, a, b) : ellipse(x + 10, y + 10, a, b));
    }
    return f;
}

TEST(RepeatMatches, AChainOfThreeMovesAlongItsOnlyPath) {
    // Rectangles 20 px tall of widths U 20, V 24, W 28 (left) and r1 23,
    // r2 26, r3 31 (right), all in one wide box. maxError admits only
    // U-r1, V-r1, V-r2, W-r2 and W-r3. V takes r1 (width one off) from U,
    // W takes r2, and U is voided; the only augmenting path is U -> r1,
    // V -> r2, W -> r3.
    const std::vector<Feature> left = {rect(500, 400, 20, 20), rect(560, 400, 24, 20),
                                       rect(620, 400, 28, 20)};
    const std::vector<Feature> right = {rect(100, 400, 23, 20), rect(160, 400, 26, 20),
                                        rect(220, 400, 31, 20)};
    MatchConfig m = config(MatchMethod::EpipolarBox);
    m.boxDxMax = 600.0;
    const auto e = [&](int l, int r) {
        return shapeError(left[static_cast<std::size_t>(l)], right[static_cast<std::size_t>(r)], m.shape);
    };
    m.shape.maxError = std::max({e(0, 0), e(1, 0), e(1, 1), e(2, 1), e(2, 2)});
    ASSERT_GT(e(0, 1), m.shape.maxError);
    ASSERT_GT(e(0, 2), m.shape.maxError);
    ASSERT_GT(e(1, 2), m.shape.maxError);
    ASSERT_GT(e(2, 0), m.shape.maxError);
    ASSERT_LT(e(1, 0), e(0, 0));  // V takes r1 from U
    ASSERT_LT(e(1, 0), e(1, 1));
    ASSERT_LT(e(2, 1), e(2, 2));  // W takes r2

    m.repeats = RepeatMatchPolicy::Void;
    EXPECT_EQ(matchWith(m, parallelRig(), left, right), (Pairs{{1, 0}, {2, 1}}));
    m.repeats = RepeatMatchPolicy::Reassign;
    const Pairs repaired = matchWith(m, parallelRig(), left, right);
    ASSERT_EQ(repaired, (Pairs{{0, 0}, {1, 1}, {2, 2}}));
    EXPECT_EQ(repaired[2].shapeError, e(2, 2));
}

TEST(RepeatMatches, TheLeastAddedErrorWins) {
    // U (20 px wide) loses r1 (21) to V (22). U can take a free right
    // feature itself (added error e(U, r3)) or take r1 and move V to the free
    // r2 (added e(U, r1) + e(V, r2) - e(V, r1)); the path that adds less is
    // taken.
    const std::vector<Feature> left = {rect(500, 400, 20, 20), rect(560, 400, 22, 20)};
    MatchConfig m = config(MatchMethod::EpipolarBox);
    m.boxDxMax = 600.0;
    const auto run = [&](int r2Width, int r3Width) {
        const std::vector<Feature> right = {rect(100, 400, 21, 20), rect(160, 400, r2Width, 20),
                                            rect(220, 400, r3Width, 20)};
        const auto e = [&](int l, int r) {
            return shapeError(left[static_cast<std::size_t>(l)], right[static_cast<std::size_t>(r)],
                              m.shape);
        };
        // V takes r1 from U; r1 is U's first choice too.
        EXPECT_LT(e(1, 0), e(0, 0));
        EXPECT_LT(e(1, 0), e(1, 1));
        EXPECT_LT(e(0, 0), e(0, 1));
        EXPECT_LT(e(0, 0), e(0, 2));
        const double direct = e(0, 2);
        const double viaV = e(0, 0) + (e(1, 1) - e(1, 0));
        return std::make_pair(direct < viaV, matchWith(m, parallelRig(), left, right));
    };
    // r2 as V's near twin (24 px), r3 far from U (16 px): through V.
    const auto [directFirst, throughV] = run(24, 16);
    EXPECT_FALSE(directFirst);
    EXPECT_EQ(throughV, (Pairs{{0, 0}, {1, 1}}));
    // r2 far from V (30 px), r3 next to U (19 px): U takes r3.
    const auto [directSecond, direct] = run(30, 19);
    EXPECT_TRUE(directSecond);
    EXPECT_EQ(direct, (Pairs{{0, 2}, {1, 0}}));
}

TEST(CandidateGrid, CrowdedRandomScenesMatchBruteForce) {
    Rng rng{7u};
    std::size_t repaired = 0;
    for (int trial = 0; trial < 6; ++trial) {
        const std::vector<Feature> left = randomFeatures(rng, 300);
        const std::vector<Feature> right = randomFeatures(rng, 280);
        MatchConfig box = config(MatchMethod::EpipolarBox);
        box.boxDxMin = rng.uniform(-50.0, 20.0);
        box.boxDxMax = box.boxDxMin + rng.uniform(5.0, 300.0);
        box.boxDyMin = rng.uniform(-30.0, 0.0);
        box.boxDyMax = box.boxDyMin + rng.uniform(10.0, 60.0);
        box.shape.maxAreaRatio = 3.0;
        const Pairs expectedBox = bruteForce(box, parallelRig(), left, right);
        EXPECT_GT(expectedBox.size(), 10u);
        EXPECT_EQ(matchWith(box, parallelRig(), left, right), expectedBox);
        MatchConfig boxVoid = box;
        boxVoid.repeats = RepeatMatchPolicy::Void;
        const Pairs expectedVoid = bruteForce(boxVoid, parallelRig(), left, right);
        EXPECT_EQ(matchWith(boxVoid, parallelRig(), left, right), expectedVoid);
        EXPECT_GE(expectedBox.size(), expectedVoid.size());  // re-pairing only adds pairs
        repaired += expectedBox.size() - expectedVoid.size();

        MatchConfig line = config(MatchMethod::EpipolarLine);
        line.maxEpipolarDistancePx = rng.uniform(0.5, 8.0);
        line.minRangeMm = rng.uniform(300.0, 900.0);
        line.maxRangeMm = line.minRangeMm + rng.uniform(100.0, 5000.0);
        const StereoSystemConfig rig = trial % 2 ? rotatedRig() : test::scorpionCalibration();
        const Pairs expectedLine = bruteForce(line, rig, left, right);
        EXPECT_GT(expectedLine.size(), 5u);
        EXPECT_EQ(matchWith(line, rig, left, right), expectedLine);
    }
    EXPECT_GT(repaired, 0u);  // crowded scenes void repeats, and some are re-paired
}

// ---------------------------------------------------------------------------
// Candidate pruning (the shape-error lower bound, the tie rule) never changes
// a result: crowded scenes of look-alike targets, every method, several
// weightings and limits, at 10, 100 and 1,000 features, give the same matches
// and the same shape errors, bit for bit, as the brute-force scan.

/// The feature of a pixel set moved by whole pixels.
Feature featureAt(std::vector<cv::Point> pixels, int dx, int dy) {
    for (cv::Point& p : pixels) p += cv::Point(dx, dy);
    return featureFromPixels(pixels);
}

/// Pixel sets of small targets about the origin: look-alike prototypes and
/// variants one pixel apart.
std::vector<std::vector<cv::Point>> prototypes() {
    auto rectPixels = [](int w, int h) {
        std::vector<cv::Point> px;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) px.emplace_back(x, y);
        return px;
    };
    auto discPixels = [](int a, int b) {
        std::vector<cv::Point> px;
        for (int y = -b; y <= b; ++y)
            for (int x = -a; x <= a; ++x)
                if (static_cast<double>(x * x) / (a * a) + static_cast<double>(y * y) / (b * b) <= 1.0)
                    px.emplace_back(x, y);
        return px;
    };
    auto trianglePixels = [](int n) {
        std::vector<cv::Point> px;
        for (int y = 0; y < n; ++y)
            for (int x = 0; x <= y; ++x) px.emplace_back(x, y);
        return px;
    };
    // Symmetric ones (centroids on whole or half pixels, so translated copies
    // have bitwise equal descriptors) and a triangle (centroid at thirds of a
    // pixel: translated copies differ by rounding).
    std::vector<std::vector<cv::Point>> p = {rectPixels(7, 5), discPixels(4, 4), discPixels(5, 3),
                                             trianglePixels(6)};
    // One pixel off (4, 5, 6, 7 of 0, 1, 2, 3), centroids off the pixel grid.
    for (std::size_t k = 0; k < 4; ++k) {
        p.push_back(p[k]);
        p.back().erase(p.back().begin() + static_cast<std::ptrdiff_t>(k));
    }
    return p;
}

struct LookAlikeScene {
    std::vector<Feature> left, right;
};

/// n left targets from the eight prototypes() at random places, about one per
/// 20 x 20 px (so a box of scorpion.xml's size holds dozens of candidates);
/// each is seen in the right image 40..120 px to the left and up to 2 rows
/// off, as a translated copy (equal or near-equal shape errors), every fifth
/// as its one-pixel sibling and every seventh moved by a sub-pixel amount.
/// Every ninth right feature is an exact duplicate of another (equal errors,
/// ties to the lower index), every eleventh left feature repeats another
/// (ties in HandleRepeatMatches), and n / 10 right distractors have no
/// partner. The right list is shuffled.
///
/// With @p rows > 0 every centroid lies exactly on one of that many image
/// rows 24 px apart, and copies stay on their row: many candidates on one
/// epipolar line.
LookAlikeScene lookAlikeScene(Rng& rng, int n, int rows = 0) {
    const auto shapes = prototypes();
    const double width = 26.0 * std::sqrt(n), height = 20.0 * std::sqrt(n);
    auto pick = [&](std::size_t count) {
        return static_cast<std::size_t>(rng.uniform(0.0, static_cast<double>(count) - 1e-9));
    };
    // A feature of prototype @p shape at (x, y); on a row scene, its centroid
    // is put on the row y.
    auto place = [&](std::size_t shape, int x, int y) {
        Feature f = featureAt(shapes[shape], x, y);
        if (rows > 0) f.centroid.y = f.weightedCentroid.y = y;
        return f;
    };
    auto randomY = [&] {
        return rows > 0 ? 200 + 24 * static_cast<int>(pick(static_cast<std::size_t>(rows)))
                        : 200 + static_cast<int>(rng.uniform(0.0, height));
    };
    LookAlikeScene scene;
    for (int i = 0; i < n; ++i) {
        if (i % 11 == 10) {  // a left feature listed twice
            scene.left.push_back(scene.left[pick(scene.left.size())]);
            scene.right.push_back(scene.right[pick(scene.right.size())]);
            continue;
        }
        const std::size_t shape = pick(shapes.size());
        const int x = 400 + static_cast<int>(rng.uniform(0.0, width));
        const int y = randomY();
        scene.left.push_back(place(shape, x, y));
        const int dx = -static_cast<int>(rng.uniform(40.0, 120.0));
        const int dy = rows > 0 ? 0 : static_cast<int>(rng.uniform(-2.0, 3.0));
        const std::size_t seen = i % 5 == 4 ? (shape + 4) % 8 : shape;  // the other variant
        Feature r = place(seen, x + dx, y + dy);
        if (i % 7 == 6) {
            const cv::Point2d subPixel(rng.uniform(-0.4, 0.4), rows > 0 ? 0.0 : rng.uniform(-0.4, 0.4));
            r.centroid += subPixel;
            r.weightedCentroid = r.centroid;
        }
        scene.right.push_back(r);
        if (i % 9 == 8) scene.right.push_back(r);  // an exact duplicate
    }
    for (int k = 0; k < n / 10; ++k)
        scene.right.push_back(place(pick(shapes.size()),
                                    400 + static_cast<int>(rng.uniform(-120.0, width)), randomY()));
    for (std::size_t i = scene.right.size() - 1; i > 0; --i)
        std::swap(scene.right[i], scene.right[pick(i + 1)]);
    return scene;
}

/// The configurations compared: every method, the shipped limits and others.
std::vector<std::pair<std::string, MatchConfig>> pruningConfigs() {
    std::vector<std::pair<std::string, MatchConfig>> configs;
    MatchConfig box = config(MatchMethod::EpipolarBox);  // data/config/scorpion.xml
    box.boxDxMin = 15.0;
    box.boxDxMax = 310.0;
    box.boxDyMin = -25.0;
    box.boxDyMax = 40.0;
    configs.emplace_back("box scorpion.xml", box);
    MatchConfig voided = box;
    voided.repeats = RepeatMatchPolicy::Void;
    configs.emplace_back("box scorpion.xml, repeats voided", voided);
    MatchConfig tight = box;
    tight.boxDxMin = 40.0;
    tight.boxDxMax = 121.0;
    tight.boxDyMin = -3.0;
    tight.boxDyMax = 3.0;
    tight.shape = {0.3, 2.0, 0.25, 1.5};
    configs.emplace_back("box tight, maxError 0.25", tight);
    // Both weights 0 (every error 0) is not a valid configuration
    // (validateMatchConfig); equal errors come from the look-alike shapes.
    MatchConfig shape = config(MatchMethod::Shape);
    configs.emplace_back("shape", shape);
    shape.shape = {1.0, 0.0, 0.2, 4.0};
    configs.emplace_back("shape, magnitude only, maxError 0.2", shape);
    MatchConfig line = config(MatchMethod::EpipolarLine);
    // 123.5..38.5 px on the parallel rig: limits between whole-pixel
    // disparities, where the matcher's depth (from normalised coordinates) and
    // StereoCoordinateCalculator's could round to different sides.
    line.minRangeMm = 810.0;
    line.maxRangeMm = 2600.0;
    line.maxEpipolarDistancePx = 4.0;
    line.shape = {0.0, 1.0, 1e9, 4.0};
    configs.emplace_back("line, direction only", line);
    return configs;
}

TEST(CandidatePruning, LookAlikeScenesMatchBruteForceAt10_100_1000Features) {
    Rng rng{2024u};
    for (int n : {10, 100, 1000}) {
        // A free scene (38 box candidates per left feature at n = 1,000) and
        // one with all targets on n / 125 rows (16 line candidates).
        const LookAlikeScene free = lookAlikeScene(rng, n);
        const LookAlikeScene onRows = lookAlikeScene(rng, n, std::max(1, n / 125));
        for (const auto& [name, configured] : pruningConfigs())
            for (const LookAlikeScene* scene : {&free, &onRows}) {
                const MatchConfig& m = configured;
                SCOPED_TRACE(name + ", n = " + std::to_string(n) +
                             (scene == &free ? ", free" : ", on rows"));
                BruteForceStats stats;
                const Pairs expected =
                    bruteForce(m, parallelRig(), scene->left, scene->right, &stats);
                const Pairs got = matchWith(m, parallelRig(), scene->left, scene->right);
                ASSERT_EQ(got, expected);
                for (std::size_t k = 0; k < got.size(); ++k)
                    ASSERT_EQ(got[k].shapeError, expected[k].shapeError) << "match " << k;
                EXPECT_FALSE(expected.empty());
                if (n == 1000 && name == "box scorpion.xml" && scene == &free) {
                    // Crowded, and full of look-alikes: many candidates per
                    // left feature, exact ties and ties up to rounding.
                    EXPECT_GT(stats.candidates, 20u * static_cast<std::size_t>(n));
                    EXPECT_GT(stats.tiedBest, 100u);
                    EXPECT_GT(stats.nearTiedBest, 100u);
                }
                if (n == 1000 && m.method == MatchMethod::EpipolarLine && scene == &onRows) {
                    EXPECT_GT(stats.candidates, 5u * static_cast<std::size_t>(n));
                }
            }
    }
}

// ---------------------------------------------------------------------------
// 1,000 x 1,000 features.

/// A deterministic permutation of 0..n-1.
std::vector<int> shuffled(int n) {
    std::vector<int> order(static_cast<std::size_t>(n));
    std::iota(order.begin(), order.end(), 0);
    unsigned state = 12345u;
    for (int i = n - 1; i > 0; --i) {
        state = state * 1664525u + 1013904223u;
        std::swap(order[static_cast<std::size_t>(i)], order[(state >> 8) % static_cast<unsigned>(i + 1)]);
    }
    return order;
}

int jitter(int i, int range) { return static_cast<int>((i * 7919u) % static_cast<unsigned>(2 * range + 1)) - range; }

TEST(LargeScene, ThousandFeaturesThroughTheBox) {
    // 40 x 25 targets 30 px apart; each right image is the left shifted by a
    // disparity of 100 +- 3 px and 0 +- 2 rows. The right list is shuffled.
    const int n = 1000;
    const std::vector<int> order = shuffled(n);
    std::vector<Feature> left, right(static_cast<std::size_t>(n));
    Pairs truth;
    for (int i = 0; i < n; ++i) {
        const Feature l = rect(40 + 30 * (i % 40), 40 + 36 * (i / 40), 8 + i % 5, 8 + i % 3);
        left.push_back(l);
        const int j = order[static_cast<std::size_t>(i)];
        right[static_cast<std::size_t>(j)] = shifted(l, -100 - jitter(i, 3), -jitter(i + 17, 2));
        truth.push_back({i, j});
    }
    MatchConfig m = config(MatchMethod::EpipolarBox);
    m.boxDxMin = 90.0;
    m.boxDxMax = 110.0;
    m.boxDyMin = -5.0;
    m.boxDyMax = 5.0;
    EXPECT_EQ(matchWith(m, parallelRig(), left, right), truth);
}

TEST(LargeScene, ThousandFeaturesThroughTheLineWithDistortion) {
    // The Scorpion calibration with distortion; targets on a 40 x 25 pixel grid
    // of the left image at depths 1000 +- 20 mm, projected into the right image.
    StereoSystemConfig s = test::scorpionCalibration();
    s.left.kc = {-0.15, 0.06, 0.001, -0.001, 0.0};
    s.right.kc = {-0.14, 0.05, -0.001, 0.0008, 0.0};
    const RigidTransform rTl = rightTLeft(s);
    const int n = 1000;
    const std::vector<int> order = shuffled(n);
    std::vector<Feature> left, right(static_cast<std::size_t>(n));
    Pairs truth;
    for (int i = 0; i < n; ++i) {
        const cv::Point2d pl(130.0 + 30.0 * (i % 40), 110.0 + 36.0 * (i / 40));
        const cv::Point2d xn = normalizePixel(s.left, pl);
        const double z = 1000.0 + jitter(i, 20);
        const cv::Point3d X(xn.x * z, xn.y * z, z);
        const auto pr = projectPoint(s.right, transformPoint(rTl, X));
        ASSERT_TRUE(pr);
        const int w = 8 + i % 5, h = 8 + i % 3;
        left.push_back(rectAt(pl, w, h));
        const int j = order[static_cast<std::size_t>(i)];
        right[static_cast<std::size_t>(j)] = rectAt(*pr, w, h);
        truth.push_back({i, j});
    }
    MatchConfig m = config(MatchMethod::EpipolarLine);
    m.minRangeMm = 950.0;
    m.maxRangeMm = 1050.0;
    m.maxEpipolarDistancePx = 2.0;
    EXPECT_EQ(matchWith(m, s, left, right), truth);
}

// ---------------------------------------------------------------------------
// Configuration checks.

TEST(SIPFeatureMatcher, RejectsUnusableConfigurations) {
    const StereoSystemConfig s = parallelRig();
    auto rejects = [&](auto change) {
        MatchConfig m;
        change(m);
        EXPECT_THROW((void)SIPFeatureMatcher(m, s), InvalidArgument);
    };
    rejects([](MatchConfig& m) { m.boxDxMax = m.boxDxMin; });
    rejects([](MatchConfig& m) { m.boxDyMin = 20.0; });
    rejects([](MatchConfig& m) { m.maxEpipolarDistancePx = -1.0; });
    rejects([](MatchConfig& m) { m.minRangeMm = 0.0; });
    rejects([](MatchConfig& m) { m.maxRangeMm = m.minRangeMm; });
    rejects([](MatchConfig& m) { m.shape.magnitudeWeight = -0.1; });
    rejects([](MatchConfig& m) { m.shape.maxAreaRatio = 0.5; });
    rejects([](MatchConfig& m) { m.shape.maxError = std::nan(""); });
    StereoSystemConfig bad = s;
    bad.right.fc[1] = 0.0;
    EXPECT_THROW((void)SIPFeatureMatcher(MatchConfig{}, bad), InvalidArgument);
    EXPECT_NO_THROW((void)SIPFeatureMatcher(MatchConfig{}, s));
}

// The matcher takes the validator's word: what a whole configuration is
// rejected for in its match and stereo parts, the matcher refuses with the
// same message, and a configuration that validates builds a matcher. The
// empty box and the empty depth range were once accepted by one and not the
// other.
TEST(SIPFeatureMatcher, RefusesExactlyWhatTheConfigurationValidatorRejects) {
    AvatarConfig valid = test::scorpionSample();
    ASSERT_NO_THROW(validateConfig(valid));
    EXPECT_NO_THROW((void)SIPFeatureMatcher(valid.match, valid.stereo));
    const std::vector<std::function<void(AvatarConfig&)>> changes = {
        [](AvatarConfig& c) { c.match.boxDxMax = c.match.boxDxMin; },
        [](AvatarConfig& c) { c.match.boxDyMin = c.match.boxDyMax + 1; },
        [](AvatarConfig& c) { c.match.maxRangeMm = c.match.minRangeMm; },
        [](AvatarConfig& c) { c.match.maxEpipolarDistancePx = 0.0; },
        [](AvatarConfig& c) { c.match.shape.maxError = 0.0; },
        [](AvatarConfig& c) { c.match.shape.magnitudeWeight = -1.0; },
        [](AvatarConfig& c) { c.stereo.right.fc[1] = 0.0; },
        [](AvatarConfig& c) { c.stereo.translationMm = {0.0, 0.0, 0.0}; },
        [](AvatarConfig& c) { c.stereo.om[2] = std::nan(""); },
    };
    for (std::size_t i = 0; i < changes.size(); ++i) {
        SCOPED_TRACE("change " + std::to_string(i));
        AvatarConfig c = valid;
        changes[i](c);
        std::string validator, matcher;
        try {
            validateConfig(c);
        } catch (const ConfigError& e) {
            validator = e.what();
        }
        try {
            (void)SIPFeatureMatcher(c.match, c.stereo);
        } catch (const ConfigError& e) {
            matcher = e.what();
        }
        EXPECT_FALSE(validator.empty());
        EXPECT_EQ(matcher, validator);
    }
}

}  // namespace
}  // namespace avatar
