#pragma once
// The calibration formats people already have (docs/tools/avatar-calibrate.md):
// OpenCV FileStorage YAML as stereoCalibrate users keep it, ROS camera_info
// YAML (one file per camera), and the Bouguet toolbox's Calib_Results_stereo
// text. All in the configuration's conventions: X_right = R(om) X_left + T
// (mm), pixel (0, 0) the centre of the top-left pixel (also OpenCV's, ROS's
// and the Bouguet toolbox's).

#include <avatar/config/StereoSystemConfig.h>

#include <opencv2/core/types.hpp>

#include <filesystem>
#include <string>

namespace avatar::calibrate {

/// A calibration read from a file: the stereo system and the image size it is for.
struct ImportedCalibration {
    StereoSystemConfig stereo;
    cv::Size imageSize;  ///< 0 x 0 when the file does not say
    std::string format;  ///< "opencv", "ros", "bouguet"
};

/// Reads @p source: a directory holding left.yaml and right.yaml (ROS), a pair
/// "LEFT.yaml,RIGHT.yaml" (ROS), a FileStorage YAML/XML file (OpenCV: keys
/// camera_matrix_left / M1 / K1 / cameraMatrix1, dist_coeffs_left / D1 / ...,
/// R, T), or a Bouguet text (fc_left = [ ... ] with optional +/- or
/// *_error = [ ... ] standard errors). Throws avatar::IoError or
/// avatar::FormatError naming the file and the key at fault.
ImportedCalibration importCalibration(const std::string& source);

/// OpenCV FileStorage YAML: image_width, image_height, camera_matrix_left,
/// dist_coeffs_left, camera_matrix_right, dist_coeffs_right, R, T (mm), E, F,
/// and the rectification R1, R2, P1, P2, Q of cv::stereoRectify.
void exportOpenCv(const StereoSystemConfig& stereo, cv::Size imageSize, const std::filesystem::path& file);

/// ROS camera_info YAML, DIR/left.yaml and DIR/right.yaml: the rectification
/// of cv::stereoRectify, the projection matrices in metres (ROS's unit: the
/// right camera's P[3] is -fx' * baseline in m).
void exportRos(const StereoSystemConfig& stereo, cv::Size imageSize, const std::filesystem::path& directory);

}  // namespace avatar::calibrate
