#pragma once
/// @file RawImageFile.h
/// Internal to avatar::acquire (not installed; the tests reach it).
/// One recorded image per file (thesis 4.2.2, docs/formats.md): headerless
/// samples in a `.raw` file, or the same samples losslessly compressed in a
/// `.png` file, named by avatar::RawImageName so that the name alone suffices to
/// rebuild the image. Both variants are read by the same functions.
///
/// Errors: avatar::IoError when a file cannot be created, read or found;
/// avatar::FormatError when its content does not fit its name or checksum;
/// avatar::InvalidArgument when a caller passes an image that cannot be named.
/// Every message names the file.

#include <avatar/acquire/SessionLog.h>
#include <avatar/common/StereoImagePairFileIO.h>

#include <opencv2/core/mat.hpp>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

namespace avatar {

/// CRC-32 (boost::crc_32_type: polynomial 0x04C11DB7, reflected, init and
/// final XOR 0xFFFFFFFF) of @p size bytes.
std::uint32_t crc32(const void* data, std::size_t size);

/// The file name of @p name with the extension of @p compression:
/// `L_00001_00042_1280x960_16b_1c_BG_le.raw` or `....png`. Throws
/// avatar::InvalidArgument if the group or member exceeds 99999 or the geometry is invalid.
std::string imageFileName(const RawImageName& name, Compression compression);

/// The geometry a StereoImagePair image is named with: its size, layout and bit
/// depth, and @p byteOrder. Throws avatar::InvalidArgument when the name cannot
/// describe the image (a 16-bit container holding 8 or fewer significant bits).
RawImageGeometry geometryOf(const cv::Mat& image, const PairLayout& layout, ByteOrder byteOrder);

/// Writes @p image into @p directory under imageFileName(@p name, @p compression)
/// and returns that name with the CRC-32 of the bytes written. The image must
/// match name.geometry (size, depth, channels); 16-bit samples are in host
/// order and are written in name.geometry.byteOrder (`.raw`) or as PNG
/// requires (`.png`). The file appears complete or not at all (written under a
/// temporary name, synced, renamed); an existing file is never overwritten
/// (avatar::IoError).
ImageFileRef writeImageFile(const std::filesystem::path& directory, const cv::Mat& image,
                            const RawImageName& name, Compression compression);

/// Reads a `.raw` or `.png` file whose name follows RawImageName and returns
/// its samples in host byte order (CV_8UC1/3 or CV_16UC1/3). A `.raw` file must
/// have exactly the size its name implies; a `.png` file must decode to the
/// size, depth and channels of its name.
cv::Mat readImageFile(const std::filesystem::path& path);

/// As readImageFile(path), and first checks that the CRC-32 of the file's bytes
/// is @p expectedCrc32 (avatar::FormatError naming the file and both values).
cv::Mat readImageFile(const std::filesystem::path& path, std::uint32_t expectedCrc32);

}  // namespace avatar
