// The full analysis chain (thesis 4.2.3) on 16-bit Bayer stereo pairs, with
// lighting correction, the two target types of data/config/scorpion.xml and
// erode/restore on, against a straightforward OpenCV baseline in the same
// binary. Run with
//   bench_pipeline --benchmark_repetitions=9 --benchmark_report_aggregates_only=true
// and see docs/benchmarks.md for the tables and how to read them.
//
// Inputs (made once per process, on first use):
//   lab_1280x960       the lab scene (data/scenes/lab.xml) rendered by
//                      avatar::render with the Scorpion configuration;
//   lab_640x480, lab_2448x2048  the same scene with the same field of view at
//                      0.3 and 5 MP (focal lengths, pixel limits and the match
//                      box scaled): the cost per megapixel of one scene;
//   synthetic_WxH/n:N  N discs per image (alternately of the two target
//                      colours) on a noisy sand-coloured background, the
//                      right image shifted by a fixed disparity, at
//                      640x480, 1280x960 and 2448x2048.
// Both are mosaicked and then divided by the lighting factors of the
// configured strobe pattern, so that the lighting stage has real work and
// its correction gives the scene's colours back.
//
// Benchmarks:
//   Pipeline/<input>          AnalyzeStereoImagePair::analyze (two threads);
//                             counters: median per stage (ms, from
//                             VisionTargets::timings), total, and what was found.
//   PipelineSerial/<input>    the same with setParallel(false) (one thread:
//                             the time is the CPU time per pair; counter
//                             megapixels, per image, for ms per megapixel).
//   PipelineSerialVeil/<input> the same with a haze's veil on every type.
//   PipelineSerialWater/<input> the same with the site's water on every type.
//   PipelineSerialVoided/<input> one thread with repeat matches voided (the
//                             thesis's HandleRepeatMatches) instead of re-paired:
//                             against PipelineSerial, what re-pairing costs.
//   Baseline/<input>          plain OpenCV calls, one image after the other.
//   PipelineVsBaseline/<input> both, interleaved per iteration: the time is the
//                             chain's; counters give the baseline's median and
//                             the ratio baseline / chain measured under the same load,
//                             in wall time (speedup) and in CPU time of all
//                             threads (cpu_ms, baseline_cpu_ms, cpu_speedup;
//                             cpu_<stage>_ms: each stage's CPU median, both threads).
//   PipelineSerialVsBaseline/<input> the same with the chain on one thread.
//   PipelineFresh/lab_*       one thread, cycling through deep copies of the
//                             pair (64 MB or more), so every frame's mosaics
//                             come from memory like a camera's: CPU per pair
//                             and per megapixel.
//   PipelineFreshVsBaseline/lab_1280x960  the same, in blocks of 8 frames
//                             alternating with the OpenCV baseline on the same
//                             fresh copies: CPU against CPU.
//   PipelineScaling/lab       lab_640x480, lab_1280x960 and lab_2448x2048 in
//                             turn, one thread: CPU ms per megapixel of each
//                             and their spread (largest / smallest).
//   Tracking/lab_1280x960/full_every:N  the tracking mode on one thread, a
//                             whole image every N frames (1000000: tracking
//                             frames only); CPU per pair from lastCpuTimings().
//   TrackingCoarse/...        the same with the whole-image frames coarse-to-fine.
//   CoarseToFine/<input>      every frame coarse-to-fine (no tracking), one thread.
//   FirstFrame/<input>        a new AnalyzeStereoImagePair and its first
//                             analysis (lighting factors built, buffers faulted
//                             in): what a short run such as avatar-analyze on a
//                             three-pair session mostly sees.
//   Match/<input>             the match stage alone (SIPFeatureMatcher, one
//                             thread, CPU time, repeats voided) on the features
//                             the chain found;
//   MatchReassign/<input>     the same with repeats re-paired (the default);
//   MatchAllPairs/<input>     the same decisions with every pair tested and every
//                             box candidate's shape error computed (what the
//                             matcher cost before it pruned candidates), checked
//                             to give the same matches.
// All but Match* are wall-clock (UseRealTime / manual time): the chain is threaded.
// "faults" is minor page faults per iteration (fresh buffers fault per 4 KiB).
//
// --opencv_threads=N (first argument) calls cv::setNumThreads(N) before
// running, for comparing with OpenCV's own thread pool limited; the chain
// itself never changes that process-global setting.

#include <avatar/analyze/AnalyzeStereoImagePair.h>
#include <avatar/analyze/LightingCorrection.h>
#include <avatar/analyze/SIPFeatureMatcher.h>
#include <avatar/common/StereoCoordinateCalculator.h>
#include <avatar/config/ConfigXml.h>
#include <avatar/render/Renderer.h>
#include <avatar/render/Scene.h>

#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <time.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace avatar {
namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

/// Minor page faults of the process so far (a fresh buffer faults once per 4 KiB page).
long minorFaults() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return usage.ru_minflt;
}

double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    if (v.size() % 2 == 1) return *mid;
    return 0.5 * (*mid + *std::max_element(v.begin(), mid));
}

// ---------------------------------------------------------------------------
// Configuration and inputs
// ---------------------------------------------------------------------------

/// A strobe pattern like data/config/seabed.xml's (milder, so that the corners
/// of a 2448x2048 image keep some signal) plus frame-average gains.
LightingConfig benchLighting(cv::Size size) {
    LightingConfig l;
    l.frameAverageEnabled = true;
    l.gainsRgb = {1.1, 1.0, 0.9};
    l.patternEnabled = true;
    l.patternCentrePx = {size.width / 2.0, size.height / 2.0};
    l.red = {1.0, 0.0008};
    l.green = {1.0, 0.0006};
    l.blue = {1.0, 0.0005};
    return l;
}

/// data/config/scorpion.xml at @p size with lighting correction on: the
/// cameras' focal lengths and principal points scaled from 1280x960 to the
/// size, so the configuration is one the validator accepts at every size.
AvatarConfig benchConfig(cv::Size size) {
    AvatarConfig c = readConfigFile(std::string(AVATAR_DATA_DIR) + "/config/scorpion.xml");
    const double sx = size.width / static_cast<double>(c.camera.width);
    const double sy = size.height / static_cast<double>(c.camera.height);
    for (CameraIntrinsics* camera : {&c.stereo.left, &c.stereo.right}) {
        camera->fc = {camera->fc[0] * sx, camera->fc[1] * sy};
        camera->cc = {camera->cc[0] * sx, camera->cc[1] * sy};
    }
    c.camera.width = size.width;
    c.camera.height = size.height;
    c.lighting = benchLighting(size);
    return c;
}

/// Channel (0 = B, 1 = G, 2 = R) of mosaic site (x, y) for BayerPattern::BG
/// (first row B G B G ..., second row G R G R ...).
int siteChannel(int x, int y) { return (x % 2 == 0 && y % 2 == 0) ? 0 : (x % 2 == 1 && y % 2 == 1) ? 2 : 1; }

/// Divides every site of a 16-bit BG mosaic by its channel's lighting
/// factor, so that the lighting correction of the chain undoes it.
void uncorrect(cv::Mat& mosaic, const cv::Mat& factors) {
    for (int y = 0; y < mosaic.rows; ++y) {
        auto* row = mosaic.ptr<std::uint16_t>(y);
        const auto* f = factors.ptr<cv::Vec3f>(y);
        for (int x = 0; x < mosaic.cols; ++x) {
            const float v = static_cast<float>(row[x]) / std::max(f[x][siteChannel(x, y)], 1e-6f);
            row[x] = static_cast<std::uint16_t>(std::min(v + 0.5f, 65535.0f));
        }
    }
}

/// The BG mosaic of a 16-bit BGR image.
cv::Mat mosaicOf(const cv::Mat& bgr) {
    cv::Mat mosaic(bgr.size(), CV_16UC1);
    for (int y = 0; y < bgr.rows; ++y) {
        const auto* in = bgr.ptr<cv::Vec<std::uint16_t, 3>>(y);
        auto* out = mosaic.ptr<std::uint16_t>(y);
        for (int x = 0; x < bgr.cols; ++x) out[x] = in[x][siteChannel(x, y)];
    }
    return mosaic;
}

struct Input {
    AvatarConfig config;
    StereoImagePair pair;
    int expectedStereo{0};  ///< stereo targets the chain must find (checked before timing)
    int discsPerImage{0};   ///< synthetic inputs: features per image
};

constexpr int kLabWidth = 1280;
constexpr int kLabHeight = 960;

/// The lab scene seen by the Scorpion cameras with @p size pixels (the same
/// field of view: focal lengths, principal points, pixel limits of the
/// configuration and the match box scaled with the image), so that the same
/// scene can be priced per megapixel.
Input makeLab(cv::Size size = {kLabWidth, kLabHeight}) {
    Input in;
    in.config = benchConfig(size);
    const double sx = size.width / static_cast<double>(kLabWidth), sy = size.height / static_cast<double>(kLabHeight);
    if (sx != 1.0 || sy != 1.0) {
        for (TargetType& t : in.config.targets.targets) t.area = {t.area.min * sx * sy, t.area.max * sx * sy};
        MatchConfig& m = in.config.match;
        m.boxDxMin *= sx;
        m.boxDxMax *= sx;
        m.boxDyMin *= sy;
        m.boxDyMax *= sy;
    }
    const render::Scene scene = render::readSceneFile(std::string(AVATAR_DATA_DIR) + "/scenes/lab.xml");
    render::RenderOptions options;
    options.sensor = render::sensorFormatFrom(in.config.camera);
    render::RenderResult r = render::render(scene, in.config.stereo, options);
    LightingCorrector corrector(in.config.lighting);
    corrector.prepare(r.pair.size());
    cv::Mat left = r.pair.left().clone(), right = r.pair.right().clone();
    uncorrect(left, corrector.factors());
    uncorrect(right, corrector.factors());
    in.pair = StereoImagePair(left, right, r.pair.layout(), r.pair.id());
    in.expectedStereo = 2;  // the duck and the arm marker
    return in;
}

/// True scene colours (B, G, R) that pass scorpion.xml's filters.
const cv::Scalar kSampleBgr(2500, 16000, 20000);  // R/G 1.25, R/B 8, B/G 0.16
const cv::Scalar kMarkerBgr(6000, 12000, 23000);  // R/G 1.92, R/B 3.8, B/G 0.5

cv::Mat syntheticImage(cv::Size size, const std::vector<cv::Point>& centres, int radius, std::uint64_t seed) {
    cv::Mat bgr(size, CV_16UC3);
    cv::RNG rng(seed);
    rng.fill(bgr, cv::RNG::NORMAL, cv::Scalar(9000, 11000, 12000), cv::Scalar::all(600));
    for (std::size_t i = 0; i < centres.size(); ++i)
        cv::circle(bgr, centres[i], radius, i % 2 == 0 ? kSampleBgr : kMarkerBgr, cv::FILLED, cv::LINE_8);
    return bgr;
}

/// @p n discs on a grid, the right image's shifted left by the disparity.
Input makeSynthetic(cv::Size size, int n) {
    Input in;
    in.config = benchConfig(size);
    // Small discs: 1,000 of them fit a 640x480 image only at about 75 px each,
    // below scorpion.xml's minimum areas (150, 80).
    for (TargetType& t : in.config.targets.targets) t.area.min = 20.0;
    const int disparity = std::max(20, size.width / 32);  // inside the match box (15..310 px)
    const int margin = 8;
    const cv::Rect region(disparity + margin, margin, size.width - disparity - 2 * margin, size.height - 2 * margin);
    const int cols = std::max(1, static_cast<int>(std::ceil(std::sqrt(n * static_cast<double>(region.width) / region.height))));
    const int rows = (n + cols - 1) / cols;
    const double pitchX = static_cast<double>(region.width) / cols;
    const double pitchY = static_cast<double>(region.height) / rows;
    const int radius = std::min(60, static_cast<int>(0.3 * std::min(pitchX, pitchY)));
    std::vector<cv::Point> left, right;
    for (int i = 0; i < n; ++i) {
        const cv::Point c(region.x + static_cast<int>((i % cols + 0.5) * pitchX),
                          region.y + static_cast<int>((i / cols + 0.5) * pitchY));
        left.push_back(c);
        right.push_back({c.x - disparity, c.y});
    }
    LightingCorrector corrector(in.config.lighting);
    corrector.prepare(size);
    cv::Mat l = mosaicOf(syntheticImage(size, left, radius, 1));
    cv::Mat r = mosaicOf(syntheticImage(size, right, radius, 2));
    uncorrect(l, corrector.factors());
    uncorrect(r, corrector.factors());
    in.pair = StereoImagePair(l, r, {PixelFormat::Bayer, BayerPattern::BG, 16});
    in.discsPerImage = n;
    return in;
}

/// Inputs by name, made on first use (so a --benchmark_filter renders only what it needs).
const Input& input(const std::string& name) {
    static std::map<std::string, std::unique_ptr<Input>> cache;
    auto& slot = cache[name];
    if (!slot) {
        int w = 0, h = 0, n = 0;
        if (std::sscanf(name.c_str(), "lab_%dx%d", &w, &h) == 2) {
            slot = std::make_unique<Input>(makeLab({w, h}));
        } else {
            if (std::sscanf(name.c_str(), "synthetic_%dx%d/n:%d", &w, &h, &n) != 3)
                throw InvalidArgument("bench_pipeline: unknown input " + name);
            slot = std::make_unique<Input>(makeSynthetic({w, h}, n));
        }
    }
    return *slot;
}

// ---------------------------------------------------------------------------
// Result summaries and checks
// ---------------------------------------------------------------------------

struct Found {
    int stereo{0};
    int featuresLeft{0};
};

Found found(const AnalyzeStereoImagePair& chain, const VisionTargets& result) {
    Found f;
    for (const VisionTarget& t : result.targets) f.stereo += (t.flags & kTargetStereo) != 0;
    for (const auto& list : chain.lastFrame().at(Side::Left).features) f.featuresLeft += static_cast<int>(list.size());
    return f;
}

/// Empty when the chain found what the input holds, else what is wrong.
std::string check(const Input& in, const Found& f) {
    // Allow 1%: at 640x480 a disc of 1,000 is only about 9 px across, and the
    // demosaic's colour fringes can push one at a dim corner out of a filter.
    if (in.discsPerImage > 0 && (f.featuresLeft > in.discsPerImage || 100 * f.featuresLeft < 99 * in.discsPerImage))
        return "found " + std::to_string(f.featuresLeft) + " features in the left image, expected " +
               std::to_string(in.discsPerImage);
    if (in.discsPerImage == 0 && f.stereo != in.expectedStereo)
        return "found " + std::to_string(f.stereo) + " stereo targets, expected " + std::to_string(in.expectedStereo);
    return {};
}

/// Per-stage timings of the iterations of one run, reported as medians.
class StageTimes {
public:
    void add(const VisionTargets& result) { add(result.timings); }
    void add(const std::vector<StageTiming>& timings) {
        for (const StageTiming& t : timings) {
            auto it = std::find_if(stages_.begin(), stages_.end(), [&](const auto& s) { return s.first == t.stage; });
            if (it == stages_.end()) it = stages_.insert(stages_.end(), {t.stage, {}});
            it->second.push_back(t.milliseconds);
        }
    }
    /// Each stage's median as the counter "<prefix><stage>_ms".
    void report(benchmark::State& state, const std::string& prefix = "") const {
        for (const auto& [stage, times] : stages_) state.counters[prefix + stage + "_ms"] = median(times);
    }
    double medianOf(const std::string& stage) const {
        for (const auto& [name, times] : stages_)
            if (name == stage) return median(times);
        return 0.0;
    }

private:
    std::vector<std::pair<std::string, std::vector<double>>> stages_;
};

// ---------------------------------------------------------------------------
// The straightforward OpenCV baseline: per image, one after the other,
// cvtColor demosaic, cv::multiply lighting, float ratios with cv::divide,
// cv::inRange per ratio and type, cv::erode + cv::connectedComponentsWithStats
// (no restore: the eroded features are taken as they are, which is cheaper
// than the chain's feature-AND restore), an area filter, the visibility
// measures on the full image; then all-pairs matching in the epipolar box and
// triangulation of the centroids.
// ---------------------------------------------------------------------------

struct BaselineImage {
    cv::Mat bgr, bgrF, rg, rb, bg, mask, m, eroded, labels, stats, centroids, gray, dark;
    std::vector<cv::Mat> ch;
    std::vector<std::vector<cv::Point2d>> points;  // per type
    std::vector<std::vector<int>> areas;
};

class Baseline {
public:
    explicit Baseline(const AvatarConfig& config)
        : config_(config), calculator_(stereoGeometry(config.stereo)), kernel_(cv::getStructuringElement(cv::MORPH_RECT, {3, 3})) {
        LightingCorrector corrector(config.lighting);
        corrector.prepare({config.camera.width, config.camera.height});
        factors_ = corrector.factors().clone();
    }

    /// Returns the number of stereo targets; @p times gets the step timings.
    int run(const StereoImagePair& pair, StageTimes& times) {
        VisionTargets t;
        const auto start = Clock::now();
        auto t0 = Clock::now();
        for (int i = 0; i < 2; ++i) cv::cvtColor(pair.image(i == 0 ? Side::Left : Side::Right), image_[i].bgr, cv::COLOR_BayerRG2BGR);
        t.timings.push_back({"demosaic", msSince(t0)});
        t0 = Clock::now();
        for (auto& im : image_) cv::multiply(im.bgr, factors_, im.bgr, 1.0, CV_16UC3);
        t.timings.push_back({"lighting", msSince(t0)});
        t0 = Clock::now();
        for (auto& im : image_) filter(im);
        t.timings.push_back({"color_filter+erode+locate", msSince(t0)});
        t0 = Clock::now();
        for (auto& im : image_) visibility(im);
        t.timings.push_back({"visibility", msSince(t0)});
        t0 = Clock::now();
        const int stereo = matchAndTriangulate();
        t.timings.push_back({"match+triangulate", msSince(t0)});
        t.timings.push_back({"total", msSince(start)});
        times.add(t);
        return stereo;
    }

private:
    void filter(BaselineImage& im) {
        const auto& types = config_.targets.targets;
        im.bgr.convertTo(im.bgrF, CV_32F);
        cv::split(im.bgrF, im.ch);
        cv::divide(im.ch[2], im.ch[1], im.rg);
        cv::divide(im.ch[2], im.ch[0], im.rb);
        cv::divide(im.ch[0], im.ch[1], im.bg);
        im.points.assign(types.size(), {});
        im.areas.assign(types.size(), {});
        for (std::size_t k = 0; k < types.size(); ++k) {
            const TargetType& type = types[k];
            cv::inRange(im.rg, type.redGreen.min, type.redGreen.max, im.mask);
            cv::inRange(im.rb, type.redBlue.min, type.redBlue.max, im.m);
            cv::bitwise_and(im.mask, im.m, im.mask);
            cv::inRange(im.bg, type.blueGreen.min, type.blueGreen.max, im.m);
            cv::bitwise_and(im.mask, im.m, im.mask);
            if (type.erodeRestore) {
                cv::erode(im.mask, im.eroded, kernel_);
            } else {
                im.eroded = im.mask;
            }
            const int n = cv::connectedComponentsWithStats(im.eroded, im.labels, im.stats, im.centroids, 8, CV_32S);
            for (int i = 1; i < n; ++i) {
                const int area = im.stats.at<int>(i, cv::CC_STAT_AREA);
                if (!type.area.contains(area)) continue;
                im.points[k].push_back({im.centroids.at<double>(i, 0), im.centroids.at<double>(i, 1)});
                im.areas[k].push_back(area);
            }
        }
    }

    void visibility(BaselineImage& im) {
        const double full = 65535.0;
        cv::Scalar mean, stddev;
        cv::cvtColor(im.bgrF, im.gray, cv::COLOR_BGR2GRAY);
        cv::meanStdDev(im.gray, mean, stddev);
        cv::min(cv::min(im.ch[0], im.ch[1]), im.ch[2], im.dark);
        contrast_ += stddev[0] / full + cv::mean(im.dark)[0] / full +
                     cv::countNonZero(im.bgr.reshape(1) >= full);
    }

    int matchAndTriangulate() {
        const MatchConfig& mc = config_.match;
        int stereo = 0;
        for (std::size_t k = 0; k < image_[0].points.size(); ++k) {
            const auto& L = image_[0].points[k];
            const auto& R = image_[1].points[k];
            std::vector<bool> used(R.size());
            for (std::size_t i = 0; i < L.size(); ++i) {
                int best = -1;
                double bestDy = 1e300;
                for (std::size_t j = 0; j < R.size(); ++j) {
                    const double dx = L[i].x - R[j].x, dy = R[j].y - L[i].y;
                    const double a = image_[0].areas[k][i], b = image_[1].areas[k][j];
                    if (used[j] || dx < mc.boxDxMin || dx > mc.boxDxMax || dy < mc.boxDyMin || dy > mc.boxDyMax ||
                        std::max(a, b) > mc.shape.maxAreaRatio * std::min(a, b))
                        continue;
                    if (std::abs(dy) < bestDy) {
                        bestDy = std::abs(dy);
                        best = static_cast<int>(j);
                    }
                }
                if (best < 0) continue;
                used[static_cast<std::size_t>(best)] = true;
                stereo += calculator_.triangulate(L[i], R[static_cast<std::size_t>(best)]).has_value();
            }
        }
        return stereo;
    }

    AvatarConfig config_;
    StereoCoordinateCalculator calculator_;
    cv::Mat kernel_, factors_;
    BaselineImage image_[2];
    double contrast_{0.0};
};

// ---------------------------------------------------------------------------
// Benchmarks
// ---------------------------------------------------------------------------

void reportFound(benchmark::State& state, const Found& f) {
    state.counters["stereo"] = f.stereo;
    state.counters["features_L"] = f.featuresLeft;
}

void BM_PipelineWith(benchmark::State& state, const std::string& name, bool parallel, bool veil, bool water,
                     bool voidRepeats) {
    const Input& in = input(name);
    AvatarConfig config = in.config;
    // The thesis's HandleRepeatMatches (docs/config.md, <repeats>): against
    // the default, what re-pairing costs the whole chain.
    if (voidRepeats) config.match.repeats = RepeatMatchPolicy::Void;
    // A haze's veil on every type (docs/config.md): the hull's test on the
    // pixels its bounding box passes and the ranges do not.
    if (veil)
        for (TargetType& t : config.targets.targets) t.veil = Veil{{0.7, 1.0, 1.0}, 0.3, std::nullopt, std::nullopt};
    // The site's water on every type (docs/config.md): one more box of ratio
    // limits on every pixel.
    if (water)
        for (TargetType& t : config.targets.targets)
            t.water = Water{{0.24, 0.0, 0.07}, 5.0, std::nullopt, std::nullopt};
    AnalyzeStereoImagePair chain(config);
    chain.setParallel(parallel);
    const Found f = found(chain, chain.analyze(in.pair, 0));  // warm-up, and the check
    if (const std::string error = check(in, f); !error.empty()) {
        state.SkipWithError(error.c_str());
        return;
    }
    // A second warm-up frame: the first frame's buffers are still held (by
    // lastFrame()) while the second is analysed, so the pools fill up only
    // then; from the third frame on a frame allocates nothing (FirstFrame
    // prices the first).
    chain.analyze(in.pair, 1);
    StageTimes times;
    std::uint64_t iteration = 2;
    const long faults0 = minorFaults();
    for (auto _ : state) {
        const VisionTargets result = chain.analyze(in.pair, iteration++);
        times.add(result);
        benchmark::DoNotOptimize(result.targets.data());
    }
    state.counters["faults"] = benchmark::Counter(static_cast<double>(minorFaults() - faults0),
                                                  benchmark::Counter::kAvgIterations);
    times.report(state);
    state.counters["megapixels"] = in.pair.size().area() / 1e6;  // per image: divide total_ms by it for ms/MP
    reportFound(state, f);
}

void BM_Pipeline(benchmark::State& state, const std::string& name, bool parallel, bool veil = false) {
    BM_PipelineWith(state, name, parallel, veil, false, false);
}

/// The tracking mode (config.analysis.tracking) on one thread: the lab pair
/// again and again, a whole-image search every @p fullFrameEvery frames and
/// the rest searched only around the two targets. Counters: the CPU time per
/// pair (AnalyzeStereoImagePair::lastCpuTimings, median over all frames and
/// over the tracking frames alone) and the share of the image searched.
/// fullFrameEvery 0: tracking off. @p coarse: whole-image frames coarse-to-fine.
void BM_Tracking(benchmark::State& state, const std::string& name, int fullFrameEvery, bool coarse) {
    const Input& in = input(name);
    AvatarConfig config = in.config;
    config.analysis.tracking.enabled = fullFrameEvery > 0;
    config.analysis.tracking.fullFrameEvery = std::max(fullFrameEvery, 1);
    config.analysis.coarseToFine.enabled = coarse;
    AnalyzeStereoImagePair chain(config);
    chain.setParallel(false);
    std::uint64_t iteration = 0;
    for (int i = 0; i < 2; ++i) {  // a whole image, then a tracking frame: both must find what the scene holds
        const Found f = found(chain, chain.analyze(in.pair, iteration++));
        if (const std::string error = check(in, f); !error.empty()) {
            state.SkipWithError(error.c_str());
            return;
        }
    }
    if (fullFrameEvery > 2 && !(chain.lastFrame().tracking() && !chain.lastFrame().coarse)) {
        state.SkipWithError("the second frame was not a tracking frame");
        return;
    }
    std::vector<double> cpu, trackingCpu, searched;
    StageTimes times;
    const long faults0 = minorFaults();
    for (auto _ : state) {
        const VisionTargets result = chain.analyze(in.pair, iteration++);
        benchmark::DoNotOptimize(result.targets.data());
        times.add(result);
        const double ms = chain.lastCpuTimings().back().milliseconds;
        cpu.push_back(ms);
        double area = 0.0;
        for (const cv::Rect& r : chain.lastFrame().regionsOf(Side::Left)) area += r.area();
        if (chain.lastFrame().tracking()) {  // tracking or coarse: the share searched at full resolution
            trackingCpu.push_back(ms);
            searched.push_back(area / in.pair.size().area());
        }
    }
    state.counters["faults"] = benchmark::Counter(static_cast<double>(minorFaults() - faults0),
                                                  benchmark::Counter::kAvgIterations);
    state.counters["cpu_ms"] = median(cpu);
    state.counters["tracking_cpu_ms"] = median(trackingCpu);
    state.counters["searched"] = median(searched);
    times.report(state);
}

void BM_Baseline(benchmark::State& state, const std::string& name) {
    const Input& in = input(name);
    Baseline baseline(in.config);
    StageTimes times;
    int stereo = baseline.run(in.pair, times);
    times = {};
    for (auto _ : state) {
        stereo = baseline.run(in.pair, times);
        benchmark::DoNotOptimize(stereo);
    }
    times.report(state);
    state.counters["stereo"] = stereo;
}

/// CPU time of the whole process (every thread: OpenCV's workers too), ms.
double processCpuMs() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
}

/// The chain and the baseline alternately, so that both see the same load;
/// the reported time is the chain's.
void BM_PipelineVsBaseline(benchmark::State& state, const std::string& name, bool parallel) {
    const Input& in = input(name);
    AnalyzeStereoImagePair chain(in.config);
    chain.setParallel(parallel);
    Baseline baseline(in.config);
    StageTimes chainTimes, baselineTimes, chainCpuTimes;
    for (std::uint64_t i = 0; i < 2; ++i) chain.analyze(in.pair, i);
    baseline.run(in.pair, baselineTimes);
    baselineTimes = {};
    std::uint64_t iteration = 2;
    std::vector<double> chainCpu, baselineCpu;
    for (auto _ : state) {
        const VisionTargets result = chain.analyze(in.pair, iteration++);
        chainTimes.add(result);
        chainCpuTimes.add(chain.lastCpuTimings());
        chainCpu.push_back(chain.lastCpuTimings().back().milliseconds);  // both of its threads
        state.SetIterationTime(result.timings.back().milliseconds / 1000.0);
        const double c0 = processCpuMs();
        benchmark::DoNotOptimize(baseline.run(in.pair, baselineTimes));
        baselineCpu.push_back(processCpuMs() - c0);
    }
    const double ours = chainTimes.medianOf("total"), theirs = baselineTimes.medianOf("total");
    state.counters["total_ms"] = ours;
    state.counters["baseline_ms"] = theirs;
    state.counters["speedup"] = ours > 0.0 ? theirs / ours : 0.0;
    // CPU against CPU: the chain's threads against every thread of the process during the baseline.
    const double oursCpu = median(chainCpu), theirsCpu = median(baselineCpu);
    state.counters["cpu_ms"] = oursCpu;
    state.counters["baseline_cpu_ms"] = theirsCpu;
    state.counters["cpu_speedup"] = oursCpu > 0.0 ? theirsCpu / oursCpu : 0.0;
    chainCpuTimes.report(state, "cpu_");  // each stage's, both threads
}

/// Deep copies of @p pair, together at least 64 MB (twice the L3 cache):
/// analysed in turn, each pair's mosaics come from memory as a camera's
/// fresh frames do, while the analyser's own buffers and factors stay as
/// warm as they would in a vision loop.
std::vector<StereoImagePair> freshCopies(const StereoImagePair& pair) {
    const std::size_t bytes = pair.left().total() * pair.left().elemSize() * 2;
    const std::size_t count = std::max<std::size_t>(4, (64u << 20) / std::max<std::size_t>(bytes, 1) + 1);
    std::vector<StereoImagePair> copies;
    for (std::size_t i = 0; i < count; ++i)
        copies.emplace_back(pair.left().clone(), pair.right().clone(), pair.layout(), pair.id());
    return copies;
}

/// Fresh frames (freshCopies), one thread: the chain's CPU per pair
/// (`cpu_ms`, lastCpuTimings) and per megapixel.
void BM_PipelineFresh(benchmark::State& state, const std::string& name) {
    const Input& in = input(name);
    const std::vector<StereoImagePair> pairs = freshCopies(in.pair);
    AnalyzeStereoImagePair chain(in.config);
    chain.setParallel(false);
    const Found f = found(chain, chain.analyze(pairs[0], 0));
    if (const std::string error = check(in, f); !error.empty()) {
        state.SkipWithError(error.c_str());
        return;
    }
    chain.analyze(pairs[1], 1);
    std::vector<double> cpu;
    std::uint64_t iteration = 2;
    for (auto _ : state) {
        const VisionTargets result = chain.analyze(pairs[iteration % pairs.size()], iteration);
        ++iteration;
        benchmark::DoNotOptimize(result.targets.data());
        cpu.push_back(chain.lastCpuTimings().back().milliseconds);
    }
    const double megapixels = in.pair.size().area() / 1e6;
    state.counters["cpu_ms"] = median(cpu);
    state.counters["ms_per_mp"] = median(cpu) / megapixels;
    state.counters["copies"] = static_cast<double>(pairs.size());
}

/// Fresh frames for both: each iteration analyses 8 fresh pairs with the
/// one-thread chain, then the same 8 with the OpenCV baseline (blocks, not
/// single frames, so that each keeps its own state warm as it would alone,
/// while both see about the same load). CPU against CPU: the chain's
/// threads, every thread of the process during the baseline (the first
/// frame of each block not counted).
void BM_PipelineFreshVsBaseline(benchmark::State& state, const std::string& name) {
    const Input& in = input(name);
    const std::vector<StereoImagePair> pairs = freshCopies(in.pair);
    AnalyzeStereoImagePair chain(in.config);
    chain.setParallel(false);
    Baseline baseline(in.config);
    StageTimes baselineTimes;
    for (std::uint64_t i = 0; i < 2; ++i) chain.analyze(pairs[i], i);
    baseline.run(pairs[0], baselineTimes);
    std::vector<double> ours, theirs;
    std::uint64_t iteration = 2;
    std::size_t next = 0;
    constexpr int kBlock = 8;
    for (auto _ : state) {
        const std::size_t first = next;
        for (int k = 0; k < kBlock; ++k) {
            chain.analyze(pairs[next % pairs.size()], iteration++);
            ++next;
            if (k > 0) ours.push_back(chain.lastCpuTimings().back().milliseconds);
        }
        next = first;
        for (int k = 0; k < kBlock; ++k) {
            const double c0 = processCpuMs();
            benchmark::DoNotOptimize(baseline.run(pairs[next % pairs.size()], baselineTimes));
            ++next;
            if (k > 0) theirs.push_back(processCpuMs() - c0);
        }
    }
    state.counters["cpu_ms"] = median(ours);
    state.counters["baseline_cpu_ms"] = median(theirs);
    state.counters["cpu_speedup"] = median(ours) > 0.0 ? median(theirs) / median(ours) : 0.0;
}

/// One scene at 0.3, 1.2 and 5 MP (lab_640x480, lab_1280x960,
/// lab_2448x2048), one thread, the three in turn in every iteration so that
/// all see the same load: CPU ms per megapixel of each (medians) and the
/// largest over the smallest (`spread`; linear: 1).
void BM_PipelineScaling(benchmark::State& state) {
    const std::vector<std::string> names{"lab_640x480", "lab_1280x960", "lab_2448x2048"};
    std::vector<const Input*> inputs;
    std::vector<std::unique_ptr<AnalyzeStereoImagePair>> chains;
    for (const std::string& name : names) {
        inputs.push_back(&input(name));
        chains.push_back(std::make_unique<AnalyzeStereoImagePair>(inputs.back()->config));
        chains.back()->setParallel(false);
        const Found f = found(*chains.back(), chains.back()->analyze(inputs.back()->pair, 0));
        if (const std::string error = check(*inputs.back(), f); !error.empty()) {
            state.SkipWithError((name + ": " + error).c_str());
            return;
        }
        chains.back()->analyze(inputs.back()->pair, 1);
    }
    std::vector<std::vector<double>> perMp(names.size());
    std::uint64_t iteration = 2;
    for (auto _ : state) {
        for (std::size_t k = 0; k < names.size(); ++k) {
            benchmark::DoNotOptimize(chains[k]->analyze(inputs[k]->pair, iteration).targets.data());
            perMp[k].push_back(chains[k]->lastCpuTimings().back().milliseconds /
                               (inputs[k]->pair.size().area() / 1e6));
        }
        ++iteration;
    }
    double lo = 1e300, hi = 0.0;
    for (std::size_t k = 0; k < names.size(); ++k) {
        const double m = median(perMp[k]);
        state.counters["ms_per_mp_" + names[k].substr(4)] = m;
        lo = std::min(lo, m);
        hi = std::max(hi, m);
    }
    state.counters["spread"] = lo > 0.0 ? hi / lo : 0.0;
}

void BM_FirstFrame(benchmark::State& state, const std::string& name) {
    const Input& in = input(name);
    const long faults0 = minorFaults();
    StageTimes times;
    for (auto _ : state) {
        AnalyzeStereoImagePair chain(in.config);
        times.add(chain.analyze(in.pair, 0));
    }
    state.counters["faults"] = benchmark::Counter(static_cast<double>(minorFaults() - faults0),
                                                  benchmark::Counter::kAvgIterations);
    times.report(state);
}

// ---------------------------------------------------------------------------
// The match stage alone, on the features the chain found
// ---------------------------------------------------------------------------

/// EpipolarBox matching with every candidate's shape error computed: all
/// pairs through the box and area tests, then shapeError() and maxError, the
/// least (error, right index) per left feature, then HandleRepeatMatches (a
/// right feature goes to the least error, equal errors to the lower left
/// index). The same decisions as SIPFeatureMatcher, without its candidate
/// grid and without pruning candidates by a bound on the shape error.
std::vector<FeatureMatch> allPairsBoxMatch(const MatchConfig& m, const std::vector<Feature>& l,
                                           const std::vector<Feature>& r) {
    std::vector<FeatureMatch> best(l.size());
    for (std::size_t i = 0; i < l.size(); ++i)
        for (std::size_t j = 0; j < r.size(); ++j) {
            const double dx = l[i].centroid.x - r[j].centroid.x;
            const double dy = l[i].centroid.y - r[j].centroid.y;
            if (!(m.boxDxMin < dx && dx < m.boxDxMax && m.boxDyMin < dy && dy < m.boxDyMax)) continue;
            const double small = std::min(l[i].area, r[j].area), large = std::max(l[i].area, r[j].area);
            if (large > m.shape.maxAreaRatio * small) continue;
            const double e = shapeError(l[i], r[j], m.shape);
            if (!(e <= m.shape.maxError)) continue;
            FeatureMatch& b = best[i];
            if (b.right < 0 || e < b.shapeError || (e == b.shapeError && static_cast<int>(j) < b.right))
                b = {static_cast<int>(i), static_cast<int>(j), e};
        }
    std::vector<int> owner(r.size(), -1);
    for (std::size_t i = 0; i < best.size(); ++i) {
        if (best[i].right < 0) continue;
        int& o = owner[static_cast<std::size_t>(best[i].right)];
        if (o < 0 || best[i].shapeError < best[static_cast<std::size_t>(o)].shapeError) o = static_cast<int>(i);
    }
    std::vector<FeatureMatch> out;
    for (std::size_t i = 0; i < best.size(); ++i)
        if (best[i].right >= 0 && owner[static_cast<std::size_t>(best[i].right)] == static_cast<int>(i))
            out.push_back(best[i]);
    return out;
}

bool sameMatches(const std::vector<FeatureMatch>& a, const std::vector<FeatureMatch>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t k = 0; k < a.size(); ++k)
        if (a[k].left != b[k].left || a[k].right != b[k].right || a[k].shapeError != b[k].shapeError)
            return false;
    return true;
}

/// SIPFeatureMatcher (allPairs false) or allPairsBoxMatch() on the features of
/// each target type that the chain found in the input, as the match stage
/// calls it, both with repeats voided (RepeatMatchPolicy::Void); they are
/// checked to agree before timing. With @p reassign, SIPFeatureMatcher alone
/// with the default RepeatMatchPolicy::Reassign (no reference to check it
/// against here; tests/analyze/FeatureMatcherTest.cpp does). Counters:
/// features and matches over the types.
void BM_Match(benchmark::State& state, const std::string& name, bool allPairs, bool reassign) {
    const Input& in = input(name);
    if (in.config.match.method != MatchMethod::EpipolarBox) {
        state.SkipWithError("the all-pairs reference is for the epipolar box");
        return;
    }
    AnalyzeStereoImagePair chain(in.config);
    chain.analyze(in.pair, 0);
    const auto& left = chain.lastFrame().at(Side::Left).features;
    const auto& right = chain.lastFrame().at(Side::Right).features;
    // Both void repeats: the all-pairs reference does not re-pair them.
    MatchConfig config = in.config.match;
    config.repeats = reassign ? RepeatMatchPolicy::Reassign : RepeatMatchPolicy::Void;
    const SIPFeatureMatcher matcher(config, in.config.stereo);
    const auto run = [&](std::size_t type) {
        return allPairs ? allPairsBoxMatch(config, left[type], right[type])
                        : matcher.match(left[type], right[type]);
    };
    std::size_t features = 0, matches = 0;
    for (std::size_t t = 0; t < left.size(); ++t) {
        const auto ours = matcher.match(left[t], right[t]);
        if (!reassign && !sameMatches(ours, allPairsBoxMatch(config, left[t], right[t]))) {
            state.SkipWithError("SIPFeatureMatcher and the all-pairs reference disagree");
            return;
        }
        features += left[t].size();
        matches += ours.size();
    }
    for (auto _ : state)
        for (std::size_t t = 0; t < left.size(); ++t) {
            const auto m = run(t);
            benchmark::DoNotOptimize(m.data());
        }
    state.counters["features_L"] = static_cast<double>(features);
    state.counters["matches"] = static_cast<double>(matches);
}

std::vector<std::string> inputNames() {
    std::vector<std::string> names{"lab_1280x960"};
    for (const char* size : {"640x480", "1280x960", "2448x2048"})
        for (int n : {1, 10, 1000}) names.push_back(std::string("synthetic_") + size + "/n:" + std::to_string(n));
    return names;
}

void registerAll() {
    for (const std::string& name : inputNames()) {
        benchmark::RegisterBenchmark(("Pipeline/" + name).c_str(), BM_Pipeline, name, true, false)
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime();
        benchmark::RegisterBenchmark(("Baseline/" + name).c_str(), BM_Baseline, name)
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime();
    }
    // One thread: CPU time per pair, and per megapixel from 0.3 to 5 MP.
    for (const std::string name : {"lab_1280x960", "lab_640x480", "lab_2448x2048", "synthetic_640x480/n:1",
                                   "synthetic_1280x960/n:1", "synthetic_2448x2048/n:1", "synthetic_1280x960/n:10"})
        benchmark::RegisterBenchmark(("PipelineSerial/" + name).c_str(), BM_Pipeline, name, false, false)
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime();
    for (const std::string name : {"lab_1280x960", "synthetic_1280x960/n:10"})
        benchmark::RegisterBenchmark(("PipelineSerialVeil/" + name).c_str(), BM_Pipeline, name, false, true)
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime();
    for (const std::string name : {"synthetic_640x480/n:1000", "synthetic_1280x960/n:1000"}) {
        benchmark::RegisterBenchmark(("PipelineSerial/" + name).c_str(), BM_Pipeline, name, false, false)
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime();
        benchmark::RegisterBenchmark(("PipelineSerialVoided/" + name).c_str(), BM_PipelineWith, name, false, false,
                                     false, true)
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime();
    }
    benchmark::RegisterBenchmark("PipelineSerialWater/lab_1280x960", BM_PipelineWith, std::string("lab_1280x960"),
                                 false, false, true, false)
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
    benchmark::RegisterBenchmark("PipelineScaling/lab", BM_PipelineScaling)->Unit(benchmark::kMillisecond);
    for (const std::string name : {"lab_640x480", "lab_1280x960", "lab_2448x2048"})
        benchmark::RegisterBenchmark(("PipelineFresh/" + name).c_str(), BM_PipelineFresh, name)
            ->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark("PipelineFreshVsBaseline/lab_1280x960", BM_PipelineFreshVsBaseline,
                                 std::string("lab_1280x960"))
        ->Unit(benchmark::kMillisecond);
    for (const std::string name : {"lab_1280x960", "synthetic_1280x960/n:10"}) {
        benchmark::RegisterBenchmark(("PipelineVsBaseline/" + name).c_str(), BM_PipelineVsBaseline, name, true)
            ->Unit(benchmark::kMillisecond)
            ->UseManualTime();
        benchmark::RegisterBenchmark(("PipelineSerialVsBaseline/" + name).c_str(), BM_PipelineVsBaseline, name,
                                     false)
            ->Unit(benchmark::kMillisecond)
            ->UseManualTime();
    }
    for (const bool coarse : {false, true}) {
        for (const int every : {1000000, 30})
            benchmark::RegisterBenchmark(
                ((coarse ? "TrackingCoarse/lab_1280x960/full_every:" : "Tracking/lab_1280x960/full_every:") +
                 std::to_string(every))
                    .c_str(),
                BM_Tracking, std::string("lab_1280x960"), every, coarse)
                ->Unit(benchmark::kMillisecond)
                ->UseRealTime();
    }
    for (const std::string name : {"lab_1280x960", "synthetic_1280x960/n:10"})
        benchmark::RegisterBenchmark(("CoarseToFine/" + name).c_str(), BM_Tracking, name, 0, true)
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime();
    benchmark::RegisterBenchmark("FirstFrame/lab_1280x960", BM_FirstFrame, std::string("lab_1280x960"))
        ->Unit(benchmark::kMillisecond)
        ->UseRealTime();
    for (const std::string& name : inputNames()) {
        benchmark::RegisterBenchmark(("Match/" + name).c_str(), BM_Match, name, false, false)
            ->Unit(benchmark::kMicrosecond);
        benchmark::RegisterBenchmark(("MatchAllPairs/" + name).c_str(), BM_Match, name, true, false)
            ->Unit(benchmark::kMicrosecond);
        benchmark::RegisterBenchmark(("MatchReassign/" + name).c_str(), BM_Match, name, false, true)
            ->Unit(benchmark::kMicrosecond);
    }
}

}  // namespace
}  // namespace avatar

int main(int argc, char** argv) {
    benchmark::Initialize(&argc, argv);
    if (argc > 1 && std::string(argv[1]).rfind("--opencv_threads=", 0) == 0) {
        cv::setNumThreads(std::stoi(std::string(argv[1]).substr(17)));
        --argc;
    }
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    avatar::registerAll();
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
