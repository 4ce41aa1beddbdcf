// The visibility stage's reductions give exactly what the OpenCV calls they
// replace give.
#include "ImageReduce.h"

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <string>

namespace avatar::detail {
namespace {

cv::Mat randomImage(cv::RNG& rng, cv::Size size, int type) {
    cv::Mat image(size, type);
    const double top = CV_MAT_DEPTH(type) == CV_8U ? 256.0 : 65536.0;
    rng.fill(image, cv::RNG::UNIFORM, cv::Scalar::all(0), cv::Scalar::all(top));
    return image;
}

TEST(DownsampleArea4, IsCvResizeInterAreaBitForBit) {
    cv::RNG rng(4242);
    for (const int type : {CV_8UC1, CV_8UC3, CV_16UC1, CV_16UC3, CV_16UC4}) {
        // Multiples of 4 (the hand-written path) and not (cv::resize itself).
        for (const cv::Size size : {cv::Size(1280, 960), cv::Size(64, 48), cv::Size(4, 4), cv::Size(66, 50)}) {
            SCOPED_TRACE(cv::typeToString(type) + " " + std::to_string(size.width) + "x" + std::to_string(size.height));
            const cv::Mat image = randomImage(rng, size, type);
            cv::Mat expected, actual;
            cv::resize(image, expected, cv::Size(), 0.25, 0.25, cv::INTER_AREA);
            downsampleArea4(image, actual);
            ASSERT_EQ(actual.size(), expected.size());
            ASSERT_EQ(actual.type(), expected.type());
            EXPECT_EQ(cv::norm(actual, expected, cv::NORM_INF), 0.0);
        }
    }
}

TEST(DownsampleArea4, RoundsHalvesToEvenLikeOpenCv) {
    // Block sums with remainders 7, 8 and 9 (mod 16) around an even and an odd quotient.
    for (const int base : {32, 48}) {
        for (const int extra : {7, 8, 9}) {
            cv::Mat image(4, 4, CV_16UC1, cv::Scalar(base / 16));
            image.at<std::uint16_t>(0, 0) = static_cast<std::uint16_t>(base / 16 + extra);
            cv::Mat expected, actual;
            cv::resize(image, expected, cv::Size(), 0.25, 0.25, cv::INTER_AREA);
            downsampleArea4(image, actual);
            EXPECT_EQ(actual.at<std::uint16_t>(0, 0), expected.at<std::uint16_t>(0, 0))
                << "base " << base << " extra " << extra;
        }
    }
}

TEST(CountPixelsWithAnyAtLeast, CountsPixelsNotSamples) {
    cv::RNG rng(17);
    for (const int type : {CV_8UC3, CV_16UC3, CV_16UC1}) {
        cv::Mat image = randomImage(rng, {97, 31}, type);
        const double full = CV_MAT_DEPTH(type) == CV_8U ? 255.0 : 65535.0;
        image.setTo(cv::Scalar::all(full), randomImage(rng, {97, 31}, CV_8UC1) > 200);
        for (const double t : {0.0, 1.0, 1000.5, full - 1.0, full, full + 1.0}) {
            std::vector<cv::Mat> planes;
            cv::split(image, planes);
            cv::Mat any = planes[0] >= t;
            for (std::size_t c = 1; c < planes.size(); ++c) any |= planes[c] >= t;
            EXPECT_EQ(countPixelsWithAnyAtLeast(image, t), cv::countNonZero(any)) << cv::typeToString(type) << " >= " << t;
            EXPECT_LE(countPixelsWithAnyAtLeast(image, t), static_cast<std::int64_t>(image.total()));
        }
    }
    // A pixel saturated in all three channels counts once: a fully saturated
    // image is 100 % saturated, not 300 %.
    const cv::Mat white(8, 8, CV_16UC3, cv::Scalar::all(65535));
    EXPECT_EQ(countPixelsWithAnyAtLeast(white, 65535), 64);
}

}  // namespace
}  // namespace avatar::detail
