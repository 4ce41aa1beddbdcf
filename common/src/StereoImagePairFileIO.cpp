#include <avatar/common/Error.h>
#include <avatar/common/ImageUtils.h>
#include <avatar/common/StereoImagePairFileIO.h>
#include <avatar/common/internal/Text.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdio>
#include <fstream>
#include <vector>

namespace avatar {
namespace fs = std::filesystem;

namespace {

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}

std::string geometryText(const RawImageGeometry& g) {
    return std::to_string(g.width) + "x" + std::to_string(g.height) + " " +
           std::to_string(g.bitDepth) + "-bit " + std::to_string(g.channels()) + "-channel";
}

// Parses a whole decimal field of a raw file name; throws naming the part.
std::uint32_t parseNumber(const std::string& name, const std::string& part, const char* what,
                          std::size_t digits = 0) {
    std::uint32_t value = 0;
    const char* first = part.data();
    const char* last = part.data() + part.size();
    auto [ptr, ec] = std::from_chars(first, last, value);
    const bool leadingZero = digits == 0 && part.size() > 1 && part[0] == '0';
    if (leadingZero)
        throw FormatError("raw file name '" + name + "': " + what + " '" + part + "' has a leading zero");
    if (part.empty() || ec != std::errc() || ptr != last || (digits != 0 && part.size() != digits))
        throw FormatError("raw file name '" + name + "': " + what + " '" + part + "' is not " +
                          (digits != 0 ? std::to_string(digits) + " digits" : "a number"));
    return value;
}

void checkWritable(const cv::Mat& image, const fs::path& path) {
    if (image.empty()) throw InvalidArgument("cannot write an empty image to " + path.string());
    if (image.depth() != CV_8U && image.depth() != CV_16U)
        throw InvalidArgument("cannot write " + path.string() +
                              ": only 8- and 16-bit unsigned images are supported");
}

}  // namespace

std::size_t RawImageGeometry::byteSize() const {
    return static_cast<std::size_t>(width) * static_cast<std::size_t>(height) *
           static_cast<std::size_t>(channels()) * static_cast<std::size_t>(bytesPerSample());
}

int RawImageGeometry::cvType() const {
    return CV_MAKETYPE(bitDepth > 8 ? CV_16U : CV_8U, channels());
}

void RawImageGeometry::validate() const {
    if (width < 1 || width > 65535 || height < 1 || height > 65535)
        throw InvalidArgument("raw geometry: size " + std::to_string(width) + "x" +
                              std::to_string(height) + " outside 1..65535");
    if (bitDepth < 1 || bitDepth > 16)
        throw InvalidArgument("raw geometry: bit depth " + std::to_string(bitDepth) +
                              " outside 1..16");
}

std::string RawImageName::str(std::string_view extension) const {
    if (group > 99999 || member > 99999)
        throw InvalidArgument("raw file name: group " + std::to_string(group) + " member " +
                              std::to_string(member) + " exceed the five digits of the name");
    if (extension != ".raw" && extension != ".png")
        throw InvalidArgument("raw file name: extension '" + std::string(extension) + "' is not .raw or .png");
    geometry.validate();
    char numbers[32];
    std::snprintf(numbers, sizeof numbers, "_%05u_%05u_", group, member);
    std::string layout;
    switch (geometry.format) {
        case PixelFormat::Bayer: layout = std::string(toString(geometry.bayerPattern)); break;
        case PixelFormat::Mono: layout = "MONO"; break;
        case PixelFormat::Bgr: layout = "BGR"; break;
    }
    return std::string(toString(side)) + numbers + std::to_string(geometry.width) + "x" +
           std::to_string(geometry.height) + "_" + std::to_string(geometry.bitDepth) + "b_" +
           std::to_string(geometry.channels()) + "c_" + layout + "_" +
           std::string(toString(geometry.byteOrder)) + std::string(extension);
}

RawImageName RawImageName::parse(const std::string& fileName) {
    const std::string name = fs::path(fileName).filename().string();
    const auto dot = name.rfind('.');
    const std::string ext = dot == std::string::npos ? "" : name.substr(dot);
    if (ext != ".raw" && ext != ".png")
        throw FormatError("raw file name '" + name + "': extension must be .raw or .png");
    const std::string stem = name.substr(0, dot);
    std::vector<std::string> parts;
    for (const std::string_view part : text::split(stem, '_')) parts.emplace_back(part);
    if (parts.size() != 8)
        throw FormatError("raw file name '" + name + "': expected 8 fields separated by '_' "
                          "(side_group_member_WxH_bits_channels_layout_order), got " +
                          std::to_string(parts.size()));
    RawImageName out;
    if (parts[0] == "L") out.side = Side::Left;
    else if (parts[0] == "R") out.side = Side::Right;
    else throw FormatError("raw file name '" + name + "': side '" + parts[0] + "' is not L or R");
    out.group = parseNumber(name, parts[1], "group", 5);
    out.member = parseNumber(name, parts[2], "member", 5);
    const auto x = parts[3].find('x');
    if (x == std::string::npos)
        throw FormatError("raw file name '" + name + "': size '" + parts[3] + "' is not WxH");
    out.geometry.width = static_cast<int>(parseNumber(name, parts[3].substr(0, x), "width"));
    out.geometry.height = static_cast<int>(parseNumber(name, parts[3].substr(x + 1), "height"));
    if (parts[4].size() < 2 || parts[4].back() != 'b')
        throw FormatError("raw file name '" + name + "': bit depth '" + parts[4] + "' is not <n>b");
    out.geometry.bitDepth =
        static_cast<int>(parseNumber(name, parts[4].substr(0, parts[4].size() - 1), "bit depth"));
    if (parts[5] != "1c" && parts[5] != "3c")
        throw FormatError("raw file name '" + name + "': channels '" + parts[5] + "' is not 1c or 3c");
    const std::string& layout = parts[6];
    if (layout == "MONO") out.geometry.format = PixelFormat::Mono;
    else if (layout == "BGR") out.geometry.format = PixelFormat::Bgr;
    else {
        out.geometry.format = PixelFormat::Bayer;
        try {
            out.geometry.bayerPattern = parseBayerPattern(layout);
        } catch (const InvalidArgument&) {
            throw FormatError("raw file name '" + name + "': layout '" + layout +
                              "' is not BG, GB, RG, GR, MONO or BGR");
        }
    }
    if ((parts[5] == "3c") != (out.geometry.format == PixelFormat::Bgr))
        throw FormatError("raw file name '" + name + "': " + parts[5] + " contradicts layout " + layout);
    if (parts[7] == "le") out.geometry.byteOrder = ByteOrder::Little;
    else if (parts[7] == "be") out.geometry.byteOrder = ByteOrder::Big;
    else throw FormatError("raw file name '" + name + "': byte order '" + parts[7] + "' is not le or be");
    try {
        out.geometry.validate();
    } catch (const InvalidArgument& e) {
        throw FormatError("raw file name '" + name + "': " + e.what());
    }
    return out;
}

void StereoImagePairFileIO::writeLossless(const fs::path& path, const cv::Mat& image) {
    checkWritable(image, path);
    const std::string ext = lower(path.extension().string());
    if (ext != ".png" && ext != ".tif" && ext != ".tiff")
        throw InvalidArgument("lossless image " + path.string() + ": extension must be .png, .tif or .tiff");
    bool ok = false;
    try {
        ok = cv::imwrite(path.string(), image);
    } catch (const cv::Exception& e) {
        throw IoError("cannot write " + path.string() + ": " + e.what());
    }
    if (!ok) throw IoError("cannot write " + path.string());
}

cv::Mat StereoImagePairFileIO::readLossless(const fs::path& path) {
    if (!fs::exists(path)) throw IoError("no such image file: " + path.string());
    cv::Mat image = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
    if (image.empty()) throw FormatError("cannot decode image file " + path.string());
    if (image.channels() == 4)
        throw FormatError("image file " + path.string() + " has an alpha channel; expected 1 or 3 channels");
    return image;
}

void StereoImagePairFileIO::writeLossless(const StereoImagePair& pair, const fs::path& leftPath,
                                          const fs::path& rightPath) {
    writeLossless(leftPath, pair.left());
    writeLossless(rightPath, pair.right());
}

StereoImagePair StereoImagePairFileIO::readLossless(const fs::path& leftPath,
                                                    const fs::path& rightPath, PairLayout layout) {
    try {
        return StereoImagePair(readLossless(leftPath), readLossless(rightPath), layout);
    } catch (const InvalidArgument& e) {
        throw FormatError(leftPath.string() + " and " + rightPath.string() + " do not form a pair: " + e.what());
    }
}

void StereoImagePairFileIO::writeDisplay(const fs::path& path, const cv::Mat& image,
                                         const PairLayout& layout, int jpegQuality) {
    checkWritable(image, path);
    if (jpegQuality < 1 || jpegQuality > 100)
        throw InvalidArgument("JPEG quality " + std::to_string(jpegQuality) + " outside 1..100");
    cv::Mat rgb = layout.format == PixelFormat::Bayer ? demosaic(image, layout.bayerPattern) : image;
    cv::Mat display = toDisplay8(rgb, layout.bitDepth);
    const std::string ext = lower(path.extension().string());
    std::vector<int> params;
    if (ext == ".jpg" || ext == ".jpeg") params = {cv::IMWRITE_JPEG_QUALITY, jpegQuality};
    else if (ext != ".png")
        throw InvalidArgument("display image " + path.string() + ": extension must be .jpg, .jpeg or .png");
    bool ok = false;
    try {
        ok = cv::imwrite(path.string(), display, params);
    } catch (const cv::Exception& e) {
        throw IoError("cannot write " + path.string() + ": " + e.what());
    }
    if (!ok) throw IoError("cannot write " + path.string());
}

cv::Mat StereoImagePairFileIO::readDisplay(const fs::path& path) {
    if (!fs::exists(path)) throw IoError("no such image file: " + path.string());
    cv::Mat image = cv::imread(path.string(), cv::IMREAD_COLOR);
    if (image.empty()) throw FormatError("cannot decode image file " + path.string());
    return image;
}

cv::Mat StereoImagePairFileIO::readRaw(const fs::path& path, const RawImageGeometry& geometry) {
    geometry.validate();
    std::error_code ec;
    const auto size = fs::file_size(path, ec);
    if (ec) throw IoError("cannot read raw file " + path.string() + ": " + ec.message());
    const std::size_t expected = geometry.byteSize();
    if (size != expected)
        throw FormatError("raw file " + path.string() + (size < expected ? " is truncated: " : " is too large: ") +
                          std::to_string(size) + " bytes, expected " + std::to_string(expected) +
                          " for " + geometryText(geometry));
    cv::Mat image(geometry.height, geometry.width, geometry.cvType());
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError("cannot open raw file " + path.string());
    in.read(reinterpret_cast<char*>(image.data), static_cast<std::streamsize>(expected));
    if (in.gcount() != static_cast<std::streamsize>(expected))
        throw IoError("raw file " + path.string() + ": read " + std::to_string(in.gcount()) +
                      " of " + std::to_string(expected) + " bytes");
    if (geometry.bytesPerSample() == 2 && geometry.byteOrder != hostByteOrder()) swapEndian16(image);
    return image;
}

cv::Mat StereoImagePairFileIO::readRaw(const fs::path& path) {
    return readRaw(path, RawImageName::parse(path.filename().string()).geometry);
}

std::size_t StereoImagePairFileIO::writeRaw(const fs::path& path, const cv::Mat& image,
                                            const RawImageGeometry& geometry) {
    geometry.validate();
    if (image.cols != geometry.width || image.rows != geometry.height || image.type() != geometry.cvType())
        throw InvalidArgument("writeRaw " + path.string() + ": image does not match geometry " +
                              geometryText(geometry));
    cv::Mat data = image.isContinuous() ? image : image.clone();
    if (geometry.bytesPerSample() == 2 && geometry.byteOrder != hostByteOrder()) {
        data = data.clone();
        swapEndian16(data);
    }
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    if (!out) throw IoError("cannot create raw file " + path.string());
    const std::size_t bytes = geometry.byteSize();
    out.write(reinterpret_cast<const char*>(data.data), static_cast<std::streamsize>(bytes));
    out.flush();
    if (!out) throw IoError("cannot write raw file " + path.string() + " (disk full?)");
    return bytes;
}

}  // namespace avatar
