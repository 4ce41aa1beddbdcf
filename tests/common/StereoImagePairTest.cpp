#include <avatar/common/Error.h>
#include <avatar/common/StereoImagePair.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

using namespace avatar;

namespace {
PairLayout bayer16() { return {PixelFormat::Bayer, BayerPattern::BG, 16}; }
}  // namespace

TEST(StereoImagePair, OwningPairKeepsImagesAndIdentity) {
    cv::Mat l(4, 6, CV_16UC1, cv::Scalar(7)), r(4, 6, CV_16UC1, cv::Scalar(9));
    AcquisitionId id{3, 42, {"0xA", 1000}, {"0xB", 1003}};
    StereoImagePair sip(l, r, bayer16(), id);
    EXPECT_EQ(sip.size(), cv::Size(6, 4));
    EXPECT_EQ(sip.containerBits(), 16);
    EXPECT_EQ(sip.channels(), 1);
    EXPECT_TRUE(sip.ownsPixels());
    EXPECT_EQ(sip.id().group, 3u);
    EXPECT_EQ(sip.id().member, 42u);
    EXPECT_EQ(sip.id().left.cameraId, "0xA");
    EXPECT_EQ(sip.id().right.timestampUs, 1003);
    EXPECT_EQ(sip.left().at<std::uint16_t>(0, 0), 7);
    EXPECT_EQ(sip.image(Side::Right).at<std::uint16_t>(3, 5), 9);
    EXPECT_EQ(sip.describe(), "group 3 member 42, 6x4 bayer BG 16-bit (owning)");
}

TEST(StereoImagePair, ViewSharesExternalMemoryWithoutCopying) {
    std::vector<std::uint16_t> left(8 * 4, 100), right(8 * 4, 200);
    auto sip = StereoImagePair::view(left.data(), right.data(), {8, 4}, CV_16UC1,
                                     {PixelFormat::Mono, BayerPattern::BG, 12});
    EXPECT_FALSE(sip.ownsPixels());
    EXPECT_EQ(sip.left().ptr<std::uint16_t>(0), left.data());
    left[5] = 1234;  // the "DMA buffer" changes underneath
    EXPECT_EQ(sip.left().at<std::uint16_t>(0, 5), 1234);

    auto copy = sip.clone();
    EXPECT_TRUE(copy.ownsPixels());
    left[5] = 1;
    EXPECT_EQ(copy.left().at<std::uint16_t>(0, 5), 1234);
    EXPECT_NE(copy.left().ptr<std::uint16_t>(0), left.data());
}

TEST(StereoImagePair, ViewHonoursRowStride) {
    // 3 pixels of data per row, 5 samples of stride (padding of the camera buffer).
    std::vector<std::uint8_t> l(5 * 2, 0), r(5 * 2, 0);
    l[5] = 77;  // row 1, column 0
    auto sip = StereoImagePair::view(l.data(), r.data(), {3, 2}, CV_8UC1,
                                     {PixelFormat::Mono, BayerPattern::BG, 8}, 5);
    EXPECT_EQ(sip.left().at<std::uint8_t>(1, 0), 77);
}

struct BadPairCase {
    const char* name;
    cv::Mat left, right;
    PairLayout layout;
    const char* message;
};

TEST(StereoImagePair, RejectsInconsistentImagesWithMessages) {
    const std::vector<BadPairCase> cases = {
        {"empty", cv::Mat(), cv::Mat(2, 2, CV_8UC1), {PixelFormat::Mono, BayerPattern::BG, 8},
         "StereoImagePair: left image is empty"},
        {"size", cv::Mat(2, 3, CV_8UC1), cv::Mat(2, 2, CV_8UC1), {PixelFormat::Mono, BayerPattern::BG, 8},
         "StereoImagePair: left image is 3x2 but right is 2x2"},
        {"type", cv::Mat(2, 2, CV_8UC1), cv::Mat(2, 2, CV_16UC1), {PixelFormat::Mono, BayerPattern::BG, 8},
         "StereoImagePair: left image type 8UC1 differs from right 16UC1"},
        {"depth", cv::Mat(2, 2, CV_32FC1), cv::Mat(2, 2, CV_32FC1), {PixelFormat::Mono, BayerPattern::BG, 8},
         "StereoImagePair: unsupported sample type depth 5C1 (8 or 16 bit unsigned only)"},
        {"channels", cv::Mat(2, 2, CV_8UC1), cv::Mat(2, 2, CV_8UC1), {PixelFormat::Bgr, BayerPattern::BG, 8},
         "StereoImagePair: format bgr needs 3 channel(s), images have 1"},
        {"bits", cv::Mat(2, 2, CV_8UC1), cv::Mat(2, 2, CV_8UC1), {PixelFormat::Bayer, BayerPattern::BG, 12},
         "StereoImagePair: bit depth 12 does not fit a 8-bit container"},
        {"wide", cv::Mat(2, 2, CV_16UC1), cv::Mat(2, 2, CV_16UC1), {PixelFormat::Bayer, BayerPattern::BG, 8},
         "StereoImagePair: bit depth 8 belongs in an 8-bit container, not 16-bit"},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(c.name);
        try {
            StereoImagePair sip(c.left, c.right, c.layout);
            FAIL() << "accepted";
        } catch (const InvalidArgument& e) {
            EXPECT_STREQ(e.what(), c.message);
        }
    }
}
