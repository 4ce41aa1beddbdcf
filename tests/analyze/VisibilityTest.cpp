// The visibility measures and verdict (thesis 3.6.1) on images whose
// statistics are known exactly.
#include <avatar/analyze/Visibility.h>

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

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

}  // namespace
}  // namespace avatar
