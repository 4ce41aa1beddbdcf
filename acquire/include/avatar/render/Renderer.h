#pragma once
/// @file Renderer.h
/// Renders a stereo pair of a Scene with exact ground truth, using the camera
/// model of avatar::analyze (Bouguet plumb bob with skew) by inverse mapping:
/// every sample of a pixel is turned into its exact undistorted ray (Newton,
/// 1e-12) and traced into the scene.
///
/// Anti-aliasing: each pixel is N x N supersampled on a regular grid. In the
/// adaptive mode (default) a pixel is supersampled only when its centre and
/// four corners do not all see the same surface (object, part, checker square
/// and set of targets behind); otherwise the centre sample stands for the
/// pixel. Silhouette centroids and areas are coverage-weighted sums over the
/// samples, so they are as exact as the supersampling.

#include <avatar/common/ImageFormat.h>
#include <avatar/common/StereoImagePair.h>
#include <avatar/config/CameraHardwareConfig.h>
#include <avatar/config/StereoSystemConfig.h>
#include <avatar/render/Scene.h>

#include <opencv2/core/types.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace avatar::render {

/// What the simulated cameras deliver.
struct SensorFormat {
    int width{1280};
    int height{960};
    int bitDepth{16};                       ///< 1..16; <= 8 gives 8-bit images
    PixelFormat format{PixelFormat::Bayer}; ///< Bayer, Bgr or Mono (panchromatic: the mean of the bands)
    BayerPattern bayerPattern{BayerPattern::BG};
    ByteOrder fileByteOrder{ByteOrder::Little};  ///< of the raw files (images in memory are host order)
};

/// The sensor format of a camera hardware configuration (size, depth, Bayer
/// pattern; endianSwap selects big-endian raw files).
SensorFormat sensorFormatFrom(const CameraHardwareConfig& camera);

struct RenderOptions {
    SensorFormat sensor;
    int supersampling{4};   ///< N: N x N samples per (edge) pixel, 1..16
    bool adaptive{true};    ///< supersample only pixels whose surface changes
    std::uint64_t seed{1};  ///< noise seed (std::mt19937_64)
    bool noise{true};       ///< false: ignore the scene's read and shot noise

    /// Throws avatar::InvalidArgument naming the bad field.
    void validate() const;
};

enum class TargetVisibility {
    Full,     ///< entirely in the image and unoccluded (it may touch the border)
    Partial,  ///< cut by the image border or partly hidden behind something
    None      ///< not seen at all
};
std::string_view toString(TargetVisibility visibility);

/// One target as one camera sees it. Pixel coordinates: integer = pixel centre.
struct TargetView {
    /// The target's 3-D centre projected (distorted); nullopt behind the camera.
    std::optional<cv::Point2d> projectedCentrePx;
    /// Coverage-weighted centroid of the visible silhouette; nullopt when not seen.
    std::optional<cv::Point2d> silhouetteCentroidPx;
    double areaPx{0.0};  ///< visible silhouette area in pixels (coverage sum)
    /// Silhouette area inside the image with nothing in front (>= areaPx).
    double potentialAreaPx{0.0};
    TargetVisibility visibility{TargetVisibility::None};
    bool occluded{false};  ///< part of it is hidden by something nearer
    bool atBorder{false};  ///< its silhouette reaches the outermost pixel row or column
    /// Part of its silhouette lies outside the image (beyond the outer pixel
    /// edges): cut by the border, not merely touching it.
    bool cut{false};
    /// The silhouette's area beyond the image's outer pixel edges, measured
    /// within 2 px of them (quarter-pixel samples, the corners' squares left
    /// out); infinity when it reaches farther; 0 when not cut.
    double outsideAreaPx{0.0};
    /// 1 - areaPx / potentialAreaPx: the part of its in-image silhouette that is hidden.
    double hiddenFraction() const { return potentialAreaPx > 0.0 ? 1.0 - areaPx / potentialAreaPx : 0.0; }
};

struct TargetTruth {
    std::string name;
    std::string type;
    Shape shape{Shape::Sphere};
    cv::Point3d centreLeftMm;
    cv::Point3d centreRightMm;
    std::optional<cv::Point3d> centreBaseMm;  ///< when a registration is known
    TargetView left;
    TargetView right;
};

/// The inner corners of a checkerboard, row by row (x fastest).
struct CheckerboardTruth {
    int cornersX{0};
    int cornersY{0};
    double squareMm{0.0};
    std::vector<cv::Point3d> cornersLeftMm;
    std::vector<cv::Point2d> cornersLeftPx;   ///< exact distorted projections
    std::vector<cv::Point2d> cornersRightPx;
};

/// Counts and timings of one render.
struct RenderStats {
    double milliseconds{0.0};
    std::uint64_t pixels{0};               ///< both images
    std::uint64_t supersampledPixels{0};   ///< pixels that got N x N samples
    std::uint64_t rays{0};
    std::uint64_t raysWithoutInverse{0};   ///< samples outside the invertible distortion
};

struct GroundTruth {
    std::string sceneName;
    std::uint64_t seed{0};
    int width{0};
    int height{0};
    int supersampling{0};
    bool adaptive{true};
    std::optional<RigidTransform> baseTVision;  ///< the registration used, if any
    std::vector<TargetTruth> targets;           ///< scene targets, then arm markers
    std::optional<CheckerboardTruth> checkerboard;
    RenderStats stats;

    /// The target of that name; throws avatar::InvalidArgument if there is none.
    const TargetTruth& target(const std::string& name) const;
};

struct RenderResult {
    StereoImagePair pair;
    GroundTruth truth;
};

/// Renders @p scene seen by @p stereo. Throws avatar::InvalidArgument for bad
/// options, SceneError for an invalid scene and for an arm marker without any
/// registration. Deterministic for given inputs (independent of thread count).
RenderResult render(const Scene& scene, const StereoSystemConfig& stereo,
                    const RenderOptions& options);

/// Ground truth as XML (see docs/tools/avatar-render.md).
std::string writeGroundTruthString(const GroundTruth& truth);
void writeGroundTruthFile(const GroundTruth& truth, const std::filesystem::path& path);

/// The files written for one rendered pair.
struct WrittenFiles {
    std::filesystem::path leftRaw, rightRaw, leftPreview, rightPreview, groundTruth;
};

/// Writes into @p directory the pair as raw files named by RawImageName (in
/// @p sensor's byte order), 8-bit PNG previews L_<group>_<member>.png and
/// R_<group>_<member>.png (unless @p previews is false) and the ground truth
/// <group>_<member>_truth.xml (numbers with 5 digits). Throws avatar::IoError.
WrittenFiles writeRender(const RenderResult& result, const SensorFormat& sensor,
                         const std::filesystem::path& directory, std::uint32_t group,
                         std::uint32_t member, bool previews = true);

}  // namespace avatar::render
