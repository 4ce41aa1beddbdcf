#include "TempDir.h"
#include "TestUtil.h"

#include "RawImageFile.h"
#include <avatar/common/Error.h>
#include <avatar/common/StereoImagePairFileIO.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <cstdint>
#include <string>
#include <tuple>

using namespace avatar;
using avatar::test::messageOf;
using avatar::test::randomImage;
using avatar::test::readBytes;
using avatar::test::sameImage;
using avatar::test::TempDir;
namespace fs = std::filesystem;

namespace {

RawImageName makeName(Side side, std::uint32_t group, std::uint32_t member, int w, int h, int bits,
                      PixelFormat format, BayerPattern pattern, ByteOrder order) {
    RawImageName n;
    n.side = side;
    n.group = group;
    n.member = member;
    n.geometry.width = w;
    n.geometry.height = h;
    n.geometry.bitDepth = bits;
    n.geometry.format = format;
    n.geometry.bayerPattern = pattern;
    n.geometry.byteOrder = order;
    return n;
}

}  // namespace

TEST(Crc32, IsTheStandardCrc32) {
    // The check value of CRC-32/ISO-HDLC (zlib, PNG, Ethernet) for "123456789".
    EXPECT_EQ(crc32("123456789", 9), 0xCBF43926u);
    EXPECT_EQ(crc32("", 0), 0x00000000u);
}

TEST(ImageFileName, FollowsTheRawNamingScheme) {
    const auto n = makeName(Side::Left, 1, 42, 1280, 960, 16, PixelFormat::Bayer, BayerPattern::BG,
                            ByteOrder::Little);
    EXPECT_EQ(imageFileName(n, Compression::None), "L_00001_00042_1280x960_16b_1c_BG_le.raw");
    EXPECT_EQ(imageFileName(n, Compression::Png), "L_00001_00042_1280x960_16b_1c_BG_le.png");
    const auto r = makeName(Side::Right, 99999, 0, 640, 480, 8, PixelFormat::Bgr, BayerPattern::BG,
                            ByteOrder::Big);
    EXPECT_EQ(imageFileName(r, Compression::None), "R_99999_00000_640x480_8b_3c_BGR_be.raw");
    const auto m = makeName(Side::Right, 7, 3, 6, 4, 12, PixelFormat::Mono, BayerPattern::GR,
                            ByteOrder::Big);
    EXPECT_EQ(imageFileName(m, Compression::Png), "R_00007_00003_6x4_12b_1c_MONO_be.png");
}

TEST(ImageFileName, RejectsNumbersBeyondFiveDigits) {
    auto n = makeName(Side::Left, 100000, 1, 4, 4, 8, PixelFormat::Mono, BayerPattern::BG,
                      ByteOrder::Little);
    EXPECT_EQ(messageOf<InvalidArgument>([&] { imageFileName(n, Compression::None); }),
              "raw file name: group 100000 member 1 exceed the five digits of the name");
    n.group = 1;
    n.member = 123456;
    EXPECT_EQ(messageOf<InvalidArgument>([&] { imageFileName(n, Compression::None); }),
              "raw file name: group 1 member 123456 exceed the five digits of the name");
}

TEST(GeometryOf, RejectsContainersTheNameCannotDescribe) {
    const cv::Mat m16(4, 4, CV_16UC1, cv::Scalar(1));
    EXPECT_EQ(messageOf<InvalidArgument>(
                  [&] { geometryOf(m16, {PixelFormat::Mono, BayerPattern::BG, 8}, ByteOrder::Little); }),
              "a 16-bit image with 8 significant bits cannot be named: a raw file name's bit depth above 8 "
              "implies 16-bit samples, 8 or fewer 8-bit samples");
    const auto g = geometryOf(m16, {PixelFormat::Bayer, BayerPattern::GB, 12}, ByteOrder::Big);
    EXPECT_EQ(g.width, 4);
    EXPECT_EQ(g.bitDepth, 12);
    EXPECT_EQ(g.format, PixelFormat::Bayer);
    EXPECT_EQ(g.bayerPattern, BayerPattern::GB);
    EXPECT_EQ(g.byteOrder, ByteOrder::Big);
}

// ------------------------------------------------------------ round trips

using RoundTripParam = std::tuple<int /*bits*/, ByteOrder, PixelFormat, Compression>;

class ImageFileRoundTrip : public ::testing::TestWithParam<RoundTripParam> {};

TEST_P(ImageFileRoundTrip, ReadsBackTheSameSamples) {
    const auto [bits, order, format, compression] = GetParam();
    TempDir dir;
    const int channels = format == PixelFormat::Bgr ? 3 : 1;
    const int type = CV_MAKETYPE(bits > 8 ? CV_16U : CV_8U, channels);
    const cv::Mat image = randomImage(6, 10, type, bits, 1000u + static_cast<unsigned>(bits));
    const auto name = makeName(Side::Right, 12, 345, 10, 6, bits, format, BayerPattern::GR, order);

    const ImageFileRef ref = writeImageFile(dir.path(), image, name, compression);
    EXPECT_EQ(ref.name, imageFileName(name, compression));
    const fs::path path = dir / ref.name;
    const auto bytes = readBytes(path);
    EXPECT_EQ(ref.crc32, crc32(bytes.data(), bytes.size()));
    // Nothing but the file itself is left in the directory.
    EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1);

    EXPECT_TRUE(sameImage(readImageFile(path), image));
    EXPECT_TRUE(sameImage(readImageFile(path, ref.crc32), image));

    if (compression == Compression::None) {
        // Headerless samples in the order of the name: check the first sample byte by byte.
        ASSERT_EQ(bytes.size(), static_cast<std::size_t>(10 * 6 * channels * (bits > 8 ? 2 : 1)));
        if (bits > 8) {
            const std::uint16_t v = image.at<std::uint16_t>(0, 0);
            const unsigned hi = v >> 8, lo = v & 0xFF;
            EXPECT_EQ(bytes[0], order == ByteOrder::Big ? hi : lo);
            EXPECT_EQ(bytes[1], order == ByteOrder::Big ? lo : hi);
        } else {
            EXPECT_EQ(bytes[0], image.at<std::uint8_t>(0, 0));
        }
        // The common library reads the same file to the same image.
        EXPECT_TRUE(sameImage(StereoImagePairFileIO::readRaw(path), image));
    } else {
        // A standard PNG decoder sees the unscaled samples.
        EXPECT_TRUE(sameImage(cv::imread(path.string(), cv::IMREAD_UNCHANGED), image));
    }
}

static std::string roundTripName(const ::testing::TestParamInfo<RoundTripParam>& info) {
    const auto& [bits, order, format, compression] = info.param;
    return std::to_string(bits) + "bit_" + std::string(toString(order)) + "_" + std::string(toString(format)) +
           (compression == Compression::Png ? "_png" : "_raw");
}

INSTANTIATE_TEST_SUITE_P(
    BitsOrdersLayouts, ImageFileRoundTrip,
    ::testing::Combine(::testing::Values(8, 12, 16), ::testing::Values(ByteOrder::Little, ByteOrder::Big),
                       ::testing::Values(PixelFormat::Mono, PixelFormat::Bayer, PixelFormat::Bgr),
                       ::testing::Values(Compression::None, Compression::Png)),
    roundTripName);

TEST(ImageFile, ReadsRawFilesWrittenByTheCommonLibrary) {
    TempDir dir;
    const cv::Mat image = randomImage(5, 7, CV_16UC1, 12, 5);
    const auto name = makeName(Side::Left, 3, 4, 7, 5, 12, PixelFormat::Bayer, BayerPattern::RG, ByteOrder::Big);
    const fs::path path = dir / name.str();
    StereoImagePairFileIO::writeRaw(path, image, name.geometry);
    EXPECT_TRUE(sameImage(readImageFile(path), image));
}

TEST(ImageFile, WritesAnImageThatIsAViewOfALargerOne) {
    TempDir dir;
    const cv::Mat big = randomImage(20, 30, CV_16UC1, 16, 9);
    const cv::Mat roi = big(cv::Rect(3, 4, 10, 6));
    ASSERT_FALSE(roi.isContinuous());
    const auto name = makeName(Side::Left, 1, 1, 10, 6, 16, PixelFormat::Mono, BayerPattern::BG, ByteOrder::Big);
    const auto ref = writeImageFile(dir.path(), roi, name, Compression::None);
    EXPECT_TRUE(sameImage(readImageFile(dir / ref.name), roi));
}

TEST(ImageFile, NeverOverwritesAFile) {
    TempDir dir;
    const cv::Mat image = randomImage(2, 2, CV_8UC1, 8, 1);
    const auto name = makeName(Side::Left, 1, 2, 2, 2, 8, PixelFormat::Mono, BayerPattern::BG, ByteOrder::Little);
    writeImageFile(dir.path(), image, name, Compression::None);
    const fs::path path = dir / "L_00001_00002_2x2_8b_1c_MONO_le.raw";
    EXPECT_EQ(messageOf<IoError>([&] { writeImageFile(dir.path(), image, name, Compression::None); }),
              "file " + path.string() + " exists already; recorded files are never overwritten");
}

TEST(ImageFile, RejectsAnImageThatDoesNotMatchItsName) {
    TempDir dir;
    const cv::Mat image(4, 5, CV_8UC1, cv::Scalar(0));
    const auto name = makeName(Side::Left, 1, 2, 5, 4, 12, PixelFormat::Mono, BayerPattern::BG, ByteOrder::Little);
    EXPECT_EQ(messageOf<InvalidArgument>([&] { writeImageFile(dir.path(), image, name, Compression::None); }),
              "cannot write " + (dir / "L_00001_00002_5x4_12b_1c_MONO_le.raw").string() +
                  ": the image is 5x4 8-bit 1-channel but the name says 5x4 12-bit 1-channel");
}

// ------------------------------------------------------------ damage

class DamagedImageFile : public ::testing::Test {
protected:
    void SetUp() override {
        image = randomImage(6, 8, CV_16UC1, 16, 3);
        name = makeName(Side::Left, 1, 7, 8, 6, 16, PixelFormat::Bayer, BayerPattern::BG, ByteOrder::Little);
        ref = writeImageFile(dir.path(), image, name, Compression::None);
        path = dir / ref.name;
    }
    TempDir dir;
    cv::Mat image;
    RawImageName name;
    ImageFileRef ref;
    fs::path path;
};

TEST_F(DamagedImageFile, TruncatedRawFile) {
    fs::resize_file(path, 95);
    const std::string expected = "raw file " + path.string() +
                                 " is truncated: 95 bytes, its name says 8x6 16-bit 1-channel = 96 bytes";
    EXPECT_EQ(messageOf<FormatError>([&] { readImageFile(path); }), expected);
    EXPECT_EQ(messageOf<FormatError>([&] { readImageFile(path, ref.crc32); }), expected);
}

TEST_F(DamagedImageFile, RawFileTooLargeForItsName) {
    fs::resize_file(path, 100);
    EXPECT_EQ(messageOf<FormatError>([&] { readImageFile(path, ref.crc32); }),
              "raw file " + path.string() + " is too large: 100 bytes, its name says 8x6 16-bit 1-channel = 96 bytes");
}

TEST_F(DamagedImageFile, BadChecksum) {
    auto bytes = readBytes(path);
    bytes[17] ^= 0x01;
    avatar::test::writeText(path, std::string(bytes.begin(), bytes.end()));
    char computed[9];
    std::snprintf(computed, sizeof computed, "%08x", crc32(bytes.data(), bytes.size()));
    char recorded[9];
    std::snprintf(recorded, sizeof recorded, "%08x", ref.crc32);
    EXPECT_EQ(messageOf<FormatError>([&] { readImageFile(path, ref.crc32); }),
              "image file " + path.string() + ": checksum mismatch: recorded " + recorded + ", computed " +
                  computed + " (the file was altered or damaged)");
}

TEST_F(DamagedImageFile, MissingFile) {
    fs::remove(path);
    EXPECT_EQ(messageOf<IoError>([&] { readImageFile(path, ref.crc32); }),
              "image file " + path.string() + " does not exist");
}

TEST_F(DamagedImageFile, PngOfOtherGeometryThanItsName) {
    const fs::path png = dir / "L_00001_00007_8x6_12b_1c_BG_le.png";
    cv::imwrite(png.string(), cv::Mat(6, 8, CV_8UC1, cv::Scalar(3)));
    EXPECT_EQ(messageOf<FormatError>([&] { readImageFile(png); }),
              "PNG file " + png.string() + " holds a 8x6 8-bit 1-channel image but its name says 8x6 12-bit 1-channel");
}

TEST_F(DamagedImageFile, UndecodablePng) {
    const fs::path png = dir / "L_00001_00007_8x6_16b_1c_BG_le.png";
    avatar::test::writeText(png, "not a png");
    EXPECT_EQ(messageOf<FormatError>([&] { readImageFile(png); }),
              "PNG file " + png.string() + " cannot be decoded");
}

TEST_F(DamagedImageFile, NameThatDoesNotParse) {
    const fs::path bad = dir / "L_00001_7_8x6_16b_1c_BG_le.raw";
    fs::copy_file(path, bad);
    EXPECT_EQ(messageOf<FormatError>([&] { readImageFile(bad); }),
              "raw file name 'L_00001_7_8x6_16b_1c_BG_le.raw': member '7' is not 5 digits");
}
