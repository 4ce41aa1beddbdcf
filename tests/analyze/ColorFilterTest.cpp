#include <avatar/analyze/ImageColorFilter.h>
#include "ColorFilterKernel.h"
#include "KernelClones.h"

#include <avatar/common/Error.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

namespace avatar {
namespace {

struct Bgr {
    int b, g, r;
};

template <typename S>
cv::Mat imageOf(const std::vector<Bgr>& pixels, int cols, int scale = 1) {
    const int type = sizeof(S) == 1 ? CV_8UC3 : CV_16UC3;
    cv::Mat image(static_cast<int>(pixels.size()) / cols, cols, type);
    for (std::size_t i = 0; i < pixels.size(); ++i) {
        auto& px = image.at<cv::Vec<S, 3>>(static_cast<int>(i) / cols, static_cast<int>(i) % cols);
        px = {static_cast<S>(pixels[i].b * scale), static_cast<S>(pixels[i].g * scale),
              static_cast<S>(pixels[i].r * scale)};
    }
    return image;
}

TargetType ratioType(Range rg, Range rb, Range bg) {
    TargetType t;
    t.name = "t";
    t.redGreen = rg;
    t.redBlue = rb;
    t.blueGreen = bg;
    return t;
}

cv::Mat filterOne(const cv::Mat& image, int bitDepth, const TargetType& type) {
    std::vector<cv::Mat> masks;
    colorFilterMasks(image, bitDepth, {type}, masks);
    EXPECT_EQ(masks.size(), 1u);
    EXPECT_EQ(masks[0].type(), CV_8UC1);
    EXPECT_EQ(masks[0].size(), image.size());
    return masks[0];
}

std::vector<int> maskValues(const cv::Mat& mask) {
    std::vector<int> v;
    for (int y = 0; y < mask.rows; ++y)
        for (int x = 0; x < mask.cols; ++x) v.push_back(mask.at<std::uint8_t>(y, x));
    return v;
}

bool sameMask(const cv::Mat& a, const cv::Mat& b) {
    return a.size() == b.size() && a.type() == b.type() && cv::countNonZero(a != b) == 0;
}

// The 5x5 image: every pixel's verdict for the range 0.5..2 on all three
// ratios, worked out by hand (ratios as R/G, R/B, B/G).
const std::vector<Bgr> kHandPixels = {
    {100, 100, 100},  // 1, 1, 1                       pass
    {100, 50, 100},   // R/G = 2 (max), B/G = 2 (max)  pass
    {100, 50, 101},   // R/G = 2.02                    fail
    {50, 100, 50},    // R/G = 0.5 (min), B/G = 0.5    pass
    {50, 100, 49},    // R/G = 0.49                    fail
    {0, 0, 0},        // black: 0/0                    fail
    {0, 100, 100},    // B = 0: R/B = inf              fail
    {100, 0, 100},    // G = 0: R/G = inf              fail
    {100, 100, 0},    // R = 0: R/G = 0 < 0.5          fail
    {255, 255, 255},  // saturated, 1, 1, 1            pass
    {255, 255, 0},    // R = 0                         fail
    {0, 255, 255},    // B = 0                         fail
    {200, 100, 200},  // R/G = 2, R/B = 1, B/G = 2     pass
    {200, 100, 50},   // R/B = 0.25                    fail
    {100, 200, 200},  // R/G = 1, R/B = 2, B/G = 0.5   pass
    {100, 201, 200},  // B/G = 0.4975                  fail
    {1, 1, 1},        // darkest grey                  pass
    {1, 2, 1},        // 0.5, 1, 0.5                   pass
    {1, 2, 0},        // R = 0                         fail
    {0, 0, 1},        // 1/0 everywhere                fail
    {128, 255, 255},  // 1, 1.99, 0.502                pass
    {127, 255, 255},  // R/B = 2.008                   fail
    {255, 128, 255},  // 1.99, 1, 1.99                 pass
    {255, 127, 255},  // R/G = 2.008                   fail
    {60, 90, 120},    // 1.333, 2, 0.667               pass
};
const std::vector<int> kHandExpected = {255, 255, 0,   255, 0, 0, 0,   0, 0, 255, 0,   0,  255,
                                        0,   255, 0,   255, 255, 0, 0, 255, 0, 255, 0, 255};

TEST(ColorFilter, HandBuiltImagePixelByPixel8And16Bit) {
    const TargetType type = ratioType({0.5, 2.0}, {0.5, 2.0}, {0.5, 2.0});
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint8_t>(kHandPixels, 5), 8, type)), kHandExpected);
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint16_t>(kHandPixels, 5), 16, type)), kHandExpected);
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint16_t>(kHandPixels, 5, 257), 16, type)), kHandExpected);
}

TEST(ColorFilter, ZeroRedPassesOnlyWhenRatioMinimaAreZero) {
    const std::vector<Bgr> px = {{100, 100, 0}, {0, 100, 0}, {100, 0, 0}, {0, 0, 0}, {100, 100, 100}};
    const TargetType type = ratioType({0.0, 2.0}, {0.0, 2.0}, {0.5, 2.0});
    // R = 0 with G, B > 0: ratios 0, 0, 1; B = 0 or G = 0: 0/0; black: 0/0.
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint8_t>(px, 5), 8, type)),
              (std::vector<int>{255, 0, 0, 0, 255}));
}

// Clipped channels (issue: a red candy at (240, 0, 0) was found only at its
// edges): x/0 is +infinity, passing every min and an open max (>= 65536) only;
// 0/0 passes that ratio; black fails.
TEST(ColorFilter, ClippedChannelsAreInfiniteOrUndecidedRatios) {
    const std::vector<Bgr> px = {
        {0, 0, 240},    // R/G = R/B = inf, B/G = 0/0
        {0, 120, 240},  // R/G = 2, R/B = inf, B/G = 0
        {120, 0, 240},  // R/G = inf, R/B = 2, B/G = inf
        {0, 0, 0},      // black
        {0, 0, 1},      // the darkest red: R/G = R/B = inf
        {60, 60, 60},   // grey: every ratio 1
    };
    const TargetType open = ratioType({1.5, 1e9}, {1.5, 65536.0}, {0.0, 2.0});
    const TargetType bounded = ratioType({1.5, 65535.0}, {1.5, 1e9}, {0.0, 2.0});
    const std::vector<int> openExpected = {255, 255, 0, 0, 255, 0};  // B/G = inf fails its max of 2
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint8_t>(px, 6), 8, open)), openExpected);
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint16_t>(px, 6), 16, open)), openExpected);
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint16_t>(px, 6, 257), 16, open)), openExpected);
    // A bounded R/G max: every pixel with G = 0 fails; (0, 120, 240) has R/G = 2 and passes.
    const std::vector<int> rgBounded = {0, 255, 0, 0, 0, 0};
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint8_t>(px, 6), 8, bounded)), rgBounded);
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint16_t>(px, 6, 257), 16, bounded)), rgBounded);
    // Even the largest max a configuration can hold is open.
    const double most = std::numeric_limits<double>::max();
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint16_t>(px, 6), 16, ratioType({0, most}, {0, most}, {0, most}))),
              (std::vector<int>{255, 255, 255, 0, 255, 255}));
}

// A limit that is a double next to a fraction: double(1/3) < 1/3 < next
// double, double(0.1) > 1/10. The test is exact for the double limit, at 8
// and 16 bits alike (a product rounded to double would call 0.1 * 2570 = 257).
TEST(ColorFilter, RatioTestIsExactForTheDoubleLimit) {
    const double third = 1.0 / 3.0;
    const double tenth = 0.1;
    ASSERT_LT(third * 3.0 - 1.0, 1e-15);  // sanity: these are the usual doubles
    struct Case {
        Range rg;
        int g, r;
        bool pass;
    };
    const std::vector<Case> cases = {
        {{third, 10.0}, 3, 1, true},                        // 1/3 >= double(1/3)
        {{0.0, third}, 3, 1, false},                        // 1/3 >  double(1/3)
        {{0.0, std::nextafter(third, 1.0)}, 3, 1, true},    // next double above 1/3
        {{tenth, 10.0}, 10, 1, false},                      // 1/10 < double(0.1)
        {{0.0, tenth}, 10, 1, true},                        // 1/10 <= double(0.1)
        {{std::nextafter(tenth, 0.0), 10.0}, 10, 1, true},  // previous double is below 1/10
        {{0.25, 0.25}, 4, 1, true},                         // exactly representable: both ends inclusive
        {{0.0, std::nextafter(0.25, 0.0)}, 4, 1, false},
        {{std::nextafter(0.25, 1.0), 1.0}, 4, 1, false},
        {{255.0, 255.0}, 1, 255, true},
        {{0.0, 254.0}, 1, 255, false},
    };
    for (const Case& c : cases) {
        for (int scale : {1, 257}) {
            // B chosen so that R/B and B/G are 1-ish and within wide ranges.
            const std::vector<Bgr> px = {{c.g, c.g, c.r}};
            const TargetType type = ratioType(c.rg, {0.0, 1e9}, {0.0, 1e9});
            const cv::Mat image = scale == 1 ? imageOf<std::uint8_t>(px, 1) : imageOf<std::uint16_t>(px, 1, scale);
            const cv::Mat mask = filterOne(image, scale == 1 ? 8 : 16, type);
            EXPECT_EQ(mask.at<std::uint8_t>(0, 0), c.pass ? 255 : 0)
                << "R/G = " << c.r << "/" << c.g << " in [" << c.rg.min << ", " << c.rg.max << "] x" << scale;
        }
    }
}

// Exact reference: sign of r/g - x for a double x >= 0, in 128-bit integers.
__extension__ typedef __int128 Int128;
int exactCompare(std::int64_t r, std::int64_t g, double x) {
    if (x < 1e-9) return r > 0 ? 1 : (x > 0.0 ? -1 : 0);  // below every r/g > 0
    int e = 0;
    const double f = std::frexp(x, &e);
    const auto m = static_cast<std::int64_t>(std::ldexp(f, 53));  // x = m * 2^(e-53)
    const int s = e - 53;
    Int128 lhs = r, rhs = static_cast<Int128>(m) * g;
    if (s >= 0) rhs <<= s; else lhs <<= -s;
    return lhs < rhs ? -1 : (lhs > rhs ? 1 : 0);
}

TEST(ColorFilter, RatioTestAgreesWithExactArithmeticOnRandom16BitPixels) {
    cv::RNG rng(7);
    for (int trial = 0; trial < 40; ++trial) {
        // Limits: random, or the double nearest a random fraction, or one ulp beside it.
        auto limit = [&]() {
            const double q = rng.uniform(1, 65536);
            const double frac = rng.uniform(0, 65536) / q;
            switch (rng.uniform(0, 4)) {
                case 0: return frac;
                case 1: return std::nextafter(frac, 0.0);
                case 2: return std::nextafter(frac, 1e9);
                default: return rng.uniform(0.0, 4.0);
            }
        };
        double lo = limit(), hi = limit();
        if (lo > hi) std::swap(lo, hi);
        const TargetType type = ratioType({lo, hi}, {0.0, 1e9}, {0.0, 1e9});
        // Pixels whose R/G is at or next to the limits, and random ones.
        cv::Mat image(1, 512, CV_16UC3);
        for (int x = 0; x < image.cols; ++x) {
            int g = rng.uniform(1, 65536);
            int r = rng.uniform(0, 65536);
            if (x % 3 != 0) {
                const double target = x % 3 == 1 ? lo : hi;
                g = rng.uniform(1, 65536);
                const double rr = std::round(target * g) + rng.uniform(-1, 2);
                r = static_cast<int>(std::clamp(rr, 0.0, 65535.0));
            }
            image.at<cv::Vec3w>(0, x) = {static_cast<std::uint16_t>(g), static_cast<std::uint16_t>(g),
                                         static_cast<std::uint16_t>(r)};
        }
        const cv::Mat mask = filterOne(image, 16, type);
        for (int x = 0; x < image.cols; ++x) {
            const cv::Vec3w p = image.at<cv::Vec3w>(0, x);
            const bool expected = exactCompare(p[2], p[1], lo) >= 0 && exactCompare(p[2], p[1], hi) <= 0 &&
                                  exactCompare(p[2], p[0], 1e9) <= 0;
            ASSERT_EQ(mask.at<std::uint8_t>(0, x), expected ? 255 : 0)
                << "R/G = " << p[2] << "/" << p[1] << " limits " << lo << " " << hi;
        }
    }
}

TEST(ColorFilter, EightAndSixteenBitGiveIdenticalMasksForScaledImages) {
    cv::Mat image8(48, 64, CV_8UC3);
    cv::RNG rng(11);
    rng.fill(image8, cv::RNG::UNIFORM, 0, 256);
    cv::Mat image16;
    image8.convertTo(image16, CV_16UC3, 257.0);

    std::vector<TargetType> types8 = {ratioType({0.8, 1.25}, {0.5, 2.0}, {0.3, 1.1}),
                                      ratioType({1.0 / 3.0, 3.0}, {0.1, 0.7}, {0.0, 1e9})};
    types8[0].brightness = Range{100.0, 600.0};
    TargetType hsv;
    hsv.name = "hsv";
    hsv.filter = ColorFilterMethod::Hsv;
    hsv.hsv = {{300.0, 60.0}, {0.25, 0.9}, {0.2, 0.95}};
    types8.push_back(hsv);
    std::vector<TargetType> types16 = types8;
    types16[0].brightness = Range{100.0 * 257, 600.0 * 257};

    std::vector<cv::Mat> m8, m16;
    colorFilterMasks(image8, 8, types8, m8);
    colorFilterMasks(image16, 16, types16, m16);
    ASSERT_EQ(m8.size(), 3u);
    for (std::size_t t = 0; t < m8.size(); ++t) {
        EXPECT_TRUE(sameMask(m8[t], m16[t])) << "type " << t;
        EXPECT_GT(cv::countNonZero(m8[t]), 20) << "type " << t << " should pass some pixels";
        EXPECT_LT(cv::countNonZero(m8[t]), static_cast<int>(image8.total()) - 20) << "type " << t << " should fail some pixels";
    }
}

TEST(ColorFilter, SeveralTypesInOnePassEqualEachTypeAlone) {
    cv::Mat image(37, 53, CV_16UC3);
    cv::RNG rng(3);
    rng.fill(image, cv::RNG::UNIFORM, 0, 65536);
    std::vector<TargetType> types = {ratioType({0.8, 1.25}, {0.5, 2.0}, {0.3, 1.1}),
                                     ratioType({0.2, 0.9}, {0.1, 5.0}, {1.0, 3.0})};
    types[1].window = {5, 7, 30, 20};
    types[1].brightness = Range{30000.0, 120000.0};
    TargetType hsv;
    hsv.name = "hsv";
    hsv.filter = ColorFilterMethod::Hsv;
    hsv.hsv = {{100.0, 200.0}, {0.1, 1.0}, {0.0, 1.0}};
    hsv.window = {40, 0, 100, 10};
    types.push_back(hsv);

    std::vector<cv::Mat> together;
    colorFilterMasks(image, 16, types, together);
    ASSERT_EQ(together.size(), types.size());
    for (std::size_t t = 0; t < types.size(); ++t) {
        EXPECT_TRUE(sameMask(together[t], filterOne(image, 16, types[t]))) << "type " << t;
        EXPECT_GT(cv::countNonZero(together[t]), 0) << "type " << t;
    }
}

TEST(ColorFilter, SearchWindowIsClippedAndTheRestOfTheMaskIsZero) {
    cv::Mat image(5, 5, CV_8UC3, cv::Scalar(100, 100, 100));  // every pixel passes
    TargetType type = ratioType({0.5, 2.0}, {0.5, 2.0}, {0.5, 2.0});
    type.window = {3, 2, 10, 10};  // partly outside: columns 3..4, rows 2..4
    const cv::Mat mask = filterOne(image, 8, type);
    for (int y = 0; y < 5; ++y)
        for (int x = 0; x < 5; ++x)
            EXPECT_EQ(mask.at<std::uint8_t>(y, x), (x >= 3 && y >= 2) ? 255 : 0) << x << "," << y;

    type.window = {1, 1, 2, 3};  // inside
    const cv::Mat inside = filterOne(image, 8, type);
    EXPECT_EQ(cv::countNonZero(inside), 6);
    EXPECT_EQ(cv::countNonZero(inside(cv::Rect(1, 1, 2, 3))), 6);

    type.window = {};  // unset: whole image
    EXPECT_EQ(cv::countNonZero(filterOne(image, 8, type)), 25);

    type.window = {5, 0, 3, 3};  // entirely outside
    std::vector<cv::Mat> masks;
    EXPECT_THROW(colorFilterMasks(image, 8, {type}, masks), InvalidArgument);
}

TEST(ColorFilter, BrightnessRangeIsInclusiveOnRPlusGPlusB) {
    // Sums 299, 300, 301, 600, 601 (every ratio within 0.5..2).
    const std::vector<Bgr> px = {{99, 100, 100}, {100, 100, 100}, {101, 100, 100}, {200, 200, 200}, {201, 200, 200}};
    TargetType type = ratioType({0.5, 2.0}, {0.5, 2.0}, {0.5, 2.0});
    type.brightness = Range{300.0, 600.0};
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint16_t>(px, 5), 16, type)),
              (std::vector<int>{0, 255, 255, 255, 0}));
    type.brightness = Range{299.5, 600.5};  // fractional limits: 300..600 as integers
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint16_t>(px, 5), 16, type)),
              (std::vector<int>{0, 255, 255, 255, 0}));
    type.brightness = Range{0.0, 1e12};
    EXPECT_EQ(cv::countNonZero(filterOne(imageOf<std::uint8_t>(px, 5), 8, type)), 5);
}

TargetType hsvType(Range hue, Range sat, Range val) {
    TargetType t;
    t.name = "hsv";
    t.filter = ColorFilterMethod::Hsv;
    t.hsv = {hue, sat, val};
    return t;
}

TEST(ColorFilter, HsvHueWrapsThroughZero) {
    // Hues: 0 (red), 360 - 60*43/255 = 349.88, 60*43/255 = 10.12, 120 (green),
    // 240 (blue), grey (hue 0 but saturation 0), black, 60 (yellow, r = g).
    const std::vector<Bgr> px = {{0, 0, 255},   {43, 0, 255},   {0, 43, 255}, {0, 255, 0},
                                 {255, 0, 0},   {128, 128, 128}, {0, 0, 0},   {0, 255, 255}};
    const TargetType red = hsvType({340.0, 20.0}, {0.2, 1.0}, {0.0, 1.0});
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint8_t>(px, 8), 8, red)),
              (std::vector<int>{255, 255, 255, 0, 0, 0, 0, 0}));
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint16_t>(px, 8, 257), 16, red)),
              (std::vector<int>{255, 255, 255, 0, 0, 0, 0, 0}));
    // Not wrapping; limits exactly on 60 and 120 are inclusive.
    const TargetType yellowGreen = hsvType({60.0, 120.0}, {0.0, 1.0}, {0.0, 1.0});
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint8_t>(px, 8), 8, yellowGreen)),
              (std::vector<int>{0, 0, 0, 255, 0, 0, 0, 255}));
    // Saturation 0 allowed: grey and black have hue 0, so a range through 0
    // takes them; 349.88 and 10.12 are outside 350..5.
    const TargetType anyRed = hsvType({350.0, 5.0}, {0.0, 1.0}, {0.0, 1.0});
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint8_t>(px, 8), 8, anyRed)),
              (std::vector<int>{255, 0, 0, 0, 0, 255, 255, 0}));
}

TEST(ColorFilter, HsvSaturationAndValueLimitsAreExactAndRelativeToBitDepth) {
    // S = (max - min)/max, V = max / (2^bitDepth - 1).
    const std::vector<Bgr> px = {{50, 50, 100}, {49, 49, 100}, {51, 51, 100}, {0, 0, 2047}, {0, 0, 2048}};
    const TargetType half = hsvType({0.0, 360.0}, {0.5, 0.5}, {0.0, 1.0});
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint16_t>(px, 5), 12, half)), (std::vector<int>{255, 0, 0, 0, 0}));
    // V = 2047/4095 < 0.5 < 2048/4095 at 12 bits.
    const TargetType bright = hsvType({0.0, 360.0}, {0.0, 1.0}, {0.5, 1.0});
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint16_t>(px, 5), 12, bright)), (std::vector<int>{0, 0, 0, 0, 255}));
    // At 16 bits every one of these is dark.
    const TargetType dark = hsvType({0.0, 360.0}, {0.0, 1.0}, {0.0, 0.04});
    EXPECT_EQ(cv::countNonZero(filterOne(imageOf<std::uint16_t>(px, 5), 16, dark)), 5);
}

TEST(ColorFilter, HsvAgreesWithOpenCvAwayFromTheLimits) {
    cv::Mat image(60, 80, CV_16UC3);
    cv::RNG rng(5);
    rng.fill(image, cv::RNG::UNIFORM, 0, 65536);
    cv::Mat imageF, hsv;
    image.convertTo(imageF, CV_32FC3, 1.0 / 65535.0);
    cv::cvtColor(imageF, hsv, cv::COLOR_BGR2HSV);  // H in degrees, S and V in [0, 1]
    const TargetType type = hsvType({300.0, 45.0}, {0.3, 0.8}, {0.25, 0.9});
    const cv::Mat mask = filterOne(image, 16, type);
    int compared = 0;
    for (int y = 0; y < image.rows; ++y) {
        for (int x = 0; x < image.cols; ++x) {
            const cv::Vec3f p = hsv.at<cv::Vec3f>(y, x);
            const auto near = [](double v, double limit) { return std::abs(v - limit) < 1e-3; };
            if (near(p[0], 300) || near(p[0], 45) || near(p[1], 0.3) || near(p[1], 0.8) || near(p[2], 0.25) ||
                near(p[2], 0.9))
                continue;
            const bool expected = (p[0] >= 300 || p[0] <= 45) && p[1] >= 0.3 && p[1] <= 0.8 && p[2] >= 0.25 &&
                                  p[2] <= 0.9;
            EXPECT_EQ(mask.at<std::uint8_t>(y, x), expected ? 255 : 0) << x << "," << y;
            ++compared;
        }
    }
    EXPECT_GT(compared, 4600);
}

TEST(ColorFilter, RejectsBadImagesDepthsAndRanges) {
    std::vector<cv::Mat> masks;
    const TargetType ok = ratioType({0.5, 2.0}, {0.5, 2.0}, {0.5, 2.0});
    EXPECT_THROW(colorFilterMasks(cv::Mat(4, 4, CV_32FC3), 16, {ok}, masks), FormatError);
    EXPECT_THROW(colorFilterMasks(cv::Mat(4, 4, CV_8UC1), 8, {ok}, masks), FormatError);
    EXPECT_THROW(colorFilterMasks(cv::Mat(), 8, {ok}, masks), FormatError);
    EXPECT_THROW(colorFilterMasks(cv::Mat(4, 4, CV_8UC3), 9, {ok}, masks), InvalidArgument);
    EXPECT_THROW(colorFilterMasks(cv::Mat(4, 4, CV_16UC3), 0, {ok}, masks), InvalidArgument);
    EXPECT_THROW(colorFilterMasks(cv::Mat(4, 4, CV_16UC3), 17, {ok}, masks), InvalidArgument);
    const cv::Mat image(4, 4, CV_16UC3, cv::Scalar::all(1000));
    EXPECT_THROW(colorFilterMasks(image, 16, {ratioType({2.0, 1.0}, {0.5, 2.0}, {0.5, 2.0})}, masks),
                 InvalidArgument);
    EXPECT_THROW(colorFilterMasks(image, 16, {ratioType({0.5, std::nan("")}, {0.5, 2.0}, {0.5, 2.0})}, masks),
                 InvalidArgument);
    EXPECT_THROW(colorFilterMasks(image, 16, {hsvType({std::nan(""), 1.0}, {0.0, 1.0}, {0.0, 1.0})}, masks),
                 InvalidArgument);
    try {
        TargetType bad = ok;
        bad.name = "duck";
        bad.brightness = Range{10.0, 5.0};
        colorFilterMasks(image, 16, {bad}, masks);
        FAIL() << "no exception";
    } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find("duck"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("brightness"), std::string::npos) << e.what();
    }
    // No types: no masks.
    colorFilterMasks(image, 16, {}, masks);
    EXPECT_TRUE(masks.empty());
}

TEST(ColorFilter, MaskStillReferencedElsewhereIsNotOverwritten) {
    const cv::Mat image(3, 3, CV_8UC3, cv::Scalar(100, 100, 100));
    const TargetType type = ratioType({0.5, 2.0}, {0.5, 2.0}, {0.5, 2.0});
    std::vector<cv::Mat> masks(1, cv::Mat(3, 3, CV_8UC1, cv::Scalar(7)));
    const cv::Mat kept = masks[0];  // e.g. held by a display
    colorFilterMasks(image, 8, {type}, masks);
    EXPECT_EQ(cv::countNonZero(kept != 7), 0);
    EXPECT_EQ(cv::countNonZero(masks[0]), 9);
    // A mask owned only by the vector is reused in place.
    const std::uint8_t* buffer = masks[0].data;
    colorFilterMasks(image, 8, {type}, masks);
    EXPECT_EQ(masks[0].data, buffer);
}

TEST(ApplyMask, KeepsPixelsWhereTheMaskIsSet) {
    cv::Mat image(2, 2, CV_16UC3);
    image.at<cv::Vec3w>(0, 0) = {1, 2, 3};
    image.at<cv::Vec3w>(0, 1) = {4, 5, 6};
    image.at<cv::Vec3w>(1, 0) = {7, 8, 9};
    image.at<cv::Vec3w>(1, 1) = {65535, 65535, 65535};
    cv::Mat mask = (cv::Mat_<std::uint8_t>(2, 2) << 255, 0, 0, 255);
    const cv::Mat out = applyMask(image, mask);
    ASSERT_EQ(out.type(), CV_16UC3);
    EXPECT_EQ(out.at<cv::Vec3w>(0, 0), cv::Vec3w(1, 2, 3));
    EXPECT_EQ(out.at<cv::Vec3w>(0, 1), cv::Vec3w(0, 0, 0));
    EXPECT_EQ(out.at<cv::Vec3w>(1, 0), cv::Vec3w(0, 0, 0));
    EXPECT_EQ(out.at<cv::Vec3w>(1, 1), cv::Vec3w(65535, 65535, 65535));
    EXPECT_THROW(applyMask(image, cv::Mat(3, 2, CV_8UC1)), InvalidArgument);
    EXPECT_THROW(applyMask(image, cv::Mat(2, 2, CV_16UC1)), FormatError);
}

}  // namespace

// ---- brightness bands (thesis 3.3.2) ---------------------------------------------

namespace {

/// The filter's definition, pixel by pixel, in exact arithmetic: which band
/// the brightness M = R+G+B falls in, then each ratio against its range with
/// x/0 = +infinity (passes a min, and a max only when it is >= 65536) and 0/0
/// passing; black fails.
bool referencePasses(const TargetType& t, std::int64_t b, std::int64_t g, std::int64_t r) {
    const std::int64_t m = b + g + r;
    if (m == 0) return false;
    if (t.brightness && !(t.brightness->min <= static_cast<double>(m) && static_cast<double>(m) <= t.brightness->max))
        return false;
    const Range* rg = &t.redGreen;
    const Range* rb = &t.redBlue;
    const Range* bg = &t.blueGreen;
    for (const BrightnessBand& band : t.brightnessBands)
        if (band.brightness.min <= static_cast<double>(m) && static_cast<double>(m) <= band.brightness.max) {
            rg = &band.redGreen;
            rb = &band.redBlue;
            bg = &band.blueGreen;
        }
    const auto within = [](std::int64_t num, std::int64_t den, const Range& range) {
        if (den == 0) return num == 0 || range.max >= 65536.0;
        return exactCompare(num, den, range.min) >= 0 && exactCompare(num, den, range.max) <= 0;
    };
    return within(r, g, *rg) && within(r, b, *rb) && within(b, g, *bg);
}

/// The samples (B, G, R) of pixel (x, y) of an 8- or 16-bit BGR image.
std::array<std::int64_t, 3> samplesAt(const cv::Mat& image, int bits, int x, int y) {
    if (bits == 8) {
        const cv::Vec3b p = image.at<cv::Vec3b>(y, x);
        return {p[0], p[1], p[2]};
    }
    const cv::Vec3w p = image.at<cv::Vec3w>(y, x);
    return {p[0], p[1], p[2]};
}

TargetType bandedType() {
    TargetType t = ratioType({1.2, 1.6}, {1.0, 3.0}, {0.2, 1.5});
    // A dark band where the target's R/G sinks (the dark lab of 6.3), a
    // middle one, and the type's own ranges above.
    t.brightnessBands = {BrightnessBand{{0.0, 90.0}, {0.9, 1.25}, {0.5, 3.0}, {0.0, 2.0}},
                         BrightnessBand{{90.5, 200.0}, {1.0, 1.4}, {0.8, 1e9}, {0.1, 1.8}}};
    return t;
}

}  // namespace

TEST(ColorFilter, BrightnessBandsAgreeWithTheDefinitionPixelByPixel8And16Bit) {
    cv::RNG rng(11);
    for (const int bits : {8, 16}) {
        const int scale = bits == 8 ? 1 : 257;
        TargetType t = bandedType();
        for (BrightnessBand& b : t.brightnessBands) b.brightness = {b.brightness.min * scale, b.brightness.max * scale};
        t.brightness = Range{3.0 * scale, 700.0 * scale};
        cv::Mat image(64, 96, bits == 8 ? CV_8UC3 : CV_16UC3);
        for (int y = 0; y < image.rows; ++y)
            for (int x = 0; x < image.cols; ++x) {
                // Dark and mid-range pixels around the limits, a few clipped to zero.
                int v[3];
                for (int& c : v) c = rng.uniform(0, 10) == 0 ? 0 : rng.uniform(1, 140);
                if (bits == 8) image.at<cv::Vec3b>(y, x) = cv::Vec3b(v[0], v[1], v[2]);
                else image.at<cv::Vec3w>(y, x) = cv::Vec3w(v[0] * scale + rng.uniform(0, 200), v[1] * scale,
                                                           v[2] * scale);
            }
        const cv::Mat mask = filterOne(image, bits, t);
        int passed = 0;
        for (int y = 0; y < image.rows; ++y)
            for (int x = 0; x < image.cols; ++x) {
                const auto [b, g, r] = samplesAt(image, bits, x, y);
                const bool expected = referencePasses(t, b, g, r);
                passed += expected;
                ASSERT_EQ(mask.at<std::uint8_t>(y, x), expected ? 255 : 0)
                    << bits << "-bit pixel (" << b << ", " << g << ", " << r << ") at " << x << "," << y;
            }
        EXPECT_GT(passed, 100) << "the test needs pixels that pass";
    }
}

// The separation bands exist for: a target whose R/G falls with brightness
// against a background whose R/G does not. One range over both brightnesses
// takes the background in; bands keep it out.
TEST(ColorFilter, BandsSeparateWhatOneRangeCannot) {
    std::vector<Bgr> px;
    std::vector<int> isTarget;
    for (int i = 0; i < 40; ++i) {
        const int dim = 10 + i;  // dark: M 33..90
        px.push_back({dim, dim, dim * 11 / 10 + 1});      // target, dark: R/G ~1.1
        isTarget.push_back(255);
        px.push_back({dim, dim, dim * 3 / 2});             // background, dark: R/G 1.5
        isTarget.push_back(0);
        const int lit = 80 + i;  // bright: M > 240
        px.push_back({lit, lit, lit * 3 / 2});             // target, bright: R/G 1.5
        isTarget.push_back(255);
        px.push_back({lit, lit, lit * 11 / 10});           // background, bright: R/G ~1.1
        isTarget.push_back(0);
    }
    const cv::Mat image = imageOf<std::uint8_t>(px, 4);
    // One range covering the target at both brightnesses covers the background too.
    const TargetType single = ratioType({1.05, 1.55}, {1.05, 1.55}, {0.9, 1.1});
    const std::vector<int> one = maskValues(filterOne(image, 8, single));
    int falsePositives = 0;
    for (std::size_t i = 0; i < one.size(); ++i) falsePositives += one[i] == 255 && isTarget[i] == 0;
    EXPECT_GT(falsePositives, 60);
    TargetType banded = ratioType({1.4, 1.55}, {1.4, 1.55}, {0.9, 1.1});
    banded.brightnessBands = {BrightnessBand{{0.0, 200.0}, {1.05, 1.25}, {1.05, 1.25}, {0.9, 1.1}}};
    EXPECT_EQ(maskValues(filterOne(image, 8, banded)), isTarget);
}

TEST(ColorFilter, BandsAreValidated) {
    TargetType t = bandedType();
    t.brightnessBands[1].brightness = {80.0, 200.0};  // overlaps band 1
    std::vector<cv::Mat> masks;
    try {
        colorFilterMasks(cv::Mat(2, 2, CV_8UC3, cv::Scalar(1, 1, 1)), 8, {t}, masks);
        ADD_FAILURE() << "overlapping bands accepted";
    } catch (const InvalidArgument& e) {
        EXPECT_NE(std::string(e.what()).find("/brightnessBands/band[2]/brightness: overlaps band[1] (0..90)"),
                  std::string::npos)
            << e.what();
    }
    t = bandedType();
    t.filter = ColorFilterMethod::Hsv;
    EXPECT_THROW(colorFilterMasks(cv::Mat(2, 2, CV_8UC3, cv::Scalar(1, 1, 1)), 8, {t}, masks), InvalidArgument);
}

// A green target seen through haze: its pixels are t J + (1 - t) V, V the
// water's backscatter (0.7 : 1 : 1), so they leave its B/G range (0.2-0.3)
// towards V's. With the veil the type accepts them while the veil's share of
// G is at most maxShare, and nothing else: not V itself, not a grey seabed
// mixed with V, not a colour beside the hull.
TEST(ColorFilter, AVeilAcceptsTheTypesColourMixedWithItUpToItsShare) {
    const std::array<double, 3> green{0.12, 0.6, 0.15}, veil{0.7, 1.0, 1.0}, seabed{0.55, 0.5, 0.4};
    // The colour whose G is made of share s of the veil's and 1 - s of @p c's.
    const auto mixed = [](const std::array<double, 3>& c, const std::array<double, 3>& v, double s, double g) {
        Bgr px{};
        const double kc = (1.0 - s) * g / c[1], kv = s * g / v[1];
        px.r = static_cast<int>(std::lround(kc * c[0] + kv * v[0]));
        px.g = static_cast<int>(std::lround(kc * c[1] + kv * v[1]));
        px.b = static_cast<int>(std::lround(kc * c[2] + kv * v[2]));
        return px;
    };
    std::vector<Bgr> px;
    std::vector<int> expected;
    for (double s : {0.0, 0.1, 0.2, 0.28}) {
        px.push_back(mixed(green, veil, s, 30000.0));
        expected.push_back(255);
    }
    for (double s : {0.36, 0.5, 0.8, 1.0}) {  // beyond the share; the veil alone
        px.push_back(mixed(green, veil, s, 30000.0));
        expected.push_back(0);
    }
    for (double s : {0.0, 0.3, 0.6, 0.9}) {  // the seabed through the same haze
        px.push_back(mixed(seabed, veil, s, 30000.0));
        expected.push_back(0);
    }
    // Beside the hull: the veiled green at share 0.2 with B/G 15 % up or down.
    Bgr off = mixed(green, veil, 0.2, 30000.0);
    off.b = static_cast<int>(off.b * 1.3);
    px.push_back(off);
    expected.push_back(0);
    const cv::Mat image = imageOf<std::uint16_t>(px, 1);
    TargetType t = ratioType({0.1, 0.3}, {0.0, 1e9}, {0.2, 0.3});
    std::vector<int> without(expected.size(), 0);
    without[0] = 255;  // share 0.1 already has B/G 0.325
    EXPECT_EQ(maskValues(filterOne(image, 16, t)), without);
    t.veil = Veil{veil, 0.3, std::nullopt, std::nullopt};
    EXPECT_EQ(maskValues(filterOne(image, 16, t)), expected);
    // Scaled to 8 bits the verdicts are the same (the ratios barely move).
    std::vector<Bgr> small = px;
    for (Bgr& p : small) p = {p.b / 128, p.g / 128, p.r / 128};
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint8_t>(small, 1), 8, t)), expected);
    // The brightness range still holds.
    t.brightness = Range{0.0, 30000.0};
    std::vector<int> dim(expected.size(), 0);
    EXPECT_EQ(maskValues(filterOne(image, 16, t)), dim);
}

// An orange target seen through blue-green water: each channel decays as
// exp(-k L) over the light's path L, so its R/G falls by exp(-0.25 L) and its
// B/G by exp(-0.04 L), and beyond a metre it leaves its ranges. With the
// water the type accepts it up to the water's longest path, and through a
// water that takes only its red as far, and nothing else: not farther, not
// with a B/G risen or fallen beyond the water's, not green, yellow or the
// seabed.
TEST(ColorFilter, AWaterAcceptsTheTypesColourSeenThroughItUpToItsPath) {
    const std::array<double, 3> orange{0.95, 0.42, 0.05}, attenuation{0.3, 0.05, 0.09};
    const auto through = [&](const std::array<double, 3>& c, double pathM, double g) {
        std::array<double, 3> seen{};
        for (std::size_t i = 0; i < 3; ++i) seen[i] = c[i] * std::exp(-attenuation[i] * pathM);
        const double k = g / seen[1];
        return Bgr{static_cast<int>(std::lround(k * seen[2])), static_cast<int>(std::lround(k * seen[1])),
                   static_cast<int>(std::lround(k * seen[0]))};
    };
    std::vector<Bgr> px;
    std::vector<int> expected;
    for (double path : {0.0, 1.0, 2.0, 3.0, 3.9}) {
        px.push_back(through(orange, path, 20000.0));
        expected.push_back(255);
    }
    for (double path : {5.5, 7.0}) {  // beyond the path (the colour lies inside its ranges: 1.3 m beyond)
        px.push_back(through(orange, path, 20000.0));
        expected.push_back(0);
    }
    const std::array<double, 3> green{0.12, 0.6, 0.15}, yellow{0.92, 0.72, 0.04}, seabed{0.55, 0.5, 0.4};
    for (const std::array<double, 3>& other : {green, yellow, seabed})
        for (double path : {0.0, 2.0, 4.0}) {  // green, yellow, the seabed through the same water
            px.push_back(through(other, path, 20000.0));
            expected.push_back(0);
        }
    // Beside its way: the orange at 2 m with B/G 45 % up or 40 % down.
    for (double f : {1.45, 0.6}) {
        Bgr off = through(orange, 2.0, 20000.0);
        off.b = static_cast<int>(off.b * f);
        px.push_back(off);
        expected.push_back(0);
    }
    // A water that absorbs R as this one does and B as G.
    Bgr redOnly = through(orange, 0.0, 20000.0);
    redOnly.r = static_cast<int>(std::lround(redOnly.r * std::exp(-0.25 * 3.9)));
    px.push_back(redOnly);
    expected.push_back(255);
    const cv::Mat image = imageOf<std::uint16_t>(px, 1);
    TargetType t = ratioType({1.9, 2.6}, {0.0, 1e9}, {0.09, 0.15});
    std::vector<int> without(expected.size(), 0);
    without[0] = 255;  // only the orange seen through no water
    EXPECT_EQ(maskValues(filterOne(image, 16, t)), without);
    t.water = Water{attenuation, 4.0, std::nullopt, std::nullopt};
    EXPECT_EQ(maskValues(filterOne(image, 16, t)), expected);
    // Scaled to 8 bits the verdicts are the same.
    std::vector<Bgr> small = px;
    for (Bgr& p : small) p = {p.b / 200, p.g / 200, p.r / 200};
    EXPECT_EQ(maskValues(filterOne(imageOf<std::uint8_t>(small, 1), 8, t)), expected);
    // The water acts on its own ranges when it has them: a narrower B/G leaves
    // the orange's way out.
    t.water->blueGreen = Range{0.145, 0.15};
    std::vector<int> narrow = without;
    EXPECT_EQ(maskValues(filterOne(image, 16, t)), narrow);
    // With a veil too, each adds its own region: the orange mixed with the
    // veil passes as well, the water's way still does.
    t.water->blueGreen.reset();
    t.veil = Veil{{0.7, 1.0, 1.0}, 0.3, std::nullopt, std::nullopt};
    const double g = 20000.0, kc = 0.8 * g / orange[1], kv = 0.2 * g;
    px.push_back(Bgr{static_cast<int>(std::lround(kc * orange[2] + kv)), static_cast<int>(std::lround(g)),
                     static_cast<int>(std::lround(kc * orange[0] + kv * 0.7))});
    expected.push_back(255);
    const cv::Mat both = imageOf<std::uint16_t>(px, 1);
    EXPECT_EQ(maskValues(filterOne(both, 16, t)), expected);
    t.water.reset();
    std::vector<int> veilOnly(expected.size(), 0);
    veilOnly[0] = veilOnly.back() = 255;
    EXPECT_EQ(maskValues(filterOne(both, 16, t)), veilOnly);
    // The brightness range still holds.
    t.water = Water{attenuation, 4.0, std::nullopt, std::nullopt};
    t.brightness = Range{0.0, 20000.0};
    EXPECT_EQ(maskValues(filterOne(both, 16, t)), std::vector<int>(expected.size(), 0));
}

namespace {

/// What the filter says of a configuration with type @p t alone: the
/// message of its InvalidArgument, or "accepted".
std::string filterVerdict(const TargetType& t) {
    std::vector<cv::Mat> masks;
    try {
        colorFilterMasks(cv::Mat(2, 2, CV_8UC3, cv::Scalar(1, 1, 1)), 8, {t}, masks);
    } catch (const InvalidArgument& e) {
        return std::string(e.what());
    }
    return std::string("accepted");
}

}  // namespace

TEST(ColorFilter, AWaterIsValidated) {
    const auto message = filterVerdict;
    TargetType t = ratioType({1.9, 2.6}, {0.0, 1e9}, {0.09, 0.15});
    t.water = Water{{0.3, 0.05, 0.09}, 0.0, std::nullopt, std::nullopt};
    EXPECT_NE(message(t).find("/water/maxPathM: must be above 0 and at most 1000 m, got 0"), std::string::npos)
        << message(t);
    t.water->maxPathM = 4.0;
    t.water->attenuationPerM[0] = std::nan("");
    EXPECT_NE(message(t).find("/water/attenuationPerM: component 1 must be"), std::string::npos) << message(t);
    t.water->attenuationPerM[0] = 0.3;
    t.brightnessBands = {BrightnessBand{{0.0, 200.0}, {1.9, 2.6}, {0.0, 1e9}, {0.09, 0.15}}};
    EXPECT_NE(message(t).find("/water: a water cannot be combined with brightness bands"), std::string::npos)
        << message(t);
    t.brightnessBands.clear();
    EXPECT_EQ(message(t), "accepted");
    t.filter = ColorFilterMethod::Hsv;
    EXPECT_NE(message(t).find("/water: a water needs <filter> rgb_ratio"), std::string::npos) << message(t);
}

TEST(ColorFilter, AVeilIsValidated) {
    const auto message = filterVerdict;
    TargetType t = ratioType({0.1, 0.3}, {0.0, 1e9}, {0.2, 0.3});
    t.veil = Veil{{0.7, 0.0, 1.0}, 0.3, std::nullopt, std::nullopt};
    EXPECT_NE(message(t).find("/veil/colourRgb: G (component 2) must be > 0, got 0"), std::string::npos)
        << message(t);
    t.veil = Veil{{0.7, 1.0, 1.0}, 1.0, std::nullopt, std::nullopt};
    EXPECT_NE(message(t).find("/veil/maxShare: must be above 0 and below 1"), std::string::npos) << message(t);
    t.veil = Veil{{0.7, 1.0, 1.0}, 0.3, std::nullopt, std::nullopt};
    t.brightnessBands = {BrightnessBand{{0.0, 200.0}, {0.1, 0.3}, {0.0, 1e9}, {0.2, 0.3}}};
    EXPECT_NE(message(t).find("/veil: a veil cannot be combined with brightness bands"), std::string::npos)
        << message(t);
    t.brightnessBands.clear();
    t.filter = ColorFilterMethod::Hsv;
    EXPECT_NE(message(t).find("/veil: a veil needs <filter> rgb_ratio"), std::string::npos) << message(t);
}

// The row kernel (an AVX-512 one where the CPU has it, the portable loop
// elsewhere) against the definition, pixel by pixel: every row width from 1
// to 40 (whole 16-pixel steps and every remainder), and the pixels where a
// kernel can go wrong: zeros in each channel, black, the container's maximum,
// ratios exactly at and next to each limit, sums at the band edges. The types
// cover open and bounded maxima, zero minima, bands (several segments ORed),
// and at 16 bits limits next to fractions with large denominators, which the
// filter tests in double rather than float.
TEST(ColorFilter, RowKernelAgreesWithTheDefinitionForEveryWidthAndEdgePixel) {
    const double third = 1.0 / 3.0;
    std::vector<TargetType> types = {
        ratioType({0.5, 2.0}, {0.5, 2.0}, {0.5, 2.0}),
        ratioType({0.0, 1e9}, {1.5, 65536.0}, {0.0, 2.0}),  // open maxima and a zero minimum
        ratioType({0.5, 2.0}, {0.5, 1e9}, {0.0, 2.0}),      // only R/B open: B = 0 can pass
        ratioType({0.5, 2.0}, {0.0, 2.0}, {0.0, 1e9}),      // only B/G open: (B, 0, 0) passes
        ratioType({1.5, 65535.0}, {0.25, 4.0}, {0.0, 255.0}),  // maxima above 8-bit ratios, yet bounded
        ratioType({12345.0 / 54321.0, 40000.0 / 39999.0}, {std::nextafter(third, 0.0), 3.0}, {0.1, 65535.0 / 2.0}),
    };
    cv::RNG rng(23);
    for (const int bits : {8, 16}) {
        const int scale = bits == 8 ? 1 : 257;
        const int full = bits == 8 ? 255 : 65535;
        TargetType banded = bandedType();
        for (BrightnessBand& b : banded.brightnessBands) b.brightness = {b.brightness.min * scale, b.brightness.max * scale};
        banded.brightness = Range{3.0 * scale, 700.0 * scale};
        std::vector<TargetType> all = types;
        all.push_back(banded);
        for (const TargetType& t : all) {
            // Ratio limits to put pixels at, and brightness edges to put sums at.
            std::vector<double> limits = {t.redGreen.min, t.redGreen.max, t.redBlue.min, t.redBlue.max,
                                          t.blueGreen.min, t.blueGreen.max};
            std::vector<double> sums;
            for (const BrightnessBand& b : t.brightnessBands) {
                limits.insert(limits.end(), {b.redGreen.min, b.redGreen.max, b.redBlue.min, b.redBlue.max});
                sums.insert(sums.end(), {std::floor(b.brightness.min), std::ceil(b.brightness.max)});
            }
            if (t.brightness) sums.insert(sums.end(), {t.brightness->min, t.brightness->max});
            const auto sample = [&]() {
                const int kind = rng.uniform(0, 6);
                int v[3] = {rng.uniform(0, full + 1), rng.uniform(0, full + 1), rng.uniform(0, full + 1)};
                if (kind == 1) {  // zeros in some channels, black included
                    for (int& c : v) c = rng.uniform(0, 2) ? 0 : c;
                } else if (kind == 2) {  // the extremes
                    for (int& c : v) c = std::vector<int>{0, 1, full - 1, full}[rng.uniform(0, 4)];
                } else if (kind == 3) {  // a ratio at or next to a limit: num = limit * den + -1, 0, 1
                    const double x = std::min(limits[rng.uniform(0, static_cast<int>(limits.size()))], 1e6);
                    const int num = rng.uniform(0, 3) == 0 ? 1 : 2;  // R, or B as numerator
                    const int den = num == 2 ? rng.uniform(0, 2) : 1;  // R/B or R/G; B/G
                    v[den] = rng.uniform(0, 4) == 0 ? rng.uniform(0, 4) : rng.uniform(1, full + 1);
                    const double n = std::round(x * v[den]) + rng.uniform(-1, 2);
                    v[num] = static_cast<int>(std::clamp(n, 0.0, static_cast<double>(full)));
                } else if (kind == 4 && !sums.empty()) {  // the sum at or next to a band or range edge
                    const int s = static_cast<int>(sums[rng.uniform(0, static_cast<int>(sums.size()))]) +
                                  rng.uniform(-1, 2);
                    v[0] = rng.uniform(0, std::max(1, s / 3 + 1));
                    v[1] = rng.uniform(0, std::max(1, s / 3 + 1));
                    v[2] = std::clamp(s - v[0] - v[1], 0, full);
                } else if (kind == 5) {  // small samples: small ratios' denominators
                    for (int& c : v) c = rng.uniform(0, 4);
                }
                return cv::Vec<int, 3>(v[0], v[1], v[2]);
            };
            int passed = 0, failed = 0;
            // Every width to 40, then wider rows mostly of one colour that
            // fails every type's minima (a kernel may skip such stretches
            // whole) with the samples above among it, alone and in runs.
            std::vector<int> widths;
            for (int width = 1; width <= 40; ++width) widths.push_back(width);
            for (const int width : {63, 64, 65, 127, 128, 200, 257}) widths.push_back(width);
            for (const int width : widths) {
                cv::Mat image(5, width, bits == 8 ? CV_8UC3 : CV_16UC3);
                for (int y = 0; y < image.rows; ++y)
                    for (int x = 0; x < width; ++x) {
                        const bool background = width > 40 && (y % 2 == 0 ? rng.uniform(0, 10) != 0 : (x / 20) % 3 != 0);
                        const cv::Vec<int, 3> p = background ? cv::Vec<int, 3>(full, full, 0) : sample();
                        if (bits == 8) image.at<cv::Vec3b>(y, x) = cv::Vec3b(p[0], p[1], p[2]);
                        else image.at<cv::Vec3w>(y, x) = cv::Vec3w(p[0], p[1], p[2]);
                    }
                const cv::Mat mask = filterOne(image, bits, t);
                for (int y = 0; y < image.rows; ++y)
                    for (int x = 0; x < width; ++x) {
                        const auto [b, g, r] = samplesAt(image, bits, x, y);
                        const bool expected = referencePasses(t, b, g, r);
                        (expected ? passed : failed) += 1;
                        ASSERT_EQ(mask.at<std::uint8_t>(y, x), expected ? 255 : 0)
                            << bits << "-bit pixel (" << b << ", " << g << ", " << r << ") at " << x << "," << y
                            << " of width " << width << ", type R/G " << t.redGreen.min << ".." << t.redGreen.max;
                    }
            }
            // Both verdicts are well represented, or the comparison proves little.
            EXPECT_GT(passed, 100) << bits << "-bit, type R/G " << t.redGreen.min;
            EXPECT_GT(failed, 100) << bits << "-bit, type R/G " << t.redGreen.min;
        }
    }
}

}  // namespace avatar

namespace avatar {
namespace {

// The AVX-512 ratio test first tries one limit alone on each 64 pixels and
// skips them when all fail it, switching to another limit when the one it
// tries lets through pixels the whole test rejects. Backgrounds that each
// fail exactly one of the six limits, in stretches of random kinds and
// lengths with passing pixels among them, must still give the definition's
// verdicts; and row() says false only when no pixel passed (exactly so with
// the AVX-512 kernel).
TEST(ColorFilter, RowSkipsBackgroundByOneLimitAndSaysWhetherAnyPixelPassed) {
    const TargetType type = ratioType({0.5, 2.0}, {0.5, 2.0}, {0.5, 2.0});
    // (B, G, R): each fails one limit only; the last passes.
    const std::array<cv::Vec3f, 7> kinds{{{600, 1000, 450},     // R/G below its minimum
                                          {1500, 1000, 2200},   // R/G above its maximum
                                          {1900, 1000, 900},    // R/B below
                                          {700, 1000, 1500},    // R/B above
                                          {450, 1000, 600},     // B/G below
                                          {2100, 1000, 1900},   // B/G above
                                          {1000, 1000, 1000}}};  // passes
    const int n = 1280;
    const detail::ColorTest test(type, cv::Size(n, 1), CV_16U, 16);
    std::mt19937 rng(7);
    std::vector<float> b(n), g(n), r(n);
    std::vector<std::uint8_t> out(n), scratch(n);
    int rowsWithout = 0, rowsWith = 0;
    for (int row = 0; row < 400; ++row) {
        std::vector<bool> expected(n);
        const bool withTargets = row % 2 == 0;
        for (int x = 0; x < n;) {
            const int length = std::uniform_int_distribution<int>(1, 150)(rng);
            int kind = std::uniform_int_distribution<int>(0, 5)(rng);
            if (withTargets && std::uniform_int_distribution<int>(0, 7)(rng) == 0) kind = 6;
            for (int k = 0; k < length && x < n; ++k, ++x) {
                b[x] = kinds[kind][0];
                g[x] = kinds[kind][1];
                r[x] = kinds[kind][2];
                expected[x] = kind == 6;
            }
        }
        const bool some = test.row(b.data(), g.data(), r.data(), out.data(), n, scratch.data());
        bool anyExpected = false;
        for (int x = 0; x < n; ++x) {
            ASSERT_EQ(out[x], expected[x] ? 255 : 0) << "row " << row << " x " << x;
            anyExpected = anyExpected || expected[x];
        }
        if (!some) {
            EXPECT_FALSE(anyExpected) << "row " << row;
        }
        if (detail::cpuRunsAvx512f()) {
            EXPECT_EQ(some, anyExpected) << "row " << row;
        }
        (anyExpected ? rowsWith : rowsWithout)++;
    }
    EXPECT_GT(rowsWith, 150);
    EXPECT_GT(rowsWithout, 150);
}

}  // namespace
}  // namespace avatar
