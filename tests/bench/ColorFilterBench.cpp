// Colour filter (thesis 3.3.2) and lighting correction (thesis 3.2) on a
// 1280x960 16-bit BGR image, against a straightforward OpenCV baseline in the
// same binary, all on one core. Run with
//   bench_color_filter --benchmark_repetitions=9 --benchmark_report_aggregates_only=true
#include <avatar/analyze/ImageColorFilter.h>
#include <avatar/analyze/LightingCorrection.h>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <vector>

namespace {

constexpr int kWidth = 1280;
constexpr int kHeight = 960;

/// A 16-bit BGR image with smooth colour gradients, blobs of the two target
/// colours and noise, so that every branch of a filter is exercised.
cv::Mat makeImage16() {
    cv::Mat image(kHeight, kWidth, CV_16UC3);
    cv::RNG rng(20240611);
    rng.fill(image, cv::RNG::UNIFORM, cv::Scalar::all(0), cv::Scalar::all(65536));
    for (int i = 0; i < 40; ++i) {
        const cv::Point c(rng.uniform(0, kWidth), rng.uniform(0, kHeight));
        const cv::Scalar colour = i % 2 == 0 ? cv::Scalar(9000, 12000, 30000) : cv::Scalar(5000, 30000, 8000);
        cv::circle(image, c, rng.uniform(5, 60), colour, cv::FILLED);
    }
    return image;
}

std::vector<avatar::TargetType> makeTypes() {
    avatar::TargetType sample;
    sample.name = "sample";
    sample.redGreen = {1.8, 3.2};
    sample.redBlue = {2.5, 4.0};
    sample.blueGreen = {0.5, 1.0};
    sample.brightness = avatar::Range{20000.0, 150000.0};
    avatar::TargetType marker;
    marker.name = "arm_marker";
    marker.redGreen = {0.1, 0.4};
    marker.redBlue = {1.2, 2.0};
    marker.blueGreen = {0.1, 0.3};
    return {sample, marker};
}

void BM_ColorFilter16(benchmark::State& state) {
    const cv::Mat image = makeImage16();
    const auto types = makeTypes();
    std::vector<cv::Mat> masks;
    for (auto _ : state) {
        avatar::colorFilterMasks(image, 16, types, masks);
        benchmark::DoNotOptimize(masks.data());
        benchmark::ClobberMemory();
    }
}
BENCHMARK(BM_ColorFilter16)->Unit(benchmark::kMillisecond);

/// The same types seen through haze (a veil of 0.7 : 1 : 1 up to 0.3 of G):
/// the pixels the ranges reject but the hull's bounding box passes take the
/// hull's edges too.
void BM_ColorFilter16Veil(benchmark::State& state) {
    const cv::Mat image = makeImage16();
    auto types = makeTypes();
    for (auto& t : types) t.veil = avatar::Veil{{0.7, 1.0, 1.0}, 0.3, std::nullopt, std::nullopt};
    std::vector<cv::Mat> masks;
    for (auto _ : state) {
        avatar::colorFilterMasks(image, 16, types, masks);
        benchmark::DoNotOptimize(masks.data());
        benchmark::ClobberMemory();
    }
}
BENCHMARK(BM_ColorFilter16Veil)->Unit(benchmark::kMillisecond);

/// The same types seen through the site's water (R/G down to exp(-1.2),
/// B/G to exp(-0.35) of their ranges' minima): one more box of ratio limits.
void BM_ColorFilter16Water(benchmark::State& state) {
    const cv::Mat image = makeImage16();
    auto types = makeTypes();
    for (auto& t : types) t.water = avatar::Water{{0.24, 0.0, 0.07}, 5.0, std::nullopt, std::nullopt};
    std::vector<cv::Mat> masks;
    for (auto _ : state) {
        avatar::colorFilterMasks(image, 16, types, masks);
        benchmark::DoNotOptimize(masks.data());
        benchmark::ClobberMemory();
    }
}
BENCHMARK(BM_ColorFilter16Water)->Unit(benchmark::kMillisecond);

void BM_ColorFilter8(benchmark::State& state) {
    cv::Mat image;
    makeImage16().convertTo(image, CV_8UC3, 1.0 / 257.0);
    auto types = makeTypes();
    types[0].brightness = avatar::Range{20000.0 / 257.0, 150000.0 / 257.0};
    std::vector<cv::Mat> masks;
    for (auto _ : state) {
        avatar::colorFilterMasks(image, 8, types, masks);
        benchmark::DoNotOptimize(masks.data());
        benchmark::ClobberMemory();
    }
}
BENCHMARK(BM_ColorFilter8)->Unit(benchmark::kMillisecond);

void BM_ColorFilterHsv16(benchmark::State& state) {
    const cv::Mat image = makeImage16();
    auto types = makeTypes();
    for (auto& t : types) t.filter = avatar::ColorFilterMethod::Hsv;
    types[0].hsv = {{340.0, 20.0}, {0.4, 1.0}, {0.2, 1.0}};
    types[1].hsv = {{90.0, 150.0}, {0.5, 1.0}, {0.1, 0.9}};
    std::vector<cv::Mat> masks;
    for (auto _ : state) {
        avatar::colorFilterMasks(image, 16, types, masks);
        benchmark::DoNotOptimize(masks.data());
        benchmark::ClobberMemory();
    }
}
BENCHMARK(BM_ColorFilterHsv16)->Unit(benchmark::kMillisecond);

/// Baseline: the ratios as float images with cv::divide (once for all types),
/// then per type cv::inRange on each ratio and on R+G+B and cv::bitwise_and.
void BM_ColorFilter16OpenCv(benchmark::State& state) {
    const cv::Mat image = makeImage16();
    const auto types = makeTypes();
    std::vector<cv::Mat> masks(types.size());
    cv::Mat imageF, rg, rb, bg, sum, m;
    std::vector<cv::Mat> ch;
    for (auto _ : state) {
        image.convertTo(imageF, CV_32F);
        cv::split(imageF, ch);
        cv::divide(ch[2], ch[1], rg);
        cv::divide(ch[2], ch[0], rb);
        cv::divide(ch[0], ch[1], bg);
        cv::add(ch[0], ch[1], sum);
        cv::add(sum, ch[2], sum);
        for (std::size_t t = 0; t < types.size(); ++t) {
            const auto& type = types[t];
            cv::inRange(rg, type.redGreen.min, type.redGreen.max, masks[t]);
            cv::inRange(rb, type.redBlue.min, type.redBlue.max, m);
            cv::bitwise_and(masks[t], m, masks[t]);
            cv::inRange(bg, type.blueGreen.min, type.blueGreen.max, m);
            cv::bitwise_and(masks[t], m, masks[t]);
            if (type.brightness) {
                cv::inRange(sum, type.brightness->min, type.brightness->max, m);
                cv::bitwise_and(masks[t], m, masks[t]);
            }
        }
        benchmark::DoNotOptimize(masks.data());
        benchmark::ClobberMemory();
    }
}
BENCHMARK(BM_ColorFilter16OpenCv)->Unit(benchmark::kMillisecond);

avatar::LightingConfig lightingConfig() {
    avatar::LightingConfig c;
    c.frameAverageEnabled = true;
    c.gainsRgb = {1.4, 1.1, 0.9};
    c.patternEnabled = true;
    c.patternCentrePx = {640.0, 480.0};
    c.red = {1.0, 0.0012};
    c.green = {1.0, 0.0009};
    c.blue = {1.0, 0.0006};
    return c;
}

void BM_Lighting16(benchmark::State& state) {
    const cv::Mat original = makeImage16();
    avatar::LightingCorrector corrector(lightingConfig());
    corrector.prepare(original.size());
    cv::Mat image = original.clone();
    for (auto _ : state) {
        // Correcting the same buffer again and again saturates it; the cost
        // does not depend on the values (branch-free).
        corrector.apply(image, 16);
        benchmark::DoNotOptimize(image.data);
        benchmark::ClobberMemory();
    }
}
BENCHMARK(BM_Lighting16)->Unit(benchmark::kMillisecond);

/// Baseline: cv::multiply of the 16-bit image by the float factor image,
/// result saturated to 16 bits.
void BM_Lighting16OpenCv(benchmark::State& state) {
    const cv::Mat original = makeImage16();
    avatar::LightingCorrector corrector(lightingConfig());
    corrector.prepare(original.size());
    const cv::Mat& factors = corrector.factors();
    cv::Mat image = original.clone();
    for (auto _ : state) {
        cv::multiply(image, factors, image, 1.0, CV_16U);
        benchmark::DoNotOptimize(image.data);
        benchmark::ClobberMemory();
    }
}
BENCHMARK(BM_Lighting16OpenCv)->Unit(benchmark::kMillisecond);

}  // namespace

// One core for everything: OpenCV's baseline would otherwise use its thread
// pool, while the AVATAR stages run single-threaded (left and right images are
// processed concurrently by the pipeline instead).
int main(int argc, char** argv) {
    cv::setNumThreads(1);
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
