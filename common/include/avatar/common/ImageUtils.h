#pragma once
/// @file ImageUtils.h
/// Pixel utilities used throughout AVATAR (thesis 4.2.1): 16-bit endian swap,
/// Bayer demosaic and conversion to 8 bits for display.

#include <avatar/common/ImageFormat.h>
#include <avatar/common/StereoImagePair.h>

#include <opencv2/core/mat.hpp>

namespace avatar {

/// Reverses the two bytes of every sample of a 16-bit image, in place.
/// Throws avatar::InvalidArgument for any other depth.
void swapEndian16(cv::Mat& image);

/// Demosaic algorithms offered by OpenCV for both 8- and 16-bit mosaics.
enum class DemosaicMethod {
    Bilinear,   ///< fastest; colour fringes on sharp edges
    EdgeAware   ///< OpenCV's edge-aware interpolation; fewer fringes
};

/// The colour of the site (@p x, @p y) of a mosaic of @p pattern: 0 blue, 1
/// green, 2 red (the channel index of a BGR image). BayerPattern names the
/// first row's two sites: BG is blue, green / green, red.
int bayerSiteColour(BayerPattern pattern, int x, int y);

/// Converts a one-channel Bayer mosaic (8 or 16 bit) into a 3-channel BGR image
/// of the same depth. Throws avatar::InvalidArgument for other input.
cv::Mat demosaic(const cv::Mat& mosaic, BayerPattern pattern,
                 DemosaicMethod method = DemosaicMethod::Bilinear);

/// Demosaics both images of a Bayer pair; the result has format Bgr and keeps
/// the identity and bit depth. Throws avatar::InvalidArgument if the pair is not Bayer.
StereoImagePair demosaic(const StereoImagePair& pair,
                         DemosaicMethod method = DemosaicMethod::Bilinear);

/// Scales an image with @p bitDepth significant bits to 8 bits for display
/// (value * 255 / (2^bitDepth - 1), rounded, saturated). An 8-bit image with
/// bitDepth 8 is returned as a copy.
cv::Mat toDisplay8(const cv::Mat& image, int bitDepth);

}  // namespace avatar
