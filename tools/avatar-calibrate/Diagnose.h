#pragma once
// Appendix A diagnostics of a calibration: the essential and fundamental
// matrices, a picture of a pair with the epipolar lines of chosen points, and
// the rectified pair.

#include "Inputs.h"

#include <avatar/config/StereoSystemConfig.h>

#include <nlohmann/json.hpp>
#include <opencv2/core/types.hpp>

#include <filesystem>
#include <vector>

namespace avatar::calibrate {

/// Writes into @p directory (created): epipolar.png (left | right: each
/// chosen left point and its epipolar curve in the right image, distortion
/// included), rectified.png (the pair rectified by cv::stereoRectify, with
/// horizontal lines: a point and its match lie on one), and returns E, F and
/// the rectification as JSON (also written as matrices.json).
nlohmann::json diagnose(const StereoSystemConfig& stereo, const LoadedImage& left, const LoadedImage& right,
                        const std::vector<cv::Point2d>& points, const std::filesystem::path& directory);

}  // namespace avatar::calibrate
