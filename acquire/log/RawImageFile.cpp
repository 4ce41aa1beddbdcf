#include <avatar/common/internal/FileUtil.h>
#include <avatar/common/internal/Text.h>

#include "RawImageFile.h"
#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>

#include <zlib.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <optional>

#include <vector>

namespace avatar {
namespace fs = std::filesystem;

namespace {

std::string describe(const RawImageGeometry& g) {
    return std::to_string(g.width) + "x" + std::to_string(g.height) + " " +
           std::to_string(g.bitDepth) + "-bit " + std::to_string(g.channels()) + "-channel";
}

std::string describe(const cv::Mat& m) {
    return std::to_string(m.cols) + "x" + std::to_string(m.rows) + " " +
           (m.depth() == CV_8U ? "8-bit" : m.depth() == CV_16U ? "16-bit" : "non-8/16-bit") + " " +
           std::to_string(m.channels()) + "-channel";
}

bool isPng(const fs::path& path) { return path.extension() == ".png"; }

void checkCrc(const fs::path& path, std::uint32_t expected, std::uint32_t actual) {
    if (actual != expected)
        throw FormatError("image file " + path.string() + ": checksum mismatch: recorded " + text::hex8(expected) +
                          ", computed " + text::hex8(actual) + " (the file was altered or damaged)");
}

void checkRawSize(const fs::path& path, std::size_t size, const RawImageGeometry& g) {
    const std::size_t expected = g.byteSize();
    if (size != expected)
        throw FormatError("raw file " + path.string() + (size < expected ? " is truncated: " : " is too large: ") +
                          std::to_string(size) + " bytes, its name says " + describe(g) + " = " +
                          std::to_string(expected) + " bytes");
}

/// A raw file read straight into the image's samples (no intermediate
/// buffer), its size checked first ("truncated" says more than a checksum
/// mismatch), then its CRC-32 when one was recorded, then the byte order.
cv::Mat readRaw(const fs::path& path, const RawImageGeometry& g, const std::optional<std::uint32_t>& expectedCrc32) {
    std::size_t size = 0;
    const fileutil::FileDescriptor fd = fileutil::openForReading(path, "image file", size);
    checkRawSize(path, size, g);
    cv::Mat image(g.height, g.width, g.cvType());
    fileutil::readAll(fd.get(), image.data, size, path, "image file");
    if (expectedCrc32) checkCrc(path, *expectedCrc32, crc32(image.data, size));
    if (g.bytesPerSample() == 2 && g.byteOrder != hostByteOrder()) swapEndian16(image);
    return image;
}

cv::Mat decodePng(const fs::path& path, const std::vector<unsigned char>& bytes,
                  const RawImageGeometry& g) {
    cv::Mat image;
    try {
        image = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
    } catch (const cv::Exception& e) {
        throw FormatError("PNG file " + path.string() + " cannot be decoded: " + e.what());
    }
    if (image.empty()) throw FormatError("PNG file " + path.string() + " cannot be decoded");
    if (image.cols != g.width || image.rows != g.height || image.type() != g.cvType())
        throw FormatError("PNG file " + path.string() + " holds a " + describe(image) +
                          " image but its name says " + describe(g));
    return image;
}

}  // namespace

std::uint32_t crc32(const void* data, std::size_t size) {
    // zlib's table-driven (braided) CRC-32: the value of the byte-wise
    // CRC-32/ISO-HDLC the session logs have always carried, at several times
    // its speed (docs/benchmarks.md, replay).
    return static_cast<std::uint32_t>(::crc32_z(0UL, static_cast<const Bytef*>(data), size));
}

std::string imageFileName(const RawImageName& name, Compression compression) {
    return name.str(compression == Compression::Png ? ".png" : ".raw");
}

RawImageGeometry geometryOf(const cv::Mat& image, const PairLayout& layout, ByteOrder byteOrder) {
    if (image.depth() == CV_16U && layout.bitDepth <= 8)
        throw InvalidArgument("a 16-bit image with " + std::to_string(layout.bitDepth) +
                              " significant bits cannot be named: a raw file name's bit depth "
                              "above 8 implies 16-bit samples, 8 or fewer 8-bit samples");
    if (image.depth() == CV_8U && layout.bitDepth > 8)
        throw InvalidArgument("an 8-bit image cannot hold " + std::to_string(layout.bitDepth) +
                              " significant bits");
    RawImageGeometry g;
    g.width = image.cols;
    g.height = image.rows;
    g.bitDepth = layout.bitDepth;
    g.format = layout.format;
    g.bayerPattern = layout.bayerPattern;
    g.byteOrder = byteOrder;
    return g;
}

ImageFileRef writeImageFile(const fs::path& directory, const cv::Mat& image, const RawImageName& name,
                            Compression compression) {
    const std::string fileName = imageFileName(name, compression);
    const fs::path path = directory / fileName;
    const RawImageGeometry& g = name.geometry;
    if (image.cols != g.width || image.rows != g.height || image.type() != g.cvType())
        throw InvalidArgument("cannot write " + path.string() + ": the image is " + describe(image) +
                              " but the name says " + describe(g));

    std::vector<unsigned char> bytes;
    if (compression == Compression::Png) {
        try {
            if (!cv::imencode(".png", image, bytes))
                throw IoError("cannot encode " + path.string() + " as PNG");
        } catch (const cv::Exception& e) {
            throw IoError("cannot encode " + path.string() + " as PNG: " + e.what());
        }
    } else {
        cv::Mat data = image.isContinuous() ? image : image.clone();
        if (g.bytesPerSample() == 2 && g.byteOrder != hostByteOrder()) {
            data = data.clone();
            swapEndian16(data);
        }
        bytes.assign(data.data, data.data + g.byteSize());
    }
    fileutil::writeNewFileDurably(path, bytes.data(), bytes.size());
    return {fileName, crc32(bytes.data(), bytes.size())};
}

cv::Mat readImageFile(const fs::path& path) {
    const RawImageGeometry g = RawImageName::parse(path.filename().string()).geometry;
    if (!isPng(path)) return readRaw(path, g, std::nullopt);
    return decodePng(path, fileutil::readWholeFile(path, "image file"), g);
}

cv::Mat readImageFile(const fs::path& path, std::uint32_t expectedCrc32) {
    const RawImageGeometry g = RawImageName::parse(path.filename().string()).geometry;
    if (!isPng(path)) return readRaw(path, g, expectedCrc32);
    const std::vector<unsigned char> bytes = fileutil::readWholeFile(path, "image file");
    checkCrc(path, expectedCrc32, crc32(bytes.data(), bytes.size()));
    return decodePng(path, bytes, g);
}

}  // namespace avatar
