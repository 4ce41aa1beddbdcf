#include <avatar/analyze/LightingCorrection.h>
#include <avatar/common/Error.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

namespace avatar {
namespace {

namespace fs = std::filesystem;

LightingConfig falloffConfig() {
    LightingConfig c;
    c.frameAverageEnabled = true;
    c.gainsRgb = {1.5, 1.25, 0.75};  // R, G, B
    c.patternEnabled = true;
    c.patternCentrePx = {20.0, 10.0};
    c.red = {1.1, 0.01};
    c.green = {0.9, 0.02};
    c.blue = {1.0, -0.005};
    return c;
}

/// Writes a float image losslessly: OpenCV's default for a 32FC3 TIFF is the
/// lossy SGILOG (LogLuv) encoding, which also cannot hold negative values.
bool writeFloatTiff(const fs::path& path, const cv::Mat& image) {
    return cv::imwrite(path.string(), image, {cv::IMWRITE_TIFF_COMPRESSION, 1 /* none */});
}

/// A fresh directory for one test's files, removed afterwards.
class TempDir {
public:
    TempDir() {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        path_ = fs::temp_directory_path() / ("avatar_lighting_" + std::string(info->name()));
        fs::remove_all(path_);
        fs::create_directories(path_);
    }
    ~TempDir() {
        std::error_code ec;
        fs::remove_all(path_, ec);
    }
    const fs::path& path() const { return path_; }

private:
    fs::path path_;
};

TEST(Lighting, FactorsAreGainTimesFalloffPerChannelInBgrOrder) {
    const LightingConfig c = falloffConfig();
    LightingCorrector corrector(c);
    EXPECT_TRUE(corrector.enabled());
    corrector.prepare({48, 32});
    const cv::Mat& f = corrector.factors();
    ASSERT_EQ(f.type(), CV_32FC3);
    ASSERT_EQ(f.size(), cv::Size(48, 32));
    // Centre (20, 10): d = 0, factor = gain * c.
    const cv::Vec3f centre = f.at<cv::Vec3f>(10, 20);
    EXPECT_NEAR(centre[0], 0.75 * 1.0, 1e-6);
    EXPECT_NEAR(centre[1], 1.25 * 0.9, 1e-6);
    EXPECT_NEAR(centre[2], 1.5 * 1.1, 1e-6);
    // (23, 14) and (44, 17): d = 5 and 25 (3-4-5 and 24-7-25 triangles).
    for (const auto& [x, y, d] : {std::tuple{23, 14, 5.0}, std::tuple{44, 17, 25.0}, std::tuple{20, 31, 21.0}}) {
        const cv::Vec3f v = f.at<cv::Vec3f>(y, x);
        EXPECT_NEAR(v[0] / (0.75 * 1.0 * std::exp(-0.005 * d)), 1.0, 1e-6) << d;
        EXPECT_NEAR(v[1] / (1.25 * 0.9 * std::exp(0.02 * d)), 1.0, 1e-6) << d;
        EXPECT_NEAR(v[2] / (1.5 * 1.1 * std::exp(0.01 * d)), 1.0, 1e-6) << d;
    }
    // e > 0 brightens the periphery.
    EXPECT_GT(f.at<cv::Vec3f>(0, 0)[2], centre[2]);
    EXPECT_LT(f.at<cv::Vec3f>(0, 0)[0], centre[0]);
}

TEST(Lighting, EachPartCanBeSwitchedOff) {
    LightingConfig c = falloffConfig();
    c.patternEnabled = false;
    LightingCorrector gainsOnly(c);
    gainsOnly.prepare({8, 8});
    EXPECT_EQ(gainsOnly.factors().at<cv::Vec3f>(7, 0), cv::Vec3f(0.75f, 1.25f, 1.5f));

    c = falloffConfig();
    c.frameAverageEnabled = false;
    LightingCorrector patternOnly(c);
    patternOnly.prepare({48, 32});
    EXPECT_NEAR(patternOnly.factors().at<cv::Vec3f>(14, 23)[2], 1.1 * std::exp(0.05), 1e-6);

    c.patternEnabled = false;
    LightingCorrector none(c);
    EXPECT_FALSE(none.enabled());
    cv::Mat image(4, 4, CV_16UC3, cv::Scalar(1, 2, 3));
    none.apply(image, 16);  // no prepare() needed: a no-op
    EXPECT_EQ(image.at<cv::Vec3w>(3, 3), cv::Vec3w(1, 2, 3));
}

TEST(Lighting, ApplyMultipliesRoundsAndSaturatesAtFullScale) {
    LightingConfig c;
    c.frameAverageEnabled = true;
    c.gainsRgb = {2.0, 1.5, 0.5};  // R, G, B
    LightingCorrector corrector(c);
    corrector.prepare({3, 1});

    cv::Mat image16(1, 3, CV_16UC3);
    image16.at<cv::Vec3w>(0, 0) = {101, 3, 1000};    // B*0.5, G*1.5, R*2
    image16.at<cv::Vec3w>(0, 1) = {65535, 50000, 40000};
    image16.at<cv::Vec3w>(0, 2) = {0, 0, 0};
    cv::Mat copy = image16.clone();
    corrector.apply(image16, 16);
    EXPECT_EQ(image16.at<cv::Vec3w>(0, 0), cv::Vec3w(51, 5, 2000));  // 50.5 -> 51, 4.5 -> 5
    EXPECT_EQ(image16.at<cv::Vec3w>(0, 1), cv::Vec3w(32768, 65535, 65535));
    EXPECT_EQ(image16.at<cv::Vec3w>(0, 2), cv::Vec3w(0, 0, 0));
    // 12 significant bits: saturates at 4095.
    copy.at<cv::Vec3w>(0, 1) = {4095, 3000, 2100};
    corrector.apply(copy, 12);
    EXPECT_EQ(copy.at<cv::Vec3w>(0, 1), cv::Vec3w(2048, 4095, 4095));

    cv::Mat image8(1, 3, CV_8UC3);
    image8.at<cv::Vec3b>(0, 0) = {255, 100, 100};
    image8.at<cv::Vec3b>(0, 1) = {3, 200, 127};
    image8.at<cv::Vec3b>(0, 2) = {1, 1, 1};
    corrector.apply(image8, 8);
    EXPECT_EQ(image8.at<cv::Vec3b>(0, 0), cv::Vec3b(128, 150, 200));
    EXPECT_EQ(image8.at<cv::Vec3b>(0, 1), cv::Vec3b(2, 255, 254));
    EXPECT_EQ(image8.at<cv::Vec3b>(0, 2), cv::Vec3b(1, 2, 2));  // 0.5 -> 1, 1.5 -> 2
}

TEST(Lighting, EightAndSixteenBitAgreeWithADoubleReference) {
    LightingCorrector corrector(falloffConfig());
    const cv::Size size(64, 40);
    corrector.prepare(size);
    cv::Mat image16(size, CV_16UC3);
    cv::RNG rng(9);
    rng.fill(image16, cv::RNG::UNIFORM, 0, 65536);
    cv::Mat image8;
    image16.convertTo(image8, CV_8UC3, 1.0 / 257.0);
    const cv::Mat in16 = image16.clone(), in8 = image8.clone();
    corrector.apply(image16, 16);
    corrector.apply(image8, 8);
    int saturated = 0;
    for (int y = 0; y < size.height; ++y) {
        for (int x = 0; x < size.width; ++x) {
            for (int k = 0; k < 3; ++k) {
                const double f = corrector.factors().at<cv::Vec3f>(y, x)[k];
                const double e16 = std::min(std::round(in16.at<cv::Vec3w>(y, x)[k] * f), 65535.0);
                const double e8 = std::min(std::round(in8.at<cv::Vec3b>(y, x)[k] * f), 255.0);
                ASSERT_LE(std::abs(image16.at<cv::Vec3w>(y, x)[k] - e16), 1.0) << x << "," << y << "," << k;
                ASSERT_LE(std::abs(image8.at<cv::Vec3b>(y, x)[k] - e8), 1.0) << x << "," << y << "," << k;
                saturated += image16.at<cv::Vec3w>(y, x)[k] == 65535;
            }
        }
    }
    EXPECT_GT(saturated, 100);  // the range was exercised up to full scale
}

TEST(Lighting, ApplyFromTwoThreadsEqualsSerial) {
    LightingCorrector corrector(falloffConfig());
    const cv::Size size(640, 480);
    corrector.prepare(size);
    cv::Mat left(size, CV_16UC3), right(size, CV_16UC3);
    cv::RNG rng(1);
    rng.fill(left, cv::RNG::UNIFORM, 0, 65536);
    rng.fill(right, cv::RNG::UNIFORM, 0, 65536);
    cv::Mat leftSerial = left.clone(), rightSerial = right.clone();
    corrector.apply(leftSerial, 16);
    corrector.apply(rightSerial, 16);
    std::thread a([&] { corrector.apply(left, 16); });
    std::thread b([&] { corrector.apply(right, 16); });
    a.join();
    b.join();
    EXPECT_EQ(cv::countNonZero(left.reshape(1) != leftSerial.reshape(1)), 0);
    EXPECT_EQ(cv::countNonZero(right.reshape(1) != rightSerial.reshape(1)), 0);
}

TEST(Lighting, PrepareOncePerSizeAndApplyChecksTheImage) {
    LightingCorrector corrector(falloffConfig());
    cv::Mat image(10, 12, CV_16UC3, cv::Scalar::all(100));
    EXPECT_THROW(corrector.apply(image, 16), InvalidArgument);  // not prepared
    corrector.prepare({12, 10});
    const float* first = corrector.factors().ptr<float>(0);
    corrector.prepare({12, 10});
    EXPECT_EQ(corrector.factors().ptr<float>(0), first);  // same size: kept
    cv::Mat other(11, 12, CV_16UC3);
    EXPECT_THROW(corrector.apply(other, 16), InvalidArgument);
    cv::Mat f32(10, 12, CV_32FC3);
    EXPECT_THROW(corrector.apply(f32, 16), FormatError);
    EXPECT_THROW(corrector.apply(image, 17), InvalidArgument);
    cv::Mat image8(10, 12, CV_8UC3);
    EXPECT_THROW(corrector.apply(image8, 12), InvalidArgument);
    EXPECT_THROW(corrector.prepare({0, 0}), InvalidArgument);
}

TEST(Lighting, RejectsInvalidGainsAndFalloff) {
    LightingConfig c = falloffConfig();
    c.gainsRgb[1] = -1.0;
    EXPECT_THROW(LightingCorrector{c}, InvalidArgument);
    c = falloffConfig();
    c.blue.exponent = std::nan("");
    EXPECT_THROW(LightingCorrector{c}, InvalidArgument);
    c = falloffConfig();
    c.red.coefficient = std::numeric_limits<double>::infinity();
    EXPECT_THROW(LightingCorrector{c}, InvalidArgument);
}

TEST(Lighting, SteepFalloffIsClampedNotInfinite) {
    LightingConfig c = falloffConfig();
    c.red.exponent = 50.0;  // exp(50 * 40) overflows double
    LightingCorrector corrector(c);
    corrector.prepare({48, 32});
    double lo = 0, hi = 0;
    cv::minMaxLoc(corrector.factors().reshape(1), &lo, &hi);
    EXPECT_TRUE(std::isfinite(hi));
    cv::Mat image(32, 48, CV_16UC3, cv::Scalar::all(1));
    corrector.apply(image, 16);
    EXPECT_EQ(image.at<cv::Vec3w>(0, 0)[2], 65535);
}

TEST(Lighting, TemplateImageRelativeToConfigDir) {
    TempDir dir;
    cv::Mat tmpl(6, 8, CV_32FC3);
    for (int y = 0; y < 6; ++y)
        for (int x = 0; x < 8; ++x) tmpl.at<cv::Vec3f>(y, x) = {1.0f + x * 0.125f, 2.0f, 0.5f + y * 0.25f};
    fs::create_directories(dir.path() / "lighting");
    ASSERT_TRUE(writeFloatTiff(dir.path() / "lighting" / "template.tiff", tmpl));

    LightingConfig c = falloffConfig();
    c.templateImagePath = "lighting/template.tiff";
    LightingCorrector corrector(c, dir.path());
    corrector.prepare({8, 6});
    const cv::Vec3f v = corrector.factors().at<cv::Vec3f>(5, 3);
    EXPECT_NEAR(v[0], 0.75 * (1.0 + 3 * 0.125), 1e-6);
    EXPECT_NEAR(v[1], 1.25 * 2.0, 1e-6);
    EXPECT_NEAR(v[2], 1.5 * (0.5 + 5 * 0.25), 1e-6);

    cv::Mat image(6, 8, CV_16UC3, cv::Scalar(1000, 1000, 1000));
    corrector.apply(image, 16);
    EXPECT_EQ(image.at<cv::Vec3w>(5, 3), cv::Vec3w(1031, 2500, 2625));

    // Absolute path: configDir not used. PFM (Portable Float Map) works too.
    ASSERT_TRUE(cv::imwrite((dir.path() / "template.pfm").string(), tmpl));
    c.templateImagePath = (dir.path() / "template.pfm").string();
    LightingCorrector absolute(c, "/nonexistent");
    absolute.prepare({8, 6});
    EXPECT_EQ(absolute.factors().at<cv::Vec3f>(2, 2), corrector.factors().at<cv::Vec3f>(2, 2));

    // Wrong size: named at prepare().
    try {
        corrector.prepare({16, 12});
        FAIL() << "no exception";
    } catch (const FormatError& e) {
        EXPECT_NE(std::string(e.what()).find("template.tiff"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("8x6"), std::string::npos) << e.what();
    }
}

template <typename E>
void expectTemplateError(const fs::path& dir, const std::string& name, const std::string& text) {
    LightingConfig c = falloffConfig();
    c.templateImagePath = name;
    try {
        LightingCorrector corrector(c, dir);
        FAIL() << "no exception for " << name;
    } catch (const E& e) {
        EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
    }
}

TEST(Lighting, TemplateImageErrorsNameTheFile) {
    TempDir dir;
    expectTemplateError<IoError>(dir.path(), "missing.tiff", "does not exist");
    std::ofstream(dir.path() / "garbage.tiff") << "not an image";
    expectTemplateError<IoError>(dir.path(), "garbage.tiff", "cannot decode");
    ASSERT_TRUE(writeFloatTiff(dir.path() / "gray.tiff", cv::Mat(4, 4, CV_32FC1, cv::Scalar(1.0))));
    expectTemplateError<FormatError>(dir.path(), "gray.tiff", "1 channels");
    ASSERT_TRUE(cv::imwrite((dir.path() / "eight.png").string(), cv::Mat(4, 4, CV_8UC3, cv::Scalar::all(1))));
    expectTemplateError<FormatError>(dir.path(), "eight.png", "floating-point");
    cv::Mat negative(4, 4, CV_32FC3, cv::Scalar::all(1.0));
    negative.at<cv::Vec3f>(2, 1) = {1.0f, -0.5f, 1.0f};
    ASSERT_TRUE(writeFloatTiff(dir.path() / "negative.tiff", negative));
    expectTemplateError<FormatError>(dir.path(), "negative.tiff", "(1, 2)");

    // A template is not read when the pattern is off.
    LightingConfig c = falloffConfig();
    c.patternEnabled = false;
    c.templateImagePath = "missing.tiff";
    EXPECT_NO_THROW((LightingCorrector{c, dir.path()}));
}

TEST(FrameAverageGains, RatiosOfChannelSumsInRgbOrder) {
    cv::Mat raw(4, 5, CV_16UC3, cv::Scalar(10, 20, 40));        // B, G, R
    cv::Mat corrected(4, 5, CV_16UC3, cv::Scalar(30, 20, 20));
    raw.at<cv::Vec3w>(0, 0) = {0, 0, 0};  // a black pixel changes the sums, not the method
    corrected.at<cv::Vec3w>(0, 0) = {0, 0, 0};
    const auto g = frameAverageGains(raw, corrected);
    EXPECT_DOUBLE_EQ(g[0], 0.5);  // R
    EXPECT_DOUBLE_EQ(g[1], 1.0);  // G
    EXPECT_DOUBLE_EQ(g[2], 3.0);  // B

    // Over a set: sums over every image, then the ratios (not the mean of ratios).
    cv::Mat raw2(4, 5, CV_16UC3, cv::Scalar(30, 20, 40));
    cv::Mat corrected2(4, 5, CV_16UC3, cv::Scalar(30, 60, 40));
    const auto s = frameAverageGains(std::vector<cv::Mat>{raw, raw2}, std::vector<cv::Mat>{corrected, corrected2});
    EXPECT_DOUBLE_EQ(s[0], (19 * 20.0 + 20 * 40.0) / (19 * 40.0 + 20 * 40.0));
    EXPECT_DOUBLE_EQ(s[1], (19 * 20.0 + 20 * 60.0) / (19 * 20.0 + 20 * 20.0));
    EXPECT_DOUBLE_EQ(s[2], (19 * 30.0 + 20 * 30.0) / (19 * 10.0 + 20 * 30.0));

    // Applying the gains to the raw image gives the corrected one (constant images).
    LightingConfig c;
    c.frameAverageEnabled = true;
    c.gainsRgb = g;
    LightingCorrector corrector(c);
    corrector.prepare(raw.size());
    cv::Mat fixedImage = raw.clone();
    corrector.apply(fixedImage, 16);
    EXPECT_EQ(cv::countNonZero(fixedImage.reshape(1) != corrected.reshape(1)), 0);
}

TEST(FrameAverageGains, RejectsMismatchedImagesAndEmptyChannels) {
    const cv::Mat raw(4, 5, CV_16UC3, cv::Scalar(10, 0, 40));
    EXPECT_THROW(frameAverageGains(raw, raw), InvalidArgument);  // green sums to 0
    const cv::Mat ok(4, 5, CV_16UC3, cv::Scalar::all(1));
    EXPECT_THROW(frameAverageGains(ok, cv::Mat(4, 6, CV_16UC3)), InvalidArgument);
    EXPECT_THROW(frameAverageGains(ok, cv::Mat(4, 5, CV_8UC3)), InvalidArgument);
    EXPECT_THROW(frameAverageGains(cv::Mat(4, 5, CV_16UC1), cv::Mat(4, 5, CV_16UC1)), InvalidArgument);
    EXPECT_THROW(frameAverageGains(std::vector<cv::Mat>{ok}, std::vector<cv::Mat>{}), InvalidArgument);
}

}  // namespace
}  // namespace avatar
