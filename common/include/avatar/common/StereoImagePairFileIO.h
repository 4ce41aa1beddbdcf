#pragma once
/// @file StereoImagePairFileIO.h
/// Reading and writing stereo pairs and single images (thesis 4.2.1):
/// lossless 8/16-bit PNG or TIFF, 8-bit JPEG/PNG for display, and headerless
/// raw binary files whose geometry comes from the caller or from the file name.

#include <avatar/common/ImageFormat.h>
#include <avatar/common/StereoImagePair.h>

#include <opencv2/core/mat.hpp>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

namespace avatar {

/// Everything needed to turn a headerless block of samples into an image.
struct RawImageGeometry {
    int width{0};
    int height{0};
    int bitDepth{16};                  ///< significant bits, 1..16; > 8 is stored in 2 bytes
    PixelFormat format{PixelFormat::Bayer};
    BayerPattern bayerPattern{BayerPattern::BG};
    ByteOrder byteOrder{ByteOrder::Little};  ///< of 2-byte samples in the file

    int channels() const { return format == PixelFormat::Bgr ? 3 : 1; }
    int bytesPerSample() const { return bitDepth > 8 ? 2 : 1; }
    /// Exact size of the file in bytes.
    std::size_t byteSize() const;
    /// CV_8UC1, CV_16UC1, CV_8UC3 or CV_16UC3.
    int cvType() const;
    /// Throws avatar::InvalidArgument naming the bad field.
    void validate() const;
};

/// The name of one raw image file, which alone suffices to rebuild the image:
///   <side>_<group:5>_<member:5>_<width>x<height>_<bits>b_<channels>c_<layout>_<order>.raw
/// e.g. "L_00001_00042_1280x960_16b_1c_BG_le.raw", where layout is a Bayer
/// pattern (BG, GB, RG, GR), "MONO" or "BGR", and order is "le" or "be".
/// See docs/formats.md.
struct RawImageName {
    Side side{Side::Left};
    std::uint32_t group{0};   ///< 0..99999
    std::uint32_t member{0};  ///< 0..99999
    RawImageGeometry geometry;

    /// The file name (no directory) with @p extension ".raw" or ".png" (the
    /// lossless archive variant). Throws avatar::InvalidArgument when group or
    /// member exceed five digits, the geometry is invalid, or the extension is neither.
    std::string str(std::string_view extension = ".raw") const;
    /// Parses a file name (a directory part is ignored); only the canonical
    /// spelling str() produces is accepted (no leading zeros in sizes). Throws
    /// avatar::FormatError naming the name and the part that does not parse.
    static RawImageName parse(const std::string& fileName);
};

/// File input and output for pairs and images. All functions throw
/// avatar::IoError (naming the path) when a file cannot be read or written and
/// avatar::FormatError when its content does not fit.
class StereoImagePairFileIO {
public:
    /// Writes one image losslessly; the extension chooses PNG (.png) or TIFF
    /// (.tif/.tiff). 8- and 16-bit samples are kept as they are.
    static void writeLossless(const std::filesystem::path& path, const cv::Mat& image);
    /// Reads a lossless image exactly as stored (depth and channels unchanged).
    static cv::Mat readLossless(const std::filesystem::path& path);

    /// Writes both images of a pair losslessly.
    static void writeLossless(const StereoImagePair& pair, const std::filesystem::path& leftPath,
                              const std::filesystem::path& rightPath);
    /// Reads a pair written by writeLossless(); @p layout says what the pixels mean.
    static StereoImagePair readLossless(const std::filesystem::path& leftPath,
                                        const std::filesystem::path& rightPath, PairLayout layout);

    /// Writes an 8-bit rendition for people: JPEG (.jpg/.jpeg, @p jpegQuality 1..100)
    /// or PNG. A Bayer image is demosaiced first; 16-bit data is scaled from @p bitDepth.
    static void writeDisplay(const std::filesystem::path& path, const cv::Mat& image,
                             const PairLayout& layout, int jpegQuality = 90);
    /// Reads an 8-bit image file (JPEG, PNG, BMP...) as BGR; used for old 8-bit test sets.
    static cv::Mat readDisplay(const std::filesystem::path& path);

    /// Reads a headerless raw file. The file's size must be exactly
    /// geometry.byteSize(); 2-byte samples are converted to host byte order.
    static cv::Mat readRaw(const std::filesystem::path& path, const RawImageGeometry& geometry);
    /// Reads a raw file whose name follows RawImageName.
    static cv::Mat readRaw(const std::filesystem::path& path);
    /// Writes @p image as a headerless raw file in @p byteOrder. The image's
    /// type must match the geometry's; returns the number of bytes written.
    static std::size_t writeRaw(const std::filesystem::path& path, const cv::Mat& image,
                                const RawImageGeometry& geometry);
};

}  // namespace avatar
