#pragma once
/// @file StereoCalibration.h
/// Stereo calibration from checkerboard pairs (thesis 3.1.1, Appendix A,
/// Tables 6-1 and 6-4): corner detection with sub-pixel refinement, each
/// camera's intrinsics, then the stereo extrinsics, through OpenCV's
/// calibration functions; standard errors of every parameter, per-pair and
/// overall reprojection errors and the epipolar error.
///
/// Conventions are the configuration's (StereoSystemConfig): the Bouguet /
/// OpenCV plumb-bob model, X_right = R(om) X_left + T, pixel (0, 0) the centre
/// of the top-left pixel (OpenCV's corner coordinates are already so).

#include <avatar/config/StereoSystemConfig.h>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include <optional>
#include <string>
#include <vector>

namespace avatar {

/// A planar checkerboard: its inner corners (columns x rows) and square size.
struct BoardGeometry {
    cv::Size innerCorners{9, 6};
    double squareMm{25.0};
    /// The corners in the board's own frame (z = 0), row by row, x fastest:
    /// the order findBoardCorners() returns them in.
    std::vector<cv::Point3f> objectPoints() const;
    /// Throws avatar::InvalidArgument unless both counts are >= 2 and the square size > 0.
    void validate() const;
};

/// The inner corners of @p board in @p image (8- or 16-bit, 1 or 3 channels;
/// 16-bit data is scaled from @p bitDepth), refined to sub-pixel accuracy
/// (cv::cornerSubPix, a window of a third of the square's size in pixels, at
/// most 11 x 11). std::nullopt when the whole board is not found.
std::optional<std::vector<cv::Point2f>> findBoardCorners(const cv::Mat& image, cv::Size innerCorners,
                                                         int bitDepth = 8);

/// The corners found in one synchronized pair.
struct CalibrationPair {
    std::string name;  ///< for reports: the left file's name
    std::vector<cv::Point2f> left;
    std::vector<cv::Point2f> right;
};

/// Whether the stereo step keeps each camera's own calibration or refines
/// everything together.
enum class StereoStrategy {
    Best,            ///< try both on held-back pairs and keep the one with the lower error
    FixIntrinsics,   ///< cv::stereoCalibrate with CALIB_FIX_INTRINSIC
    RefineAll        ///< cv::stereoCalibrate with CALIB_USE_INTRINSIC_GUESS
};
const char* toString(StereoStrategy strategy);

struct StereoCalibrationOptions {
    StereoStrategy strategy{StereoStrategy::Best};
    /// Estimate k3 (kc5). Off by default, as the Bouguet toolbox: with a few
    /// views it trades off against k1 and k2 and extrapolates badly.
    bool estimateK3{false};
    /// Share of the pairs held back to choose the strategy (at least one pair;
    /// the choice is skipped with fewer than 6 pairs, and then RefineAll is used).
    double holdOutFraction{0.25};
};

/// One camera's result.
struct CameraCalibration {
    CameraIntrinsics intrinsics;
    IntrinsicsUncertainty uncertainty;  ///< standard errors
    double rmsPx{0.0};                  ///< reprojection RMS over its views
    std::vector<double> perViewRmsPx;   ///< in the order of the pairs
};

struct StereoCalibration {
    StereoSystemConfig stereo;      ///< with .uncertainty set; no registration
    CameraCalibration left;
    CameraCalibration right;
    double rmsPx{0.0};              ///< stereo reprojection RMS over both cameras
    double leftRmsPx{0.0};          ///< of the stereo solution, left corners only
    double rightRmsPx{0.0};         ///< and right corners only
    std::vector<double> perPairRmsPx;  ///< both cameras, per pair
    std::vector<double> perPairLeftRmsPx;
    std::vector<double> perPairRightRmsPx;
    double epipolarRmsPx{0.0};      ///< distance of each corner to its epipolar line, both ways, undistorted
    StereoStrategy strategy{StereoStrategy::RefineAll};  ///< the one used
    /// The held-back comparison (when it was made): RMS of the other camera's
    /// corners predicted through the stereo calibration, px.
    std::optional<double> heldOutFixedPx;
    std::optional<double> heldOutRefinedPx;
    std::vector<std::string> heldOutPairs;
};

/// Calibrates from at least 3 pairs (each with every corner of @p board in
/// both images) of @p imageSize. Throws avatar::InvalidArgument for too few
/// pairs, corner lists of the wrong length or an image size that is empty.
StereoCalibration calibrateStereo(const std::vector<CalibrationPair>& pairs, const BoardGeometry& board,
                                  cv::Size imageSize, const StereoCalibrationOptions& options = {});

/// RMS distance (px, undistorted pixels) of each pair's corners to the
/// epipolar line of the other image's corner, both ways.
double epipolarRmsPx(const StereoSystemConfig& stereo, const std::vector<CalibrationPair>& pairs);

}  // namespace avatar
