#pragma once
/// @file ImageFormat.h
/// Vocabulary for the pixel layouts AVATAR handles.

#include <string>
#include <string_view>

namespace avatar {

/// Which camera of the stereo pair.
enum class Side { Left, Right };

/// Colour-filter-array layout of a Bayer sensor, named by the first two pixels
/// of the first image row (the libdc1394 convention): BG is
///   B G B G ...
///   G R G R ...
/// Note that OpenCV's cv::COLOR_Bayer* codes are named by the second row instead;
/// avatar::demosaic() does the translation.
enum class BayerPattern { BG, GB, RG, GR };

/// What the channels of an image mean.
enum class PixelFormat {
    Mono,   ///< one channel of intensity
    Bayer,  ///< one channel, a colour mosaic (see BayerPattern)
    Bgr     ///< three channels in OpenCV order: blue, green, red
};

/// Byte order of 16-bit samples in a file or camera buffer.
enum class ByteOrder { Little, Big };

/// "L" or "R".
std::string_view toString(Side side);
/// "BG", "GB", "RG" or "GR".
std::string_view toString(BayerPattern pattern);
/// "mono", "bayer" or "bgr".
std::string_view toString(PixelFormat format);
/// "le" or "be".
std::string_view toString(ByteOrder order);

/// Parses "BG", "GB", "RG" or "GR"; throws avatar::InvalidArgument naming the text otherwise.
BayerPattern parseBayerPattern(std::string_view text);

/// The byte order of the machine running this code.
ByteOrder hostByteOrder();

}  // namespace avatar
