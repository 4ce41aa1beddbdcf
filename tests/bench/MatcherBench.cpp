// SIPFeatureMatcher against naive all-pairs versions of the same methods, for
// 1, 10, 100 and 1,000 features per image, on a sparse scene (Box, Line,
// Shape: one or two box or line candidates per feature) and a dense one of
// look-alike discs (BoxDense, ShapeDense). The naive versions void repeat
// matches as the thesis does, and are compared with the matcher doing the
// same (RepeatMatchPolicy::Void, the ...Voided benchmarks); the plain
// benchmarks run the default, RepeatMatchPolicy::Reassign, whose cost over
// voiding is the ratio of the two in one run. Run:
//   bench_matcher --benchmark_repetitions=9 --benchmark_report_aggregates_only=true
//
// The scene: n equal-sized targets on a grid filling a 1200 x 900 px region of
// the left image, 1000 +- 20 mm away, seen through the Table 6-4 Scorpion
// calibration (roll removed) with lens distortion added; the right list is
// shuffled. Every
// naive result is checked against the matcher's before timing.

#include "CraftedFeature.h"
#include "SampleConfigs.h"

#include <avatar/common/CameraModel.h>
#include <avatar/analyze/SIPFeatureMatcher.h>
#include <avatar/common/StereoCoordinateCalculator.h>

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <vector>

namespace avatar {
namespace {

using test::featureFromPixels;

StereoSystemConfig rig() {
    StereoSystemConfig c = test::scorpionCalibration();
    // Table 6-4 has 0.047 rad of roll, which tilts rows by up to 30 px across
    // the image: too much for a box. Benchmark a rig the box suits.
    c.om = {0.002, 0.003, 0.004};
    c.left.kc = {-0.15, 0.06, 0.001, -0.001, 0.0};
    c.right.kc = {-0.14, 0.05, -0.001, 0.0008, 0.0};
    return c;
}

MatchConfig matchConfig(MatchMethod method) {
    MatchConfig m;
    m.method = method;
    // 950..1050 mm is a disparity of about 95..125 px on this rig, and the
    // vertical offset and distortion move rows by 1..19 px.
    m.boxDxMin = 90.0;
    m.boxDxMax = 135.0;
    m.boxDyMin = -2.0;
    m.boxDyMax = 24.0;
    m.minRangeMm = 950.0;
    m.maxRangeMm = 1050.0;
    m.maxEpipolarDistancePx = 2.0;
    return m;
}

/// A w x h rectangle feature whose centroid is exactly @p c.
Feature rectAt(const cv::Point2d& c, int w, int h) {
    Feature f;
    f.area = w * h;
    f.centroid = f.weightedCentroid = c;
    const int x0 = static_cast<int>(std::lround(c.x)) - w / 2;
    const int y0 = static_cast<int>(std::lround(c.y)) - h / 2;
    const int x1 = x0 + w - 1, y1 = y0 + h - 1;
    f.boundary = {cv::Point(x0, y0), cv::Point(x1, y0), cv::Point(x1, y0), cv::Point(x1, y1),
                  cv::Point(x1, y1), cv::Point(x0, y1), cv::Point(x0, y1), cv::Point(x0, y0)};
    f.box = cv::Rect(x0, y0, w, h);
    f.aspectRatio = static_cast<double>(w) / h;
    f.areaRatio = 1.0;
    return f;
}

struct Scene {
    std::vector<Feature> left, right;
    std::vector<int> truth;  ///< the right index of each left feature's own image
};

/// A deterministic permutation of 0..n-1 (Fisher-Yates over an LCG seeded by @p seed).
std::vector<int> shuffledOrder(int n, unsigned seed) {
    std::vector<int> order(static_cast<std::size_t>(n));
    std::iota(order.begin(), order.end(), 0);
    unsigned state = seed;
    for (int i = n - 1; i > 0; --i) {
        state = state * 1664525u + 1013904223u;
        std::swap(order[static_cast<std::size_t>(i)],
                  order[(state >> 8) % static_cast<unsigned>(i + 1)]);
    }
    return order;
}

Scene makeScene(int n) {
    const StereoSystemConfig s = rig();
    const RigidTransform rTl = rightTLeft(s);
    const int cols = std::max(1, static_cast<int>(std::ceil(std::sqrt(n * 4.0 / 3.0))));
    const int rows = (n + cols - 1) / cols;
    const double dx = 1200.0 / cols, dy = 900.0 / rows;
    const std::vector<int> order = shuffledOrder(n, 2024u);
    Scene scene;
    scene.truth = order;
    scene.right.resize(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
        const cv::Point2d pl(112.0 + dx * (0.5 + i % cols), 114.0 + dy * (0.5 + i / cols));
        const cv::Point2d xn = normalizePixel(s.left, pl);
        const double z = 980.0 + (i * 7919) % 41;
        const cv::Point3d X(xn.x * z, xn.y * z, z);
        const auto pr = projectPoint(s.right, transformPoint(rTl, X));
        const int w = 10 + i % 4, h = 9 + i % 3;
        scene.left.push_back(rectAt(pl, w, h));
        scene.right[static_cast<std::size_t>(order[static_cast<std::size_t>(i)])] =
            rectAt(*pr, w, h);
    }
    return scene;
}


/// A disc of radius @p r about pixel @p c; variant 1..3 loses one more pixel
/// of its rim (as a demosaic fringe would), so that look-alikes differ a little.
Feature discAt(cv::Point c, int r, int variant) {
    std::vector<cv::Point> px;
    for (int y = -r; y <= r; ++y)
        for (int x = -r; x <= r; ++x)
            if (x * x + y * y <= r * r + r) px.emplace_back(c.x + x, c.y + y);
    for (int k = 0; k < variant && px.size() > 1; ++k) px.erase(px.begin() + k * 3);
    return featureFromPixels(px);
}

/// The pipeline's dense case (bench_pipeline synthetic_640x480/n:N): n
/// look-alike discs on a grid filling a 640x480 image, the right image the
/// left shifted 20 px to the left; matched through data/config/scorpion.xml's
/// box (dx 15..310, dy -25..40), which then holds 53 candidates per left
/// feature at n = 1,000 (the chain's own 640x480 features: 27 per type). The
/// right list is shuffled.
Scene makeDenseScene(int n) {
    const cv::Rect region(28, 8, 604, 464);
    const int cols = std::max(1, static_cast<int>(std::ceil(std::sqrt(n * 604.0 / 464.0))));
    const int rows = (n + cols - 1) / cols;
    const double pitchX = 604.0 / cols, pitchY = 464.0 / rows;
    const int radius = std::max(1, std::min(60, static_cast<int>(0.3 * std::min(pitchX, pitchY))));
    const std::vector<int> order = shuffledOrder(n, 77u);
    Scene scene;
    scene.truth = order;
    scene.right.resize(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
        const cv::Point c(region.x + static_cast<int>((i % cols + 0.5) * pitchX),
                          region.y + static_cast<int>((i / cols + 0.5) * pitchY));
        const int variant = (i * 7) % 4;
        scene.left.push_back(discAt(c, radius, variant));
        scene.right[static_cast<std::size_t>(order[static_cast<std::size_t>(i)])] =
            discAt({c.x - 20, c.y}, radius, variant);
    }
    return scene;
}

MatchConfig denseConfig(MatchMethod method) {
    MatchConfig m;  // shape limits as scorpion.xml: maxError 1e9, maxAreaRatio 4
    m.method = method;
    m.boxDxMin = 15.0;
    m.boxDxMax = 310.0;
    m.boxDyMin = -25.0;
    m.boxDyMax = 40.0;
    return m;
}

// --- Naive all-pairs baselines: the same decisions, every pair examined. ----

struct Best {
    int right{-1};
    double error{0.0};
};

void offer(Best& b, int j, double e) {
    if (b.right < 0 || e < b.error || (e == b.error && j < b.right)) b = {j, e};
}

bool admissible(const Feature& a, const Feature& b, const ShapeMatchConfig& shape, double& error) {
    const double small = std::min(a.area, b.area), large = std::max(a.area, b.area);
    if (large > shape.maxAreaRatio * small) return false;
    error = shapeError(a, b, shape);
    return error <= shape.maxError;
}

std::vector<FeatureMatch> resolveRepeats(const std::vector<Best>& best, std::size_t nRight) {
    std::vector<int> owner(nRight, -1);
    for (std::size_t i = 0; i < best.size(); ++i) {
        if (best[i].right < 0) continue;
        int& o = owner[static_cast<std::size_t>(best[i].right)];
        if (o < 0 || best[i].error < best[static_cast<std::size_t>(o)].error)
            o = static_cast<int>(i);
    }
    std::vector<FeatureMatch> out;
    for (std::size_t i = 0; i < best.size(); ++i)
        if (best[i].right >= 0 && owner[static_cast<std::size_t>(best[i].right)] == static_cast<int>(i))
            out.push_back({static_cast<int>(i), best[i].right, best[i].error});
    return out;
}

/// Figure 3-15 as written: M and S recomputed for every pair.
std::vector<FeatureMatch> naiveShape(const MatchConfig& m, const StereoSystemConfig&,
                                     const std::vector<Feature>& l, const std::vector<Feature>& r) {
    std::vector<Best> best(l.size());
    for (std::size_t i = 0; i < l.size(); ++i)
        for (std::size_t j = 0; j < r.size(); ++j) {
            double e = 0.0;
            if (l[i].centroid.x > r[j].centroid.x && admissible(l[i], r[j], m.shape, e))
                offer(best[i], static_cast<int>(j), e);
        }
    return resolveRepeats(best, r.size());
}

/// Figure 3-16 as written: every left against every right.
std::vector<FeatureMatch> naiveBox(const MatchConfig& m, const StereoSystemConfig&,
                                   const std::vector<Feature>& l, const std::vector<Feature>& r) {
    std::vector<Best> best(l.size());
    for (std::size_t i = 0; i < l.size(); ++i)
        for (std::size_t j = 0; j < r.size(); ++j) {
            const double dx = l[i].centroid.x - r[j].centroid.x;
            const double dy = l[i].centroid.y - r[j].centroid.y;
            double e = 0.0;
            if (m.boxDxMin < dx && dx < m.boxDxMax && m.boxDyMin < dy && dy < m.boxDyMax &&
                admissible(l[i], r[j], m.shape, e))
                offer(best[i], static_cast<int>(j), e);
        }
    return resolveRepeats(best, r.size());
}

/// The epipolar line with every right feature's distance computed.
std::vector<FeatureMatch> naiveLine(const MatchConfig& m, const StereoSystemConfig& s,
                                    const std::vector<Feature>& l, const std::vector<Feature>& r) {
    const cv::Matx33d F = fundamentalMatrix(stereoGeometry(s));
    const StereoCoordinateCalculator tri(stereoGeometry(s));
    std::vector<cv::Point2d> rightIdeal;
    for (const Feature& f : r)
        rightIdeal.push_back(normalizedToPixel(s.right, normalizePixel(s.right, f.centroid)));
    std::vector<Best> best(l.size());
    for (std::size_t i = 0; i < l.size(); ++i) {
        const cv::Point2d pl = normalizedToPixel(s.left, normalizePixel(s.left, l[i].centroid));
        cv::Vec3d line = F * cv::Vec3d(pl.x, pl.y, 1.0);
        line /= std::hypot(line[0], line[1]);
        for (std::size_t j = 0; j < r.size(); ++j) {
            const double d = std::abs(line[0] * rightIdeal[j].x + line[1] * rightIdeal[j].y + line[2]);
            if (!(d <= m.maxEpipolarDistancePx)) continue;
            const auto p = tri.triangulate(l[i].centroid, r[j].centroid);
            double e = 0.0;
            if (p && p->leftMm.z >= m.minRangeMm && p->leftMm.z <= m.maxRangeMm &&
                admissible(l[i], r[j], m.shape, e))
                offer(best[i], static_cast<int>(j), e);
        }
    }
    return resolveRepeats(best, r.size());
}

bool sameMatches(const std::vector<FeatureMatch>& a, const std::vector<FeatureMatch>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t k = 0; k < a.size(); ++k)
        if (a[k].left != b[k].left || a[k].right != b[k].right) return false;
    return true;
}

using Naive = std::vector<FeatureMatch> (*)(const MatchConfig&, const StereoSystemConfig&,
                                            const std::vector<Feature>&, const std::vector<Feature>&);

using SceneMaker = Scene (*)(int);
using ConfigMaker = MatchConfig (*)(MatchMethod);

void runMatcher(benchmark::State& state, MatchMethod method, SceneMaker sceneOf = makeScene,
                ConfigMaker configOf = matchConfig,
                RepeatMatchPolicy repeats = RepeatMatchPolicy::Reassign) {
    const Scene scene = sceneOf(static_cast<int>(state.range(0)));
    MatchConfig config = configOf(method);
    config.repeats = repeats;
    const SIPFeatureMatcher matcher(config, rig());
    std::size_t matched = 0, correct = 0;
    for (auto _ : state) {
        const auto m = matcher.match(scene.left, scene.right);
        matched = m.size();
        benchmark::DoNotOptimize(m.data());
    }
    for (const FeatureMatch& m : matcher.match(scene.left, scene.right))
        if (scene.truth[static_cast<std::size_t>(m.left)] == m.right) ++correct;
    state.counters["matched"] = static_cast<double>(matched);
    state.counters["correct"] = static_cast<double>(correct);
}

void runNaive(benchmark::State& state, MatchMethod method, Naive naive,
              SceneMaker sceneOf = makeScene, ConfigMaker configOf = matchConfig) {
    const Scene scene = sceneOf(static_cast<int>(state.range(0)));
    MatchConfig config = configOf(method);
    config.repeats = RepeatMatchPolicy::Void;  // as the naive versions do
    const StereoSystemConfig stereo = rig();
    const auto expected = SIPFeatureMatcher(config, stereo).match(scene.left, scene.right);
    if (!sameMatches(naive(config, stereo, scene.left, scene.right), expected)) {
        state.SkipWithError("the naive matcher disagrees with SIPFeatureMatcher");
        return;
    }
    std::size_t matched = 0;
    for (auto _ : state) {
        const auto m = naive(config, stereo, scene.left, scene.right);
        matched = m.size();
        benchmark::DoNotOptimize(m.data());
    }
    state.counters["matched"] = static_cast<double>(matched);
}

void BM_Shape(benchmark::State& s) { runMatcher(s, MatchMethod::Shape); }
void BM_ShapeNaive(benchmark::State& s) { runNaive(s, MatchMethod::Shape, naiveShape); }
void BM_Box(benchmark::State& s) { runMatcher(s, MatchMethod::EpipolarBox); }
void BM_BoxNaive(benchmark::State& s) { runNaive(s, MatchMethod::EpipolarBox, naiveBox); }
void BM_Line(benchmark::State& s) { runMatcher(s, MatchMethod::EpipolarLine); }
void BM_LineNaive(benchmark::State& s) { runNaive(s, MatchMethod::EpipolarLine, naiveLine); }

void BM_BoxDense(benchmark::State& s) {
    runMatcher(s, MatchMethod::EpipolarBox, makeDenseScene, denseConfig);
}
void BM_BoxDenseNaive(benchmark::State& s) {
    runNaive(s, MatchMethod::EpipolarBox, naiveBox, makeDenseScene, denseConfig);
}
void BM_ShapeDense(benchmark::State& s) {
    runMatcher(s, MatchMethod::Shape, makeDenseScene, denseConfig);
}
void BM_ShapeDenseNaive(benchmark::State& s) {
    runNaive(s, MatchMethod::Shape, naiveShape, makeDenseScene, denseConfig);
}
void BM_BoxDenseVoided(benchmark::State& s) {
    runMatcher(s, MatchMethod::EpipolarBox, makeDenseScene, denseConfig, RepeatMatchPolicy::Void);
}
void BM_ShapeDenseVoided(benchmark::State& s) {
    runMatcher(s, MatchMethod::Shape, makeDenseScene, denseConfig, RepeatMatchPolicy::Void);
}

void sizes(benchmark::internal::Benchmark* b) {
    b->Arg(1)->Arg(10)->Arg(100)->Arg(1000)->Unit(benchmark::kMicrosecond);
}

BENCHMARK(BM_Shape)->Apply(sizes);
BENCHMARK(BM_ShapeNaive)->Apply(sizes);
BENCHMARK(BM_Box)->Apply(sizes);
BENCHMARK(BM_BoxNaive)->Apply(sizes);
BENCHMARK(BM_Line)->Apply(sizes);
BENCHMARK(BM_LineNaive)->Apply(sizes);
BENCHMARK(BM_BoxDense)->Apply(sizes);
BENCHMARK(BM_BoxDenseNaive)->Apply(sizes);
BENCHMARK(BM_ShapeDense)->Apply(sizes);
BENCHMARK(BM_ShapeDenseNaive)->Apply(sizes);
BENCHMARK(BM_BoxDenseVoided)->Apply(sizes);
BENCHMARK(BM_ShapeDenseVoided)->Apply(sizes);

}  // namespace
}  // namespace avatar

BENCHMARK_MAIN();
