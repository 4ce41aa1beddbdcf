// erodeRestore + locateFeatures on 1280x960 masks with 1, 10 and 1,000
// features, against a plain OpenCV baseline (cv::erode +
// cv::connectedComponentsWithStats: no restore, no boundary points, no
// geometric filter). Run with
//   bench_feature_locator --benchmark_repetitions=9 --benchmark_report_aggregates_only=true

#include <avatar/analyze/ImageFeatureLocator.h>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cstddef>
#include <cstdint>

namespace {

constexpr int kWidth = 1280;
constexpr int kHeight = 960;
constexpr int kNoisePixels = 300;

/// A sparse filtered mask: @p features filled discs that survive a 3x3
/// erosion, plus single noise pixels that do not.
cv::Mat makeMask(int features) {
    cv::Mat mask = cv::Mat::zeros(kHeight, kWidth, CV_8UC1);
    if (features == 1) {
        cv::circle(mask, {640, 480}, 60, cv::Scalar(255), cv::FILLED);
    } else if (features == 10) {
        for (int i = 0; i < 10; ++i) {
            cv::circle(mask, {120 + 110 * i, 200 + 50 * (i % 5)}, 25, cv::Scalar(255), cv::FILLED);
        }
    } else {
        // 40 x 25 grid of discs of radius 6 (area 113) on a 32 x 38 pitch.
        for (int i = 0; i < features; ++i) {
            cv::circle(mask, {16 + 32 * (i % 40), 19 + 38 * (i / 40)}, 6, cv::Scalar(255),
                       cv::FILLED);
        }
    }
    cv::RNG rng(12345);
    for (int i = 0; i < kNoisePixels; ++i) {
        mask.at<std::uint8_t>(rng.uniform(0, kHeight), rng.uniform(0, kWidth)) = 255;
    }
    return mask;
}

cv::Mat makeIntensity() {
    cv::Mat image(kHeight, kWidth, CV_8UC3);
    cv::randu(image, cv::Scalar::all(0), cv::Scalar::all(256));
    return image;
}

avatar::TargetType benchType() {
    avatar::TargetType t;
    t.name = "bench";
    t.area = {20.0, 1e9};
    t.aspectRatio = {0.2, 5.0};
    t.areaRatio = {0.3, 1.0};
    return t;
}

void BM_ErodeRestoreLocate(benchmark::State& state) {
    const cv::Mat mask = makeMask(static_cast<int>(state.range(0)));
    const avatar::TargetType type = benchType();
    const cv::Rect window = avatar::searchWindow(type, mask.size());
    std::size_t found = 0;
    for (auto _ : state) {
        const cv::Mat restored = avatar::erodeRestore(mask, 3);
        const auto features = avatar::locateFeatures(restored, cv::Mat(), type, window);
        found = features.size();
        benchmark::DoNotOptimize(features.data());
    }
    state.counters["features"] = static_cast<double>(found);
}

void BM_ErodeRestoreLocateWeighted(benchmark::State& state) {
    const cv::Mat mask = makeMask(static_cast<int>(state.range(0)));
    const cv::Mat intensity = makeIntensity();
    const avatar::TargetType type = benchType();
    const cv::Rect window = avatar::searchWindow(type, mask.size());
    std::size_t found = 0;
    for (auto _ : state) {
        const cv::Mat restored = avatar::erodeRestore(mask, 3);
        const auto features = avatar::locateFeatures(restored, intensity, type, window);
        found = features.size();
        benchmark::DoNotOptimize(features.data());
    }
    state.counters["features"] = static_cast<double>(found);
}

void BM_ErodeRestore(benchmark::State& state) {
    const cv::Mat mask = makeMask(static_cast<int>(state.range(0)));
    for (auto _ : state) {
        const cv::Mat restored = avatar::erodeRestore(mask, 3);
        benchmark::DoNotOptimize(restored.data);
    }
}

void BM_LocateFeatures(benchmark::State& state) {
    const cv::Mat restored = avatar::erodeRestore(makeMask(static_cast<int>(state.range(0))), 3);
    const avatar::TargetType type = benchType();
    const cv::Rect window = avatar::searchWindow(type, restored.size());
    for (auto _ : state) {
        const auto features = avatar::locateFeatures(restored, cv::Mat(), type, window);
        benchmark::DoNotOptimize(features.data());
    }
}

/// The baseline: what plain OpenCV calls give for the same mask.
void BM_OpenCvBaseline(benchmark::State& state) {
    const cv::Mat mask = makeMask(static_cast<int>(state.range(0)));
    const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, {3, 3});
    int components = 0;
    for (auto _ : state) {
        cv::Mat eroded;
        cv::Mat labels;
        cv::Mat stats;
        cv::Mat centroids;
        cv::erode(mask, eroded, kernel);
        components = cv::connectedComponentsWithStats(eroded, labels, stats, centroids, 8, CV_32S);
        benchmark::DoNotOptimize(stats.data);
    }
    state.counters["features"] = components - 1;
}

BENCHMARK(BM_ErodeRestoreLocate)->Arg(1)->Arg(10)->Arg(1000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ErodeRestoreLocateWeighted)->Arg(1)->Arg(10)->Arg(1000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_OpenCvBaseline)->Arg(1)->Arg(10)->Arg(1000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ErodeRestore)->Arg(1)->Arg(10)->Arg(1000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_LocateFeatures)->Arg(1)->Arg(10)->Arg(1000)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
