// The visibility measures and verdict (thesis 3.6.1) on images whose
// statistics are known exactly.
#include <avatar/analyze/Visibility.h>

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <random>

namespace avatar {
namespace {

TEST(Visibility, SaturationIsTheFractionOfPixels) {
    // Half of the pixels saturated in all three channels, a quarter in one.
    cv::Mat image(64, 64, CV_16UC3, cv::Scalar(20000, 20000, 20000));
    image(cv::Rect(0, 0, 64, 32)).setTo(cv::Scalar::all(65535));
    image(cv::Rect(0, 32, 64, 16)).setTo(cv::Scalar(20000, 65535, 20000));
    const VisibilityMeasures m = measureVisibility(image, 16);
    EXPECT_DOUBLE_EQ(m.saturatedFraction, 0.75);

    const cv::Mat white(64, 64, CV_8UC3, cv::Scalar::all(255));
    EXPECT_DOUBLE_EQ(measureVisibility(white, 8).saturatedFraction, 1.0);
    VisibilityConfig limits;
    limits.maxSaturatedFraction = 0.25;
    const VisibilityVerdict v = judgeVisibility(measureVisibility(white, 8), measureVisibility(image, 16), limits);
    EXPECT_EQ(v.visibility, Visibility::Poor);
    EXPECT_NE(v.reason.find("left: 100.0% saturated, above 25.0%"), std::string::npos) << v.reason;
    EXPECT_NE(v.reason.find("right: 75.0% saturated"), std::string::npos) << v.reason;
}

TEST(Visibility, ContrastAndHazeOfKnownImages) {
    // Half black, half white: luma 0 or 1, so std 0.5; min channel likewise.
    cv::Mat image(64, 64, CV_16UC3, cv::Scalar::all(0));
    image(cv::Rect(0, 0, 64, 32)).setTo(cv::Scalar::all(65535));
    VisibilityMeasures m = measureVisibility(image, 16);
    EXPECT_DOUBLE_EQ(m.contrast, 0.5);
    EXPECT_DOUBLE_EQ(m.haze, 0.5);
    // One colour everywhere: no contrast at all (exactly 0, no cancellation
    // residue), haze its smallest channel.
    image.setTo(cv::Scalar(1000, 30000, 65535));
    m = measureVisibility(image, 16);
    EXPECT_EQ(m.contrast, 0.0);
    EXPECT_DOUBLE_EQ(m.haze, 1000.0 / 65535.0);
    // 12 significant bits of 16: relative to 4095.
    image.setTo(cv::Scalar(4095, 4095, 0));
    EXPECT_DOUBLE_EQ(measureVisibility(image, 12).haze, 0.0);
}

TEST(Visibility, ContrastAndHazeAgreeWithALongDoubleReference) {
    // Random 16- and 8-bit images, also a width (1284 / 4 = 321) that is no
    // multiple of a vector: std(luma) and mean(min channel) of the 4x4 area
    // reduction, computed here in long double from cv::resize's image.
    std::mt19937 rng(7);
    for (const int type : {CV_16UC3, CV_8UC3}) {
        for (const cv::Size size : {cv::Size(1284, 964), cv::Size(640, 480)}) {
            cv::Mat image(size, type);
            cv::randu(image, 0, type == CV_16UC3 ? 65536 : 256);
            // A gradient too, so that the contrast is not that of noise alone.
            image(cv::Rect(0, 0, size.width / 3, size.height)) *= 0.25;
            const int bits = type == CV_16UC3 ? 16 : 8;
            const VisibilityMeasures m = measureVisibility(image, bits);
            cv::Mat small;
            cv::resize(image, small, {}, 0.25, 0.25, cv::INTER_AREA);
            cv::Mat wide;
            small.convertTo(wide, CV_64FC3);
            long double sum = 0, squares = 0, minimum = 0;
            for (auto it = wide.begin<cv::Vec3d>(); it != wide.end<cv::Vec3d>(); ++it) {
                const cv::Vec3d& p = *it;
                const long double l = 0.114L * p[0] + 0.587L * p[1] + 0.299L * p[2];
                sum += l;
                squares += l * l;
                minimum += std::min({p[0], p[1], p[2]});
            }
            const long double n = static_cast<long double>(small.total());
            const long double full = (1 << bits) - 1;
            const long double contrast = std::sqrt(squares / n - (sum / n) * (sum / n)) / full;
            const long double haze = minimum / n / full;
            EXPECT_NEAR(m.contrast, static_cast<double>(contrast), 1e-12 * static_cast<double>(contrast)) << size << " " << bits;
            EXPECT_NEAR(m.haze, static_cast<double>(haze), 1e-12 * static_cast<double>(haze)) << size << " " << bits;
        }
    }
}

}  // namespace
}  // namespace avatar
