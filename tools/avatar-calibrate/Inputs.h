#pragma once
// The checkerboard pairs avatar-calibrate reads: 8-bit image files (JPEG,
// PNG, ...), 16-bit PNG/TIFF, raw files named as in docs/formats.md, or the
// pairs of a recorded session; Bayer data demosaiced first.

#include <opencv2/core/mat.hpp>

#include <optional>
#include <string>
#include <vector>

namespace avatar::calibrate {

/// One image ready for the corner detector.
struct LoadedImage {
    std::string name;  ///< the file (or session record) it came from
    cv::Mat bgr;       ///< 8- or 16-bit, 1 or 3 channels
    int bitDepth{8};
};

/// The files a shell pattern matches, sorted by name. Throws avatar::IoError
/// naming the pattern when it matches nothing.
std::vector<std::string> globFiles(const std::string& pattern);

/// Reads an image file: a .raw file by its name's geometry, anything else with
/// cv::imread (depth and channels kept); a Bayer mosaic is demosaiced.
/// Throws avatar::IoError / FormatError naming the file.
LoadedImage loadImage(const std::string& path);

/// The pairs of a session directory (docs/formats.md), demosaiced; damaged
/// records are skipped and named in @p skipped.
std::vector<std::pair<LoadedImage, LoadedImage>> loadSession(const std::string& directory,
                                                             std::vector<std::string>& skipped);

}  // namespace avatar::calibrate
