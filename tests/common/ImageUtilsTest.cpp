#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cstdint>
#include <string>

using namespace avatar;

namespace {

// Colour of the filter over pixel (x, y) for a pattern named by its first row:
// 0 = blue, 1 = green, 2 = red (BGR channel index).
int filterChannel(BayerPattern p, int x, int y) {
    // The two rows of each 2x2 cell, written out by hand from the definition.
    const char* cell = p == BayerPattern::BG   ? "BGGR"
                       : p == BayerPattern::GB ? "GBRG"
                       : p == BayerPattern::RG ? "RGGB"
                                               : "GRBG";
    const char c = cell[(y % 2) * 2 + (x % 2)];
    return c == 'B' ? 0 : c == 'G' ? 1 : 2;
}

// Samples a BGR image through a colour filter array.
template <typename T>
cv::Mat mosaic(const cv::Mat& bgr, BayerPattern p) {
    cv::Mat out(bgr.size(), CV_MAKETYPE(cv::DataType<T>::depth, 1));
    for (int y = 0; y < bgr.rows; ++y)
        for (int x = 0; x < bgr.cols; ++x)
            out.at<T>(y, x) = bgr.at<cv::Vec<T, 3>>(y, x)[filterChannel(p, x, y)];
    return out;
}

// Each channel a different linear ramp: bilinear demosaicing reproduces a
// linear function exactly away from the border, so a wrong pattern mapping or
// a wrong interpolation shows up as a large error.
template <typename T>
cv::Mat ramps(int w, int h, int scale) {
    cv::Mat bgr(h, w, CV_MAKETYPE(cv::DataType<T>::depth, 3));
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            bgr.at<cv::Vec<T, 3>>(y, x) = cv::Vec<T, 3>(static_cast<T>(scale * (2 * x + 3 * y + 10)),
                                                        static_cast<T>(scale * (5 * x + y + 20)),
                                                        static_cast<T>(scale * (x + 4 * y + 30)));
    return bgr;
}

template <typename T>
int maxInteriorError(const cv::Mat& a, const cv::Mat& b, int margin) {
    int worst = 0;
    for (int y = margin; y < a.rows - margin; ++y)
        for (int x = margin; x < a.cols - margin; ++x)
            for (int c = 0; c < 3; ++c)
                worst = std::max(worst, std::abs(static_cast<int>(a.at<cv::Vec<T, 3>>(y, x)[c]) -
                                                 static_cast<int>(b.at<cv::Vec<T, 3>>(y, x)[c])));
    return worst;
}

const BayerPattern kPatterns[] = {BayerPattern::BG, BayerPattern::GB, BayerPattern::RG, BayerPattern::GR};

}  // namespace

TEST(FilterLayout, FirstRowNamesThePattern) {
    // BG: B G / G R
    EXPECT_EQ(filterChannel(BayerPattern::BG, 0, 0), 0);
    EXPECT_EQ(filterChannel(BayerPattern::BG, 1, 0), 1);
    EXPECT_EQ(filterChannel(BayerPattern::BG, 0, 1), 1);
    EXPECT_EQ(filterChannel(BayerPattern::BG, 1, 1), 2);
    // GR: G R / B G
    EXPECT_EQ(filterChannel(BayerPattern::GR, 1, 0), 2);
    EXPECT_EQ(filterChannel(BayerPattern::GR, 0, 1), 0);
    // GB: G B / R G
    EXPECT_EQ(filterChannel(BayerPattern::GB, 1, 0), 0);
    EXPECT_EQ(filterChannel(BayerPattern::GB, 0, 1), 2);
}

TEST(Demosaic, EveryPatternReproducesLinearRamps8Bit) {
    const cv::Mat truth = ramps<std::uint8_t>(24, 16, 1);
    for (auto p : kPatterns) {
        SCOPED_TRACE(std::string(toString(p)));
        cv::Mat bgr = demosaic(mosaic<std::uint8_t>(truth, p), p);
        ASSERT_EQ(bgr.type(), CV_8UC3);
        EXPECT_LE(maxInteriorError<std::uint8_t>(bgr, truth, 2), 1);
    }
}

TEST(Demosaic, EveryPatternReproducesLinearRamps16Bit) {
    const cv::Mat truth = ramps<std::uint16_t>(24, 16, 300);
    for (auto p : kPatterns) {
        SCOPED_TRACE(std::string(toString(p)));
        cv::Mat bgr = demosaic(mosaic<std::uint16_t>(truth, p), p);
        ASSERT_EQ(bgr.type(), CV_16UC3);
        EXPECT_LE(maxInteriorError<std::uint16_t>(bgr, truth, 2), 1);
    }
}

TEST(Demosaic, WrongPatternIsDetectedByTheRampTest) {
    // Guards the test itself: decoding with the wrong pattern must fail it.
    const cv::Mat truth = ramps<std::uint16_t>(24, 16, 300);
    cv::Mat bgr = demosaic(mosaic<std::uint16_t>(truth, BayerPattern::BG), BayerPattern::RG);
    EXPECT_GT(maxInteriorError<std::uint16_t>(bgr, truth, 2), 1000);
}

TEST(Demosaic, EdgeAwareKeepsUniformColour) {
    cv::Mat truth(16, 16, CV_16UC3, cv::Scalar(3000, 2000, 1000));
    for (auto p : kPatterns) {
        SCOPED_TRACE(std::string(toString(p)));
        cv::Mat bgr = demosaic(mosaic<std::uint16_t>(truth, p), p, DemosaicMethod::EdgeAware);
        EXPECT_LE(maxInteriorError<std::uint16_t>(bgr, truth, 2), 1);
    }
}

TEST(Demosaic, PairKeepsIdentityAndBitDepth) {
    cv::Mat m(8, 8, CV_16UC1, cv::Scalar(100));
    StereoImagePair raw(m, m.clone(), {PixelFormat::Bayer, BayerPattern::GR, 12}, {5, 6, {}, {}});
    StereoImagePair rgb = demosaic(raw);
    EXPECT_EQ(rgb.layout().format, PixelFormat::Bgr);
    EXPECT_EQ(rgb.layout().bitDepth, 12);
    EXPECT_EQ(rgb.channels(), 3);
    EXPECT_EQ(rgb.id().member, 6u);
    EXPECT_THROW(demosaic(rgb), InvalidArgument);
}

TEST(Demosaic, RejectsNonMosaicInput) {
    EXPECT_THROW(demosaic(cv::Mat(4, 4, CV_8UC3), BayerPattern::BG), InvalidArgument);
    EXPECT_THROW(demosaic(cv::Mat(4, 4, CV_32FC1), BayerPattern::BG), InvalidArgument);
    EXPECT_THROW(demosaic(cv::Mat(1, 4, CV_8UC1), BayerPattern::BG), InvalidArgument);
}

TEST(EndianSwap, SwapsBothBytesOfEverySample) {
    cv::Mat m = (cv::Mat_<std::uint16_t>(1, 4) << 0x1234, 0x00FF, 0xABCD, 0x0000);
    swapEndian16(m);
    EXPECT_EQ(m.at<std::uint16_t>(0, 0), 0x3412);
    EXPECT_EQ(m.at<std::uint16_t>(0, 1), 0xFF00);
    EXPECT_EQ(m.at<std::uint16_t>(0, 2), 0xCDAB);
    EXPECT_EQ(m.at<std::uint16_t>(0, 3), 0x0000);
    swapEndian16(m);
    EXPECT_EQ(m.at<std::uint16_t>(0, 0), 0x1234);
}

TEST(EndianSwap, HandlesThreeChannelsAndRoiViews) {
    cv::Mat big(4, 4, CV_16UC3, cv::Scalar(0x0102, 0x0304, 0x0506));
    cv::Mat roi = big(cv::Rect(1, 1, 2, 2));
    swapEndian16(roi);
    EXPECT_EQ(big.at<cv::Vec3w>(1, 1), cv::Vec3w(0x0201, 0x0403, 0x0605));
    EXPECT_EQ(big.at<cv::Vec3w>(0, 0), cv::Vec3w(0x0102, 0x0304, 0x0506));  // outside the view
    cv::Mat eight(2, 2, CV_8UC1);
    EXPECT_THROW(swapEndian16(eight), InvalidArgument);
}

TEST(ToDisplay8, ScalesFromTheSignificantBits) {
    cv::Mat m = (cv::Mat_<std::uint16_t>(1, 4) << 0, 2048, 4095, 1);
    cv::Mat d = toDisplay8(m, 12);
    ASSERT_EQ(d.type(), CV_8UC1);
    EXPECT_EQ(d.at<std::uint8_t>(0, 0), 0);
    EXPECT_EQ(d.at<std::uint8_t>(0, 1), 128);  // 2048*255/4095 = 127.53
    EXPECT_EQ(d.at<std::uint8_t>(0, 2), 255);
    EXPECT_EQ(d.at<std::uint8_t>(0, 3), 0);
    cv::Mat full = (cv::Mat_<std::uint16_t>(1, 2) << 65535, 32768);
    cv::Mat f = toDisplay8(full, 16);
    EXPECT_EQ(f.at<std::uint8_t>(0, 0), 255);
    EXPECT_EQ(f.at<std::uint8_t>(0, 1), 128);
    EXPECT_THROW(toDisplay8(full, 17), InvalidArgument);
    EXPECT_THROW(toDisplay8(cv::Mat(2, 2, CV_8UC1), 9), InvalidArgument);
}
