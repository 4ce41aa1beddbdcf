// The fused front end (analyze/src/FrontEnd.h) against the stages it stands
// for, run one after the other: the lighting correction of every mosaic site
// by its colour's factor (LightingCorrector::apply's formula), cv::cvtColor's
// bilinear demosaic (demosaic()), colorFilterMasks and measureVisibility.
// Every output must be identical, bit for bit: the image, every mask and
// every visibility measure, over Bayer patterns, sample depths, bit depths,
// odd sizes, byte order, lighting and the kinds of colour filter (ratio in
// float and in double, HSV, brightness bands, windows). What the order of
// correction and demosaic changes on whole scenes is measured in
// docs/accuracy.md.

#include "BufferPool.h"
#include "FrontEnd.h"
#include "Interleave.h"

#include <avatar/analyze/ImageColorFilter.h>
#include <avatar/analyze/LightingCorrection.h>
#include <avatar/analyze/Visibility.h>
#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/core/hal/hal.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstring>
#include <random>
#include <string>
#include <tuple>
#include <vector>

namespace avatar {
namespace {

/// A mosaic of smooth colour blobs with noise and a few saturated sites, so
/// the filters pass a fair share of pixels and the demosaic sees edges.
cv::Mat mosaicOf(cv::Size size, int depth, int bitDepth, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    const double full = std::ldexp(1.0, bitDepth) - 1.0;
    cv::Mat colour(size, CV_64FC3);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    const double fx = 0.05 + 0.2 * u(rng), fy = 0.05 + 0.2 * u(rng);
    for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x)
            for (int c = 0; c < 3; ++c)
                colour.at<cv::Vec3d>(y, x)[c] =
                    0.5 + 0.45 * std::sin(fx * x * (c + 1) + fy * y * (3 - c) + c) * std::cos(0.03 * (x + y));
    cv::Mat mosaic(size, depth);
    std::normal_distribution<double> noise(0.0, 0.01);
    for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x) {
            const int site = (y & 1) * 2 + (x & 1);  // any fixed assignment will do: the pattern decides the meaning
            const double v = std::clamp(colour.at<cv::Vec3d>(y, x)[site % 3] + noise(rng), 0.0, 1.0);
            double sample = std::round(v * full);
            if (u(rng) < 0.01) sample = full;  // clipped sites
            if (depth == CV_8U) mosaic.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(sample);
            else mosaic.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(sample);
        }
    return mosaic;
}

std::vector<TargetType> filterTypes(cv::Size size) {
    std::vector<TargetType> types;
    TargetType wide;  // limits exact in float for 8-bit only (the 16-bit images take the double kernel)
    wide.name = "wide";
    wide.redGreen = {0.7, 1.43};
    wide.redBlue = {0.61, 1.7};
    wide.blueGreen = {0.5, 1.9};
    types.push_back(wide);
    TargetType simple;  // limits with small denominators: float even at 16 bits
    simple.name = "simple";
    simple.redGreen = {0.5, 2.0};
    simple.redBlue = {0.25, 1e9};
    simple.brightness = Range{300.0, 1e9};
    types.push_back(simple);
    TargetType banded;
    banded.name = "banded";
    banded.redGreen = {0.9, 1.1};
    banded.brightnessBands = {BrightnessBand{{0.0, 600.0}, {0.3, 3.0}, {0.0, 1e9}, {0.0, 1e9}},
                              BrightnessBand{{601.0, 5000.0}, {0.8, 1.25}, {0.5, 2.0}, {0.0, 1e9}}};
    types.push_back(banded);
    TargetType hsv;
    hsv.name = "hsv";
    hsv.filter = ColorFilterMethod::Hsv;
    hsv.hsv.hue = {300.0, 60.0};  // wraps through red
    hsv.hsv.saturation = {0.1, 0.9};
    hsv.hsv.value = {0.2, 1.0};
    types.push_back(hsv);
    TargetType veiled;  // haze: the hull of its box and the box moved towards the veil
    veiled.name = "veiled";
    veiled.redGreen = {0.4, 0.9};
    veiled.blueGreen = {0.3, 0.7};
    veiled.redBlue = {0.8, 2.5};
    veiled.veil = Veil{{0.7, 1.0, 1.0}, 0.4, Range{0.5, 0.7}, std::nullopt};
    types.push_back(veiled);
    TargetType windowed = wide;
    windowed.name = "windowed";
    windowed.window = {size.width / 5, size.height / 3, size.width / 2, size.height / 2};
    types.push_back(windowed);
    return types;
}

LightingConfig lightingConfig(cv::Size size) {
    LightingConfig l;
    l.frameAverageEnabled = true;
    l.gainsRgb = {1.3, 0.9, 1.1};
    l.patternEnabled = true;
    l.patternCentrePx = {size.width * 0.45, size.height * 0.55};
    l.red = {1.2, 0.004};
    l.green = {0.8, 0.002};
    l.blue = {1.0, 0.006};
    return l;
}

struct Case {
    cv::Size size;
    int depth;
    int bitDepth;
    BayerPattern pattern;
    bool lighting;
    bool swap;
};

std::string describe(const Case& c) {
    return std::to_string(c.size.width) + "x" + std::to_string(c.size.height) + (c.depth == CV_8U ? " 8u" : " 16u") +
           " bits " + std::to_string(c.bitDepth) + " " + std::string(toString(c.pattern)) + (c.lighting ? " lit" : "") +
           (c.swap ? " swapped" : "");
}

void expectIdentical(const cv::Mat& a, const cv::Mat& b, const std::string& what) {
    ASSERT_EQ(a.size(), b.size()) << what;
    ASSERT_EQ(a.type(), b.type()) << what;
    cv::Mat diff;
    cv::absdiff(a.reshape(1), b.reshape(1), diff);
    EXPECT_EQ(cv::countNonZero(diff), 0) << what;
}

void checkCase(const Case& c, std::uint64_t seed) {
    SCOPED_TRACE(describe(c));
    cv::Mat mosaic = mosaicOf(c.size, c.depth, c.bitDepth, seed);
    cv::Mat stored = mosaic.clone();  // what the camera delivered: byte-swapped when asked
    if (c.swap) swapEndian16(stored);
    const std::vector<TargetType> types = filterTypes(c.size);

    // The stages one by one, the correction on the mosaic's sites.
    LightingCorrector corrector(lightingConfig(c.size));
    cv::Mat factors;
    cv::Mat corrected = mosaic.clone();
    if (c.lighting) {
        corrector.prepareMosaic(c.size, c.pattern);
        factors = corrector.mosaicFactors();
        const float full = static_cast<float>((1 << c.bitDepth) - 1);
        for (int y = 0; y < c.size.height; ++y)
            for (int x = 0; x < c.size.width; ++x) {
                const float f = factors.at<float>(y, x);
                const auto correct = [&](auto s) {
                    return static_cast<std::int32_t>(std::min(static_cast<float>(s) * f, full) + 0.5f);
                };
                if (c.depth == CV_8U)
                    corrected.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(correct(mosaic.at<std::uint8_t>(y, x)));
                else
                    corrected.at<std::uint16_t>(y, x) =
                        static_cast<std::uint16_t>(correct(mosaic.at<std::uint16_t>(y, x)));
            }
    }
    cv::Mat bgr = demosaic(corrected, c.pattern);
    std::vector<cv::Mat> masks;
    colorFilterMasks(bgr, c.bitDepth, types, masks);
    const VisibilityMeasures visibility = measureVisibility(bgr, c.bitDepth);

    // The fused pass.
    std::vector<detail::ColorTest> tests;
    for (const TargetType& t : types) tests.emplace_back(t, c.size, c.depth, c.bitDepth);
    detail::FrontEndInput in;
    in.mosaic = stored;
    in.pattern = c.pattern;
    in.bitDepth = c.bitDepth;
    in.endianSwap = c.swap;
    in.factors = c.lighting ? &factors : nullptr;
    in.tests = &tests;
    in.visibility = true;
    detail::FrontEndResult out;
    detail::runFrontEnd(in, out);

    expectIdentical(out.bgr, bgr, "image");
    ASSERT_EQ(out.masks.size(), masks.size());
    for (std::size_t t = 0; t < masks.size(); ++t) {
        expectIdentical(out.masks[t], masks[t], "mask of " + types[t].name);
        // Where each row's on pixels lie, as handed to erode_restore and locate_features: exactly.
        ASSERT_EQ(out.maskRows.size(), masks.size());
        EXPECT_TRUE(out.maskRows[t].describes(out.masks[t]));
        for (int y = 0; y < masks[t].rows; ++y) {
            int first = 0, end = 0;
            detail::nonZeroSpan(masks[t].ptr<std::uint8_t>(y), masks[t].cols, first, end);
            const auto row = static_cast<std::size_t>(y);
            ASSERT_EQ(out.maskRows[t].begin[row], first) << types[t].name << " row " << y;
            ASSERT_EQ(out.maskRows[t].end[row], end) << types[t].name << " row " << y;
        }
        // The filters must have had something to decide.
        if (t == 0 && c.size.area() >= 1000) {
            EXPECT_GT(cv::countNonZero(masks[t]), 0) << types[t].name;
        }
    }
    ASSERT_TRUE(out.visibility.has_value());
    EXPECT_EQ(std::memcmp(&out.visibility->contrast, &visibility.contrast, sizeof(double)), 0);
    EXPECT_EQ(std::memcmp(&out.visibility->haze, &visibility.haze, sizeof(double)), 0);
    EXPECT_EQ(std::memcmp(&out.visibility->saturatedFraction, &visibility.saturatedFraction, sizeof(double)), 0);
    if (c.size.area() >= 1000) {
        EXPECT_GT(visibility.saturatedFraction, 0.0);
    }

    // A second run reuses the buffers and gives the same.
    const uchar* image = out.bgr.data;
    detail::runFrontEnd(in, out);
    EXPECT_EQ(out.bgr.data, image);
    expectIdentical(out.bgr, bgr, "image, second run");

    // Mask buffers known to be 0 outside some bands of rows (masksDirty, as
    // a BufferPool says): the bands hold stale values and are written again;
    // elsewhere a row is written only where its verdicts are on. The same masks.
    {
        detail::FrontEndResult known;
        known.bgr = out.bgr.clone();
        const std::vector<cv::Rect> dirty{{0, 0, c.size.width, 1}, {0, c.size.height / 3, c.size.width, c.size.height / 4 + 1}};
        for (std::size_t t = 0; t < masks.size(); ++t) {
            cv::Mat stale = cv::Mat::zeros(c.size, CV_8UC1);
            for (const cv::Rect& r : dirty) stale(r & cv::Rect(cv::Point(), c.size)).setTo(77);
            known.masks.push_back(stale);
            known.masksDirty.push_back(dirty);
        }
        std::vector<const uchar*> buffers;
        for (const cv::Mat& m : known.masks) buffers.push_back(m.data);
        detail::runFrontEnd(in, known);
        for (std::size_t t = 0; t < masks.size(); ++t) {
            EXPECT_EQ(known.masks[t].data, buffers[t]);  // written in place
            expectIdentical(known.masks[t], masks[t], "mask of " + types[t].name + ", rows known to be 0");
            EXPECT_EQ(known.maskRows[t].begin, out.maskRows[t].begin);
            EXPECT_EQ(known.maskRows[t].end, out.maskRows[t].end);
        }
    }

    // Two images of a pair taking turns over strips of rows (one thread,
    // one read of each factor row): each exactly what its own pass gives.
    detail::FrontEndInput other = in;
    cv::Mat flipped;  // a new buffer: other.mosaic shares in's
    cv::flip(stored, flipped, -1);
    other.mosaic = flipped;
    detail::FrontEndResult alone, pairLeft, pairRight;
    detail::runFrontEnd(other, alone);
    detail::runFrontEndPair(in, pairLeft, other, pairRight);
    for (const auto& [got, want, name] : {std::tuple(&pairLeft, &out, "left"), std::tuple(&pairRight, &alone, "right")}) {
        const std::string what = std::string(name) + " of a pair";
        expectIdentical(got->bgr, want->bgr, "image, " + what);
        ASSERT_EQ(got->masks.size(), want->masks.size());
        for (std::size_t t = 0; t < want->masks.size(); ++t) {
            expectIdentical(got->masks[t], want->masks[t], "mask of " + types[t].name + ", " + what);
            EXPECT_EQ(got->maskRows[t].begin, want->maskRows[t].begin) << what;
            EXPECT_EQ(got->maskRows[t].end, want->maskRows[t].end) << what;
        }
        ASSERT_TRUE(got->visibility.has_value());
        EXPECT_EQ(std::memcmp(&got->visibility->contrast, &want->visibility->contrast, sizeof(double)), 0) << what;
        EXPECT_EQ(std::memcmp(&got->visibility->haze, &want->visibility->haze, sizeof(double)), 0) << what;
        EXPECT_EQ(std::memcmp(&got->visibility->saturatedFraction, &want->visibility->saturatedFraction,
                              sizeof(double)),
                  0)
            << what;
    }

    // The portable loops give the same where the CPU runs the AVX-512 ones.
    in.portableKernels = true;
    detail::FrontEndResult portable;
    detail::runFrontEnd(in, portable);
    expectIdentical(portable.bgr, bgr, "image, portable loops");
    for (std::size_t t = 0; t < masks.size(); ++t)
        expectIdentical(portable.masks[t], masks[t], "mask of " + types[t].name + ", portable loops");
    ASSERT_TRUE(portable.visibility.has_value());
    EXPECT_EQ(std::memcmp(&portable.visibility->contrast, &visibility.contrast, sizeof(double)), 0);
    EXPECT_EQ(std::memcmp(&portable.visibility->haze, &visibility.haze, sizeof(double)), 0);
    EXPECT_EQ(std::memcmp(&portable.visibility->saturatedFraction, &visibility.saturatedFraction, sizeof(double)), 0);
}

TEST(FrontEnd, EqualsTheStagesOneByOneBitForBit) {
    std::uint64_t seed = 1;
    for (const BayerPattern pattern : {BayerPattern::BG, BayerPattern::GB, BayerPattern::RG, BayerPattern::GR})
        for (const bool lighting : {false, true}) {
            checkCase({{64, 48}, CV_16U, 16, pattern, lighting, false}, seed++);
            checkCase({{64, 48}, CV_16U, 12, pattern, lighting, true}, seed++);
            checkCase({{64, 48}, CV_8U, 8, pattern, lighting, false}, seed++);
            checkCase({{37, 23}, CV_16U, 14, pattern, lighting, false}, seed++);  // odd: no 4x4 reduction
            checkCase({{4, 4}, CV_16U, 16, pattern, lighting, false}, seed++);    // the smallest it takes
            checkCase({{6, 9}, CV_8U, 7, pattern, lighting, false}, seed++);
        }
}

TEST(FrontEnd, EqualsTheStagesOnAFullFrame) {
    checkCase({{1280, 960}, CV_16U, 16, BayerPattern::BG, true, false}, 99);
    checkCase({{1280, 960}, CV_16U, 12, BayerPattern::GR, false, false}, 100);
}

TEST(FrontEnd, WithoutFilterOrVisibility) {
    const cv::Mat mosaic = mosaicOf({40, 20}, CV_16U, 16, 7);
    detail::FrontEndInput in;
    in.mosaic = mosaic;
    detail::FrontEndResult out;
    detail::runFrontEnd(in, out);
    expectIdentical(out.bgr, demosaic(mosaic, BayerPattern::BG), "image");
    EXPECT_TRUE(out.masks.empty());
    EXPECT_FALSE(out.visibility.has_value());
}

// Each mosaic site takes the factor of its own colour, the very value of the
// three-channel image's (BayerPattern names the first row's two sites: BG =
// blue, green / green, red), for the analytic falloff and for a template.
TEST(FrontEnd, MosaicFactorsAreEachSitesColoursFactors) {
    const cv::Size size(37, 22);
    LightingCorrector corrector(lightingConfig(size));
    corrector.prepare(size);
    for (const BayerPattern pattern : {BayerPattern::BG, BayerPattern::GB, BayerPattern::RG, BayerPattern::GR}) {
        corrector.prepareMosaic(size, pattern);
        const cv::Mat& sites = corrector.mosaicFactors();
        ASSERT_EQ(sites.type(), CV_32FC1);
        for (int y = 0; y < size.height; ++y)
            for (int x = 0; x < size.width; ++x)
                ASSERT_EQ(sites.at<float>(y, x), corrector.factors().at<cv::Vec3f>(y, x)[bayerSiteColour(pattern, x, y)])
                    << toString(pattern) << " at " << x << "," << y;
    }
    EXPECT_EQ(bayerSiteColour(BayerPattern::BG, 0, 0), 0);
    EXPECT_EQ(bayerSiteColour(BayerPattern::BG, 1, 1), 2);
    EXPECT_EQ(bayerSiteColour(BayerPattern::GR, 1, 0), 2);
    EXPECT_EQ(bayerSiteColour(BayerPattern::GR, 0, 1), 0);
}

// Gains alone (no strobe pattern): a site's factor depends on its row only
// through the row's parity, so the mosaic factors are two rows, each site's
// the very value of the three-channel image's at every row; the pass gives
// the same bits with them as with the factors tiled over the whole image
// (every stage's output: image, masks, visibility; both sample depths).
TEST(FrontEnd, GainsAloneTakeTwoRowsOfFactorsAndGiveTheSameBits) {
    LightingConfig gains;
    gains.frameAverageEnabled = true;
    gains.gainsRgb = {1.37, 0.91, 1.13};
    std::uint64_t seed = 300;
    for (const int depth : {CV_16U, CV_8U}) {
        const cv::Size size(64, 48);
        const int bits = depth == CV_16U ? 12 : 8;
        LightingCorrector corrector(gains);
        corrector.prepare(size);
        corrector.prepareMosaic(size, BayerPattern::GR);
        const cv::Mat& rows = corrector.mosaicFactors();
        ASSERT_EQ(rows.size(), cv::Size(size.width, 2));
        cv::Mat tiled(size, CV_32FC1);
        for (int y = 0; y < size.height; ++y) {
            rows.row(y & 1).copyTo(tiled.row(y));
            for (int x = 0; x < size.width; ++x)
                ASSERT_EQ(tiled.at<float>(y, x),
                          corrector.factors().at<cv::Vec3f>(y, x)[bayerSiteColour(BayerPattern::GR, x, y)])
                    << "at " << x << "," << y;
        }
        const std::vector<TargetType> types = filterTypes(size);
        std::vector<detail::ColorTest> tests;
        for (const TargetType& t : types) tests.emplace_back(t, size, depth, bits);
        detail::FrontEndInput in;
        in.mosaic = mosaicOf(size, depth, bits, seed++);
        in.pattern = BayerPattern::GR;
        in.bitDepth = bits;
        in.tests = &tests;
        in.visibility = true;
        detail::FrontEndResult two, full;
        in.factors = &rows;
        detail::runFrontEnd(in, two);
        in.factors = &tiled;
        detail::runFrontEnd(in, full);
        expectIdentical(two.bgr, full.bgr, "image");
        ASSERT_EQ(two.masks.size(), full.masks.size());
        for (std::size_t t = 0; t < types.size(); ++t) expectIdentical(two.masks[t], full.masks[t], "mask of " + types[t].name);
        ASSERT_TRUE(two.visibility && full.visibility);
        EXPECT_EQ(two.visibility->contrast, full.visibility->contrast);
        EXPECT_EQ(two.visibility->haze, full.visibility->haze);
        EXPECT_EQ(two.visibility->saturatedFraction, full.visibility->saturatedFraction);
        // The correction did something: without factors the image differs.
        in.factors = nullptr;
        detail::FrontEndResult none;
        detail::runFrontEnd(in, none);
        EXPECT_GT(cv::norm(none.bgr, full.bgr, cv::NORM_INF), 0.0);
        const cv::Mat three(3, size.width, CV_32FC1, cv::Scalar(1.0f));  // neither the image's rows nor two
        in.factors = &three;
        EXPECT_THROW(detail::runFrontEnd(in, none), InvalidArgument);
    }
}

TEST(FrontEnd, RefusesWhatItDoesNotHandle) {
    detail::FrontEndResult out;
    detail::FrontEndInput in;
    in.mosaic = cv::Mat(3, 8, CV_16UC1, cv::Scalar(1));
    EXPECT_FALSE(detail::frontEndHandles(in.mosaic));
    EXPECT_THROW(detail::runFrontEnd(in, out), InvalidArgument);
    in.mosaic = cv::Mat(8, 8, CV_16UC3);
    EXPECT_FALSE(detail::frontEndHandles(in.mosaic));
    in.mosaic = cv::Mat(8, 8, CV_32FC1);
    EXPECT_FALSE(detail::frontEndHandles(in.mosaic));
    in.mosaic = cv::Mat(8, 8, CV_8UC1, cv::Scalar(1));
    in.bitDepth = 12;
    EXPECT_THROW(detail::runFrontEnd(in, out), InvalidArgument);
}


// A tracking frame's regions (AnalysisFrame::regions): inside each, every
// output bit for bit what the whole image gives; outside, 0. The regions sit
// at odd and even offsets (the Bayer phase), on every edge of the image, one
// pixel wide or tall, in corners; the buffers hold junk from before.
TEST(FrontEnd, RegionsGiveTheWholeImagesPixels) {
    struct RegionCase {
        Case c;
        std::vector<cv::Rect> regions;
    };
    const std::vector<RegionCase> cases = {
        {{{64, 48}, CV_16U, 16, BayerPattern::BG, true, false}, {{5, 3, 17, 11}, {30, 20, 9, 1}, {50, 30, 1, 9}}},
        {{{64, 48}, CV_16U, 12, BayerPattern::GR, true, true}, {{0, 0, 10, 7}, {54, 41, 10, 7}, {20, 0, 1, 1}}},
        {{{64, 48}, CV_8U, 8, BayerPattern::RG, false, false}, {{0, 10, 1, 30}, {63, 10, 1, 30}, {10, 47, 40, 1}}},
        {{{37, 23}, CV_16U, 14, BayerPattern::GB, true, false}, {{1, 1, 35, 21}}},
        {{{37, 23}, CV_16U, 14, BayerPattern::BG, false, false}, {{0, 0, 37, 23}}},
        {{{6, 9}, CV_8U, 7, BayerPattern::GB, true, false}, {{0, 0, 1, 1}, {5, 8, 1, 1}, {2, 3, 2, 2}}},
    };
    std::uint64_t seed = 200;
    for (const RegionCase& rc : cases) {
        const Case& c = rc.c;
        SCOPED_TRACE(describe(c));
        cv::Mat mosaic = mosaicOf(c.size, c.depth, c.bitDepth, seed++);
        if (c.swap) swapEndian16(mosaic);
        const std::vector<TargetType> types = filterTypes(c.size);
        std::vector<detail::ColorTest> tests;
        for (const TargetType& t : types) tests.emplace_back(t, c.size, c.depth, c.bitDepth);
        LightingCorrector corrector(lightingConfig(c.size));
        corrector.prepareMosaic(c.size, c.pattern);
        detail::FrontEndInput in;
        in.mosaic = mosaic;
        in.pattern = c.pattern;
        in.bitDepth = c.bitDepth;
        in.endianSwap = c.swap;
        in.factors = c.lighting ? &corrector.mosaicFactors() : nullptr;
        in.tests = &tests;
        in.visibility = true;
        detail::FrontEndResult whole;
        detail::runFrontEnd(in, whole);

        // Into buffers full of junk, said not to be clear: the pass clears them.
        in.regions = &rc.regions;
        detail::FrontEndResult part;
        part.bgr = cv::Mat(c.size, CV_MAKETYPE(c.depth, 3), cv::Scalar::all(77));
        part.masks.assign(types.size(), cv::Mat());
        for (cv::Mat& m : part.masks) m = cv::Mat(c.size, CV_8UC1, cv::Scalar(77));
        detail::runFrontEnd(in, part);
        EXPECT_FALSE(part.visibility.has_value());  // a tracking frame measures none

        cv::Mat inside(c.size, CV_8UC1, cv::Scalar(0));
        for (const cv::Rect& r : rc.regions) inside(r).setTo(255);
        const auto check = [&](const cv::Mat& got, const cv::Mat& full, const std::string& what) {
            cv::Mat expected(full.size(), full.type(), cv::Scalar::all(0));
            full.copyTo(expected, inside);
            expectIdentical(got, expected, what);
        };
        check(part.bgr, whole.bgr, "image");
        ASSERT_EQ(part.masks.size(), whole.masks.size());
        for (std::size_t t = 0; t < types.size(); ++t) check(part.masks[t], whole.masks[t], "mask of " + types[t].name);
    }
}

TEST(FrontEnd, RefusesARegionOutsideTheImage) {
    const cv::Mat mosaic = mosaicOf({40, 20}, CV_16U, 16, 7);
    detail::FrontEndInput in;
    in.mosaic = mosaic;
    const std::vector<cv::Rect> regions{{30, 5, 11, 4}};
    in.regions = &regions;
    detail::FrontEndResult out;
    try {
        detail::runFrontEnd(in, out);
        FAIL() << "accepted a region outside the image";
    } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find("search region [30, 5, 11x4] is empty or not inside the 40x20 image"),
                  std::string::npos)
            << e.what();
    }
}

// The pool clears only what a buffer's last user wrote, and all of a fresh one.
// The interleaving the front end and the silhouettes use in place of
// cv::hal::merge16u / split16u gives their very samples, at every length
// (the vector steps of 16 pixels and the tails), and writes nothing beyond.
TEST(Interleave, GivesWhatOpenCvsMergeAndSplitGiveAtEveryLength) {
    std::mt19937 rng(3);
    std::uniform_int_distribution<int> sample(0, 65535);
    for (int n = 0; n <= 70; ++n) {
        std::vector<std::uint16_t> planes(3 * static_cast<std::size_t>(n) + 3);
        for (std::uint16_t& v : planes) v = static_cast<std::uint16_t>(sample(rng));
        const std::uint16_t* b = planes.data();
        const std::uint16_t* g = b + n;
        const std::uint16_t* r = g + n;
        std::vector<std::uint16_t> ours(3 * static_cast<std::size_t>(n) + 8, 7), theirs(ours.size(), 7);
        detail::interleave3(b, g, r, ours.data(), n);
        const std::uint16_t* src[3] = {b, g, r};
        cv::hal::merge16u(src, theirs.data(), n, 3);
        ASSERT_EQ(ours, theirs) << "interleave, n = " << n;

        std::vector<std::uint16_t> split(3 * static_cast<std::size_t>(n) + 8, 7), reference(split.size(), 7);
        detail::deinterleave3(ours.data(), split.data(), split.data() + n, split.data() + 2 * n, n);
        std::uint16_t* dst[3] = {reference.data(), reference.data() + n, reference.data() + 2 * n};
        cv::hal::split16u(theirs.data(), dst, n, 3);
        ASSERT_EQ(split, reference) << "deinterleave, n = " << n;
        ASSERT_TRUE(std::equal(split.begin(), split.begin() + 3 * n, planes.begin())) << n;
    }
}

TEST(BufferPool, ZeroedOutsideClearsWhatTheLastUserWrote) {
    detail::BufferPool pool(2);
    const cv::Size size(50, 40);
    const std::vector<cv::Rect> first{{3, 4, 10, 10}, {30, 20, 5, 5}}, second{{20, 2, 8, 30}};
    const auto outsideIsZero = [](const cv::Mat& m, const std::vector<cv::Rect>& regions) {
        cv::Mat copy = m.clone();
        for (const cv::Rect& r : regions) copy(r).setTo(0);
        return cv::countNonZero(copy) == 0;
    };
    const uchar* address = nullptr;
    {
        cv::Mat a = pool.get(size, CV_8UC1);  // written whole by its user
        a.setTo(9);
        address = a.data;
    }
    {
        cv::Mat b = pool.getZeroedOutside(size, CV_8UC1, first);
        EXPECT_EQ(b.data, address);  // the same buffer again, cleared outside
        EXPECT_TRUE(outsideIsZero(b, first));
        for (const cv::Rect& r : first) b(r).setTo(5);
    }
    {
        cv::Mat held = pool.getZeroedOutside(size, CV_8UC1, second);
        EXPECT_EQ(held.data, address);
        EXPECT_TRUE(outsideIsZero(held, second));  // the first regions' 5s are gone
        cv::Mat other = pool.getZeroedOutside(size, CV_8UC1, first);  // the first is held: a fresh one
        EXPECT_NE(other.data, address);
        EXPECT_TRUE(outsideIsZero(other, first));
        held(second[0]).setTo(4);
    }
    cv::Mat again = pool.getZeroedOutside(size, CV_8UC1, first);
    EXPECT_TRUE(outsideIsZero(again, first));
}

TEST(BufferPool, SaysWhereABufferMayBeNonZero) {
    detail::BufferPool pool(2);
    const cv::Size size(50, 40);
    const cv::Rect whole(cv::Point(), size);
    std::vector<cv::Rect> dirty;
    const uchar* address = nullptr;
    {
        cv::Mat a = pool.get(size, CV_8UC1, dirty);
        EXPECT_EQ(dirty, std::vector<cv::Rect>{whole});  // new: anything
        address = a.data;
        a.setTo(0);
        a(cv::Rect(0, 10, 50, 3)).setTo(255);
        pool.wrote(a, {cv::Rect(0, 10, 50, 3)});
    }
    {
        cv::Mat b = pool.get(size, CV_8UC1, dirty);
        EXPECT_EQ(b.data, address);
        EXPECT_EQ(dirty, std::vector<cv::Rect>{cv::Rect(0, 10, 50, 3)});  // what its last user said
        b.setTo(1);  // and says nothing: the whole image, as handed out
    }
    {
        cv::Mat c = pool.get(size, CV_8UC1, dirty);
        EXPECT_EQ(dirty, std::vector<cv::Rect>{whole});
        c.setTo(0);
        c(cv::Rect(5, 5, 4, 4)).setTo(3);
        pool.wrote(c, {cv::Rect(5, 5, 4, 4)});
    }
    // A tracking frame's buffer after it: cleared only where that user wrote.
    const std::vector<cv::Rect> regions{{20, 20, 10, 10}};
    cv::Mat d = pool.getZeroedOutside(size, CV_8UC1, regions);
    EXPECT_EQ(d.data, address);
    cv::Mat outside = d.clone();
    outside(regions[0]).setTo(0);
    EXPECT_EQ(cv::countNonZero(outside), 0);
    // A buffer the pool does not hand out is not its to describe.
    cv::Mat foreign(size, CV_8UC1, cv::Scalar(0));
    pool.wrote(foreign, {});
    d.release();
    EXPECT_EQ(pool.get(size, CV_8UC1, dirty).data, address);
    EXPECT_EQ(dirty, regions);
}

}  // namespace
}  // namespace avatar
