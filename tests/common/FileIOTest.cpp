#include "TempDir.h"

#include <avatar/common/Error.h>
#include <avatar/common/StereoImagePairFileIO.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <cstdint>
#include <fstream>
#include <random>
#include <string>
#include <vector>

using namespace avatar;
using avatar::test::TempDir;

namespace {

cv::Mat randomImage(int rows, int cols, int type, int maxValue, unsigned seed) {
    cv::Mat m(rows, cols, type);
    cv::RNG rng(seed);
    rng.fill(m, cv::RNG::UNIFORM, 0, maxValue + 1);
    return m;
}

bool identical(const cv::Mat& a, const cv::Mat& b) {
    return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

std::string expectFormatError(const std::function<void()>& f) {
    try {
        f();
    } catch (const FormatError& e) {
        return e.what();
    }
    return "no FormatError";
}

}  // namespace

class LosslessRoundTrip : public ::testing::TestWithParam<std::tuple<int, const char*>> {};

TEST_P(LosslessRoundTrip, KeepsEverySampleExactly) {
    const auto [type, ext] = GetParam();
    TempDir dir;
    const int maxValue = CV_MAT_DEPTH(type) == CV_16U ? 65535 : 255;
    cv::Mat image = randomImage(37, 53, type, maxValue, 7);
    const auto path = dir / (std::string("img") + ext);
    StereoImagePairFileIO::writeLossless(path, image);
    EXPECT_TRUE(identical(StereoImagePairFileIO::readLossless(path), image));
}

INSTANTIATE_TEST_SUITE_P(BitDepthsChannelsFormats, LosslessRoundTrip,
                         ::testing::Combine(::testing::Values(CV_8UC1, CV_8UC3, CV_16UC1, CV_16UC3),
                                            ::testing::Values(".png", ".tif")));

TEST(LosslessPair, RoundTripsAPair) {
    TempDir dir;
    StereoImagePair pair(randomImage(10, 12, CV_16UC1, 4095, 1), randomImage(10, 12, CV_16UC1, 4095, 2),
                         {PixelFormat::Bayer, BayerPattern::GB, 12});
    StereoImagePairFileIO::writeLossless(pair, dir / "l.png", dir / "r.png");
    auto back = StereoImagePairFileIO::readLossless(dir / "l.png", dir / "r.png", pair.layout());
    EXPECT_TRUE(identical(back.left(), pair.left()));
    EXPECT_TRUE(identical(back.right(), pair.right()));
    EXPECT_EQ(back.layout().bayerPattern, BayerPattern::GB);
}

TEST(LosslessPair, MismatchedFilesAreAFormatError) {
    TempDir dir;
    StereoImagePairFileIO::writeLossless(dir / "l.png", cv::Mat(4, 4, CV_16UC1, cv::Scalar(1)));
    StereoImagePairFileIO::writeLossless(dir / "r.png", cv::Mat(4, 5, CV_16UC1, cv::Scalar(1)));
    const auto msg = expectFormatError([&] {
        StereoImagePairFileIO::readLossless(dir / "l.png", dir / "r.png", {PixelFormat::Mono, BayerPattern::BG, 16});
    });
    EXPECT_NE(msg.find("do not form a pair: StereoImagePair: left image is 4x4 but right is 5x4"),
              std::string::npos) << msg;
}

TEST(Lossless, ErrorsNameTheFile) {
    TempDir dir;
    try {
        StereoImagePairFileIO::readLossless(dir / "missing.png");
        FAIL();
    } catch (const IoError& e) {
        EXPECT_EQ(std::string(e.what()), "no such image file: " + (dir / "missing.png").string());
    }
    std::ofstream(dir / "junk.png") << "not a png";
    EXPECT_EQ(expectFormatError([&] { StereoImagePairFileIO::readLossless(dir / "junk.png"); }),
              "cannot decode image file " + (dir / "junk.png").string());
    EXPECT_THROW(StereoImagePairFileIO::writeLossless(dir / "x.jpg", cv::Mat(2, 2, CV_8UC1)), InvalidArgument);
    EXPECT_THROW(StereoImagePairFileIO::writeLossless(dir / "no" / "dir.png", cv::Mat(2, 2, CV_8UC1)), IoError);
}

TEST(Display, WritesEightBitJpegAndPngFromSixteenBitBayer) {
    TempDir dir;
    cv::Mat bayer(16, 16, CV_16UC1, cv::Scalar(4095));
    const PairLayout layout{PixelFormat::Bayer, BayerPattern::BG, 12};
    StereoImagePairFileIO::writeDisplay(dir / "a.jpg", bayer, layout, 80);
    StereoImagePairFileIO::writeDisplay(dir / "a.png", bayer, layout);
    cv::Mat jpg = StereoImagePairFileIO::readDisplay(dir / "a.jpg");
    cv::Mat png = StereoImagePairFileIO::readDisplay(dir / "a.png");
    ASSERT_EQ(png.type(), CV_8UC3);
    EXPECT_EQ(png.at<cv::Vec3b>(8, 8), cv::Vec3b(255, 255, 255));  // full scale at 12 bits
    EXPECT_NEAR(jpg.at<cv::Vec3b>(8, 8)[1], 255, 2);
    EXPECT_THROW(StereoImagePairFileIO::writeDisplay(dir / "a.jpg", bayer, layout, 0), InvalidArgument);
    EXPECT_THROW(StereoImagePairFileIO::writeDisplay(dir / "a.bmp", bayer, layout), InvalidArgument);
}

struct RawCase {
    int bitDepth;
    PixelFormat format;
    ByteOrder order;
};

class RawRoundTrip : public ::testing::TestWithParam<RawCase> {};

TEST_P(RawRoundTrip, ReadsBackWhatWasWrittenThroughItsName) {
    const RawCase c = GetParam();
    TempDir dir;
    RawImageName name;
    name.side = Side::Right;
    name.group = 12;
    name.member = 99999;
    name.geometry = {33, 21, c.bitDepth, c.format, BayerPattern::GR, c.order};
    cv::Mat image = randomImage(21, 33, name.geometry.cvType(), (1 << c.bitDepth) - 1, 3);
    const auto path = dir / name.str();
    EXPECT_EQ(StereoImagePairFileIO::writeRaw(path, image, name.geometry), name.geometry.byteSize());
    EXPECT_EQ(std::filesystem::file_size(path), name.geometry.byteSize());
    EXPECT_TRUE(identical(StereoImagePairFileIO::readRaw(path), image));
}

INSTANTIATE_TEST_SUITE_P(Depths, RawRoundTrip,
                         ::testing::Values(RawCase{8, PixelFormat::Bayer, ByteOrder::Little},
                                           RawCase{12, PixelFormat::Bayer, ByteOrder::Little},
                                           RawCase{12, PixelFormat::Bayer, ByteOrder::Big},
                                           RawCase{16, PixelFormat::Mono, ByteOrder::Big},
                                           RawCase{16, PixelFormat::Bgr, ByteOrder::Little},
                                           RawCase{8, PixelFormat::Bgr, ByteOrder::Big}));

TEST(Raw, BigEndianFileHasTheHighByteFirst) {
    TempDir dir;
    RawImageGeometry g{2, 1, 16, PixelFormat::Mono, BayerPattern::BG, ByteOrder::Big};
    cv::Mat m = (cv::Mat_<std::uint16_t>(1, 2) << 0x1234, 0xABCD);
    StereoImagePairFileIO::writeRaw(dir / "be.raw", m, g);
    std::ifstream in(dir / "be.raw", std::ios::binary);
    std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)), {});
    EXPECT_EQ(bytes, (std::vector<unsigned char>{0x12, 0x34, 0xAB, 0xCD}));
    EXPECT_TRUE(identical(StereoImagePairFileIO::readRaw(dir / "be.raw", g), m));
    // The caller says little-endian: the same bytes read as swapped samples.
    g.byteOrder = ByteOrder::Little;
    cv::Mat le = StereoImagePairFileIO::readRaw(dir / "be.raw", g);
    EXPECT_EQ(le.at<std::uint16_t>(0, 0), 0x3412);
}

TEST(Raw, TruncatedAndOversizedFilesAreReportedWithSizes) {
    TempDir dir;
    RawImageName name{Side::Left, 1, 7, {4, 3, 16, PixelFormat::Bayer, BayerPattern::BG, ByteOrder::Little}};
    const auto path = dir / name.str();
    std::ofstream(path, std::ios::binary) << std::string(20, '\0');
    EXPECT_EQ(expectFormatError([&] { StereoImagePairFileIO::readRaw(path); }),
              "raw file " + path.string() + " is truncated: 20 bytes, expected 24 for 4x3 16-bit 1-channel");
    std::ofstream(path, std::ios::binary) << std::string(25, '\0');
    EXPECT_EQ(expectFormatError([&] { StereoImagePairFileIO::readRaw(path); }),
              "raw file " + path.string() + " is too large: 25 bytes, expected 24 for 4x3 16-bit 1-channel");
    EXPECT_THROW(StereoImagePairFileIO::readRaw(dir / name.str().replace(2, 5, "00002")), IoError);
}

TEST(Raw, WriteRejectsImageNotMatchingGeometry) {
    TempDir dir;
    RawImageGeometry g{4, 4, 12, PixelFormat::Bayer, BayerPattern::BG, ByteOrder::Little};
    EXPECT_THROW(StereoImagePairFileIO::writeRaw(dir / "x.raw", cv::Mat(4, 4, CV_8UC1), g), InvalidArgument);
    EXPECT_THROW(StereoImagePairFileIO::writeRaw(dir / "x.raw", cv::Mat(4, 5, CV_16UC1), g), InvalidArgument);
}

TEST(RawImageName, FormatsAndParsesEveryField) {
    RawImageName n{Side::Left, 1, 42, {1280, 960, 16, PixelFormat::Bayer, BayerPattern::BG, ByteOrder::Little}};
    EXPECT_EQ(n.str(), "L_00001_00042_1280x960_16b_1c_BG_le.raw");
    RawImageName m{Side::Right, 99999, 0, {640, 480, 8, PixelFormat::Bgr, BayerPattern::BG, ByteOrder::Big}};
    EXPECT_EQ(m.str(), "R_99999_00000_640x480_8b_3c_BGR_be.raw");

    auto p = RawImageName::parse("/some/dir/R_00003_00017_2448x2048_12b_1c_GR_be.png");
    EXPECT_EQ(p.side, Side::Right);
    EXPECT_EQ(p.group, 3u);
    EXPECT_EQ(p.member, 17u);
    EXPECT_EQ(p.geometry.width, 2448);
    EXPECT_EQ(p.geometry.height, 2048);
    EXPECT_EQ(p.geometry.bitDepth, 12);
    EXPECT_EQ(p.geometry.format, PixelFormat::Bayer);
    EXPECT_EQ(p.geometry.bayerPattern, BayerPattern::GR);
    EXPECT_EQ(p.geometry.byteOrder, ByteOrder::Big);
    EXPECT_EQ(RawImageName::parse("L_00000_00001_8x8_10b_1c_MONO_le.raw").geometry.format, PixelFormat::Mono);
}

TEST(RawImageName, NamesThePngVariantAndRefusesWhatItCannotName) {
    RawImageName n{Side::Left, 1, 42, {1280, 960, 16, PixelFormat::Bayer, BayerPattern::BG, ByteOrder::Little}};
    EXPECT_EQ(n.str(".png"), "L_00001_00042_1280x960_16b_1c_BG_le.png");
    EXPECT_THROW(n.str(".tif"), InvalidArgument);
    n.member = 100000;
    try {
        n.str();
        FAIL();
    } catch (const InvalidArgument& e) {
        EXPECT_STREQ(e.what(), "raw file name: group 1 member 100000 exceed the five digits of the name");
    }
}

TEST(RawImageName, RejectsEachMalformedPartByName) {
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"L_00001_00042_1280x960_16b_1c_BG_le.bin", "extension must be .raw or .png"},
        {"L_00001_00042_1280x960_16b_1c_BG.raw", "expected 8 fields separated by '_' "
                                                 "(side_group_member_WxH_bits_channels_layout_order), got 7"},
        {"X_00001_00042_1280x960_16b_1c_BG_le.raw", "side 'X' is not L or R"},
        {"L_0001_00042_1280x960_16b_1c_BG_le.raw", "group '0001' is not 5 digits"},
        {"L_00001_0004a_1280x960_16b_1c_BG_le.raw", "member '0004a' is not 5 digits"},
        {"L_00001_00042_1280-960_16b_1c_BG_le.raw", "size '1280-960' is not WxH"},
        {"L_00001_00042_x960_16b_1c_BG_le.raw", "width '' is not a number"},
        {"L_00001_00042_01280x960_16b_1c_BG_le.raw", "width '01280' has a leading zero"},
        {"L_00001_00042_1280x960_016b_1c_BG_le.raw", "bit depth '016' has a leading zero"},
        {"L_00001_00042_1280x960_16_1c_BG_le.raw", "bit depth '16' is not <n>b"},
        {"L_00001_00042_1280x960_17b_1c_BG_le.raw", "raw geometry: bit depth 17 outside 1..16"},
        {"L_00001_00042_0x960_16b_1c_BG_le.raw", "raw geometry: size 0x960 outside 1..65535"},
        {"L_00001_00042_1280x960_16b_2c_BG_le.raw", "channels '2c' is not 1c or 3c"},
        {"L_00001_00042_1280x960_16b_1c_XY_le.raw", "layout 'XY' is not BG, GB, RG, GR, MONO or BGR"},
        {"L_00001_00042_1280x960_16b_3c_BG_le.raw", "3c contradicts layout BG"},
        {"L_00001_00042_1280x960_16b_1c_BGR_le.raw", "1c contradicts layout BGR"},
        {"L_00001_00042_1280x960_16b_1c_BG_me.raw", "byte order 'me' is not le or be"},
    };
    for (const auto& [name, problem] : cases) {
        SCOPED_TRACE(name);
        EXPECT_EQ(expectFormatError([&] { RawImageName::parse(name); }),
                  "raw file name '" + name + "': " + problem);
    }
}
