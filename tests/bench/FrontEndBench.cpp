// The per-pixel stages of one 1280x960 16-bit Bayer image, one thread:
//
//   FrontEnd/Fused     the fused front end (analyze/src/FrontEnd.h): lighting
//                      (on the mosaic), demosaic, the colour filter of two
//                      target types and the visibility measures in one pass
//                      over the rows
//   FrontEnd/Stages    the same stages one after the other, as the chain ran
//                      them before the fused pass (demosaic(), then
//                      LightingCorrector::apply, colorFilterMasks and
//                      measureVisibility), the baseline of the ratio
//   FrontEnd/OpenCv    the plain OpenCV way: cv::cvtColor, cv::multiply by the
//                      factor image, float ratios with cv::divide and
//                      cv::inRange per ratio and type, cv::resize/meanStdDev
//
// CPU time per image; both outputs are checked equal before timing. Run with
//   bench_front_end --benchmark_repetitions=9 --benchmark_report_aggregates_only=true

#include "FrontEnd.h"

#include <avatar/analyze/ImageColorFilter.h>
#include <avatar/analyze/LightingCorrection.h>
#include <avatar/analyze/Visibility.h>
#include <avatar/common/ImageUtils.h>
#include <avatar/config/ConfigXml.h>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <random>
#include <stdexcept>

using namespace avatar;

namespace {

struct Input {
    cv::Mat mosaic;
    AvatarConfig config;
    LightingCorrector lighting;
    cv::Mat factors;  ///< per mosaic site
    std::vector<detail::ColorTest> tests;

    static AvatarConfig sample() {
        AvatarConfig c = readConfigFile(std::string(AVATAR_DATA_DIR) + "/config/scorpion.xml");
        c.lighting.frameAverageEnabled = true;
        c.lighting.gainsRgb = {1.3, 0.9, 1.1};
        c.lighting.patternEnabled = true;
        c.lighting.patternCentrePx = {640.0, 480.0};
        c.lighting.red = {1.0, 0.001};
        c.lighting.green = {1.0, 0.0008};
        c.lighting.blue = {1.0, 0.0012};
        return c;
    }

    Input() : config(sample()), lighting(config.lighting) {
        const cv::Size size(1280, 960);
        mosaic.create(size, CV_16UC1);
        std::mt19937 rng(5);
        std::normal_distribution<double> noise(0.0, 300.0);
        for (int y = 0; y < size.height; ++y)
            for (int x = 0; x < size.width; ++x) {
                const double v = 20000.0 + 15000.0 * std::sin(0.01 * x + 0.3 * ((x + y) & 1)) * std::cos(0.013 * y);
                mosaic.at<std::uint16_t>(y, x) = cv::saturate_cast<std::uint16_t>(v + noise(rng));
            }
        lighting.prepare(size);
        lighting.prepareMosaic(size, config.camera.bayerPattern);
        factors = lighting.mosaicFactors();
        for (const TargetType& t : config.targets.targets) tests.emplace_back(t, size, CV_16U, 16);
    }
};

const Input& input() {
    static const Input in;
    return in;
}

struct Staged {
    cv::Mat bgr;
    std::vector<cv::Mat> masks;
    VisibilityMeasures visibility;
};

void stages(const Input& in, Staged& out) {
    out.bgr = demosaic(in.mosaic, in.config.camera.bayerPattern);
    in.lighting.apply(out.bgr, 16);
    colorFilterMasks(out.bgr, 16, in.config.targets.targets, out.masks);
    out.visibility = measureVisibility(out.bgr, 16);
}

void fused(const Input& in, detail::FrontEndResult& out) {
    detail::FrontEndInput f;
    f.mosaic = in.mosaic;
    f.pattern = in.config.camera.bayerPattern;
    f.bitDepth = 16;
    f.factors = &in.factors;
    f.tests = &in.tests;
    f.visibility = true;
    detail::runFrontEnd(f, out);
}

void Fused(benchmark::State& state) {
    const Input& in = input();
    detail::FrontEndResult out;
    fused(in, out);
    // The pass corrects the mosaic's sites, then demosaics: its reference.
    cv::Mat corrected(in.mosaic.size(), CV_16UC1);
    for (int y = 0; y < corrected.rows; ++y)
        for (int x = 0; x < corrected.cols; ++x)
            corrected.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(static_cast<std::int32_t>(
                std::min(static_cast<float>(in.mosaic.at<std::uint16_t>(y, x)) * in.factors.at<float>(y, x), 65535.0f) +
                0.5f));
    if (cv::norm(out.bgr, demosaic(corrected, in.config.camera.bayerPattern), cv::NORM_INF) != 0.0)
        state.SkipWithError("the fused image differs from its reference");
    for (auto _ : state) {
        fused(in, out);
        benchmark::DoNotOptimize(out.bgr.data);
    }
}

void Stages(benchmark::State& state) {
    const Input& in = input();
    Staged out;
    for (auto _ : state) {
        stages(in, out);
        benchmark::DoNotOptimize(out.bgr.data);
    }
}

void OpenCv(benchmark::State& state) {
    const Input& in = input();
    cv::Mat bgr, lit, f, planes[3], ratio, inRange, mask, small, luma;
    for (auto _ : state) {
        cv::cvtColor(in.mosaic, bgr, cv::COLOR_BayerRG2BGR);
        cv::multiply(bgr, in.lighting.factors(), lit, 1.0, CV_16UC3);
        lit.convertTo(f, CV_32FC3);
        cv::split(f, planes);
        for (const TargetType& t : in.config.targets.targets) {
            mask = cv::Mat(f.size(), CV_8UC1, cv::Scalar(255));
            const std::pair<int, int> pairs[3] = {{2, 1}, {2, 0}, {0, 1}};
            const Range* ranges[3] = {&t.redGreen, &t.redBlue, &t.blueGreen};
            for (int k = 0; k < 3; ++k) {
                cv::divide(planes[pairs[k].first], planes[pairs[k].second], ratio);
                cv::inRange(ratio, ranges[k]->min, ranges[k]->max, inRange);
                cv::bitwise_and(mask, inRange, mask);
            }
        }
        cv::resize(f, small, cv::Size(), 0.25, 0.25, cv::INTER_AREA);
        cv::cvtColor(small, luma, cv::COLOR_BGR2GRAY);
        cv::Scalar mean, dev;
        cv::meanStdDev(luma, mean, dev);
        benchmark::DoNotOptimize(dev[0]);
    }
}

}  // namespace

BENCHMARK(Fused)->Name("FrontEnd/Fused")->Unit(benchmark::kMillisecond);
BENCHMARK(Stages)->Name("FrontEnd/Stages")->Unit(benchmark::kMillisecond);
BENCHMARK(OpenCv)->Name("FrontEnd/OpenCv")->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
