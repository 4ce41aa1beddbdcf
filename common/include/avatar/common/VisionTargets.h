#pragma once
/// @file VisionTargets.h
/// VisionTargets: everything one analysis iteration tells the outside world
/// (thesis 4.2.3). The only way results leave AVATAR; produced by analyze,
/// recorded by acquire's session log, served by TAUNet.

#include <avatar/common/StereoImagePair.h>

#include <opencv2/core/types.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace avatar {

/// Bit flags of one target.
enum TargetFlag : std::uint32_t {
    kTargetStereo = 1u << 0,        ///< matched in both images; 3-D position valid
    kTargetLeftOnly = 1u << 1,      ///< seen in the left image only (occluded or out of view)
    kTargetRightOnly = 1u << 2,     ///< seen in the right image only
    kTargetAtBorder = 1u << 3,      ///< feature touches the image or search-window border
    kTargetShapeCorrected = 1u << 4 ///< position corrected for the silhouette bias of a known shape
};

/// The names of the set flags, comma-separated in bit order
/// ("stereo,border"); "-" when none is set.
std::string targetFlagsText(std::uint32_t flags);

/// One target found in an image pair.
struct VisionTarget {
    std::string type;            ///< the TargetType name, e.g. "sample"
    std::uint32_t flags{0};      ///< TargetFlag bits
    /// Position in the left camera (vision) frame, mm; set when kTargetStereo.
    std::optional<cv::Point3d> positionVisionMm;
    /// Position in the manipulator base frame, mm; set when stereo and a registration is known.
    std::optional<cv::Point3d> positionBaseMm;
    std::optional<cv::Point2d> centroidLeftPx;   ///< set when seen in the left image
    std::optional<cv::Point2d> centroidRightPx;  ///< set when seen in the right image
    double areaLeftPx{0.0};
    double areaRightPx{0.0};
    double matchError{0.0};      ///< shape difference of the match (0 for single-image targets)

    bool operator==(const VisionTarget& o) const {
        return type == o.type && flags == o.flags && positionVisionMm == o.positionVisionMm &&
               positionBaseMm == o.positionBaseMm && centroidLeftPx == o.centroidLeftPx &&
               centroidRightPx == o.centroidRightPx && areaLeftPx == o.areaLeftPx &&
               areaRightPx == o.areaRightPx && matchError == o.matchError;
    }
};

/// Time taken by one analysis stage.
struct StageTiming {
    std::string stage;
    double milliseconds{0.0};
    bool operator==(const StageTiming& o) const {
        return stage == o.stage && milliseconds == o.milliseconds;
    }
};

/// Visibility verdict of an iteration (thesis 3.6.1).
enum class Visibility { Unknown, Good, Poor };

/// The result of analysing one stereo pair.
struct VisionTargets {
    std::uint64_t iteration{0};   ///< vision iteration counter
    AcquisitionId acquisition;    ///< the pair the result belongs to
    std::vector<VisionTarget> targets;
    std::vector<StageTiming> timings;
    Visibility visibility{Visibility::Unknown};
    std::string visibilityReason; ///< e.g. "left: contrast 0.02 below 0.05"

    bool operator==(const VisionTargets& o) const {
        return iteration == o.iteration && acquisition == o.acquisition && targets == o.targets &&
               timings == o.timings && visibility == o.visibility && visibilityReason == o.visibilityReason;
    }
    bool operator!=(const VisionTargets& o) const { return !(*this == o); }

    /// The targets of one type, in the order found.
    std::vector<VisionTarget> ofType(const std::string& type) const {
        std::vector<VisionTarget> out;
        for (const auto& t : targets)
            if (t.type == type) out.push_back(t);
        return out;
    }
};

}  // namespace avatar
